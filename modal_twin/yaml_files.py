"""Read a YAML configuration file with errors that name the file.

For syntax errors they also name the line and column.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from modal_twin.errors import ConfigError
from modal_twin.paths import open_regular

__all__ = ["read_yaml"]


def read_yaml(path: str | Path, what: str = "file", *, mapping: bool = True) -> Any:
    """Return the parsed contents of ``path``.

    Raises
    ------
    ConfigError
        Missing or unreadable file, not a regular file (a FIFO is refused, never waited
        on), malformed YAML (with its line and column), or, with ``mapping``, a document
        that is not a mapping.
    """
    p = Path(path)
    with open_regular(p, what) as fh:  # a FIFO named here is refused, never waited on
        try:
            text = fh.read().decode("utf-8")
        except OSError as err:
            msg = f"{p}: cannot read {what} ({err.strerror})"
            raise ConfigError(msg) from err
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(err, "problem", None) or str(err)
        msg = f"{p}: malformed YAML{where}: {problem}"
        raise ConfigError(msg) from err
    if mapping and not isinstance(doc, dict):
        msg = f"{p}: key '<top>': expected a mapping, got {type(doc).__name__}"
        raise ConfigError(msg)
    return doc
