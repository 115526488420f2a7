"""Writing a finished matplotlib figure as a PNG (one place for the size and dpi)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

__all__ = ["save_png"]


def save_png(fig: Any, out_png: str | Path, *, dpi: int = 110) -> Path:
    """Lay out ``fig``, write it to ``out_png``, close it and return the path."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    out = Path(out_png)
    fig.savefig(out, dpi=dpi)
    plt.close(fig)
    return out
