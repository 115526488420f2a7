"""Writing a finished matplotlib figure as a PNG (one place for the size and dpi)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from modal_twin.paths import atomic_file

__all__ = ["save_png"]


def save_png(fig: Any, out_png: str | Path, *, dpi: int = 110, force: bool = True) -> Path:
    """Lay out ``fig``, write it to ``out_png``, close it and return the path.

    Written to a temporary name and renamed (:func:`modal_twin.paths.atomic_file`; an
    existing file refused unless ``force``).
    """
    import matplotlib.pyplot as plt

    fig.tight_layout()
    out = Path(out_png)
    try:
        with atomic_file(out, force=force) as tmp:
            fig.savefig(tmp, dpi=dpi)
    finally:
        plt.close(fig)
    return out
