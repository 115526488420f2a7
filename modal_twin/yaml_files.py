"""Read YAML and JSON configuration files, bounded, with errors that name the file.

For YAML syntax errors they also name the line and column. Every file is opened without
blocking and refused unless it is a regular file (:func:`modal_twin.paths.open_regular`),
then refused if larger than :data:`~modal_twin.validation.TEXT_FILE_MAX_BYTES` (``fstat`` of
the open file, before it is read). A YAML document is parsed to events first (memory
bounded by its nesting) and refused past :data:`~modal_twin.validation.YAML_MAX_NODES`
nodes, :data:`~modal_twin.validation.YAML_MAX_ALIASES` aliases or
:data:`~modal_twin.validation.YAML_MAX_DEPTH` levels; then composed, and refused if its
aliases expand it past the same limits (a "billion laughs" document) or refer to
themselves, before any Python object is constructed.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import yaml

from modal_twin.errors import ConfigError
from modal_twin.paths import open_regular
from modal_twin.validation import (
    TEXT_FILE_MAX_BYTES,
    YAML_MAX_ALIASES,
    YAML_MAX_DEPTH,
    YAML_MAX_NODES,
)

__all__ = ["read_text", "read_yaml"]

_LOADER: Any = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
"""libyaml's safe loader where PyYAML was built with it (about five times faster)."""


def read_text(path: str | Path, what: str = "file", *,
              max_bytes: int = TEXT_FILE_MAX_BYTES) -> str:
    """Return the UTF-8 text of the regular file ``path`` of at most ``max_bytes``.

    Raises
    ------
    ConfigError
        Missing or unreadable file, not a regular file (a FIFO is refused, never waited
        on), or larger than ``max_bytes`` (checked before reading).
    UnicodeDecodeError
        Not UTF-8 text.
    """
    p = Path(path)
    with open_regular(p, what) as fh:  # a FIFO named here is refused, never waited on
        size = os.fstat(fh.fileno()).st_size
        if size > max_bytes:
            msg = (f"{p}: a {what} of {size / 2**20:.0f} MiB; expected at most "
                   f"{max_bytes / 2**20:.0f} MiB (TEXT_FILE_MAX_BYTES)")
            raise ConfigError(msg)
        try:
            data = fh.read(size + 1)  # a buffer of the file's size, not of the limit
            if len(data) > size:  # grown since fstat: the rest, up to the limit
                data += fh.read(max_bytes + 1 - len(data))
        except OSError as err:
            msg = f"{p}: cannot read {what} ({err.strerror})"
            raise ConfigError(msg) from err
    if len(data) > max_bytes:  # grew while read
        msg = f"{p}: a {what} larger than {max_bytes / 2**20:.0f} MiB (TEXT_FILE_MAX_BYTES)"
        raise ConfigError(msg)
    return data.decode("utf-8")


def _refuse(p: Path, what: str, found: str) -> None:
    msg = f"{p}: a YAML {what} with {found}"
    raise ConfigError(msg)


def _count_events(text: str, p: Path, what: str) -> None:
    """Refuse a document of too many nodes, aliases or levels, from its events alone."""
    nodes = aliases = depth = 0
    for ev in yaml.parse(text, Loader=_LOADER):
        if isinstance(ev, yaml.AliasEvent):
            aliases += 1
            if aliases > YAML_MAX_ALIASES:
                _refuse(p, what, f"more than {YAML_MAX_ALIASES} aliases (YAML_MAX_ALIASES)")
        elif isinstance(ev, yaml.NodeEvent):
            nodes += 1
            if nodes > YAML_MAX_NODES:
                _refuse(p, what, f"more than {YAML_MAX_NODES} nodes (YAML_MAX_NODES)")
            if isinstance(ev, yaml.CollectionStartEvent):
                depth += 1
                if depth > YAML_MAX_DEPTH:
                    _refuse(p, what,
                            f"more than {YAML_MAX_DEPTH} levels of nesting (YAML_MAX_DEPTH)")
        elif isinstance(ev, yaml.CollectionEndEvent):
            depth -= 1


def _children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    if isinstance(node, yaml.MappingNode):
        return [n for kv in node.value for n in kv]
    return []


def _check_expanded(root: yaml.Node, p: Path, what: str) -> None:
    """Refuse a composed document whose aliases expand it past the limits, or loop.

    Nodes an alias shares are counted once per use (what a reader walking the constructed
    document visits), each composed node visited once (post-order, memoised).
    """
    size: dict[int, int] = {}
    deep: dict[int, int] = {}
    open_: set[int] = set()  # the current path: an alias to one of them is a loop
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    while stack:
        node, done = stack.pop()
        k = id(node)
        if done:
            kids = _children(node)
            size[k] = 1 + sum(size[id(c)] for c in kids)
            deep[k] = 1 + max((deep[id(c)] for c in kids), default=0)
            open_.discard(k)
            if size[k] > YAML_MAX_NODES:
                _refuse(p, what, f"aliases that expand it to more than {YAML_MAX_NODES} "
                        "nodes (YAML_MAX_NODES)")
            if deep[k] > YAML_MAX_DEPTH:
                _refuse(p, what, f"aliases that nest it more than {YAML_MAX_DEPTH} levels "
                        "(YAML_MAX_DEPTH)")
            continue
        if k in size:
            continue
        if k in open_:
            _refuse(p, what, "an alias inside the node it names (a loop)")
        open_.add(k)
        stack.append((node, True))
        stack += [(c, False) for c in _children(node)]


def read_yaml(path: str | Path, what: str = "file", *, mapping: bool = True) -> Any:
    """Return the parsed contents of ``path`` (bounded: module docstring).

    Raises
    ------
    ConfigError
        Missing or unreadable file, not a regular file (a FIFO is refused, never waited
        on), larger than :data:`~modal_twin.validation.TEXT_FILE_MAX_BYTES`, too many
        nodes, aliases or levels (expanded), an alias loop, malformed YAML (with its line
        and column), or, with ``mapping``, a document that is not a mapping.
    """
    p = Path(path)
    text = read_text(p, what)
    try:
        _count_events(text, p, what)
        root = yaml.compose(text, Loader=_LOADER)
        doc = None
        if root is not None:
            _check_expanded(root, p, what)
            loader = _LOADER("")
            try:
                doc = loader.construct_document(root)
            finally:
                loader.dispose()
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
