"""Find configuration files given relative to the working folder, the source tree or the
installed package share (``share/modal_twin``), so scenarios run from anywhere.
"""

from __future__ import annotations

import sys
from pathlib import Path

__all__ = ["resolve_config"]

_ROOTS = (Path(__file__).resolve().parents[1], Path(sys.prefix) / "share" / "modal_twin")


def resolve_config(path: str | Path) -> Path:
    """``path`` itself if it exists, else the first of the source tree / package share that
    holds it; unchanged when none does (the caller's error then names it).
    """
    p = Path(path)
    if p.is_absolute() or p.exists():
        return p
    for root in _ROOTS:
        if (root / p).exists():
            return root / p
    return p
