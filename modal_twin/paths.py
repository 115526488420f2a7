"""Find configuration files wherever a scenario is run from.

Paths are given relative to the working folder, the source tree or the installed
package share (``share/modal_twin``).
"""

from __future__ import annotations

import sys
from pathlib import Path

__all__ = ["config_roots", "resolve_config"]

_ROOTS = (Path(__file__).resolve().parents[1], Path(sys.prefix) / "share" / "modal_twin")


def resolve_config(path: str | Path) -> Path:
    """Return ``path`` itself if it exists, else the first of source tree / share that holds it.

    Unchanged when none does (the caller's error then names it).
    """
    p = Path(path)
    if p.is_absolute() or p.exists():
        return p
    for root in _ROOTS:
        if (root / p).exists():
            return root / p
    return p


def config_roots() -> tuple[Path, ...]:
    """Return the folders configuration files are looked up in (source tree, package share)."""
    return tuple(r for r in _ROOTS if r.is_dir())
