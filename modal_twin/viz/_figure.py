"""Figure helpers shared by the viz modules: a headless figure and a save helper."""

from __future__ import annotations

from pathlib import Path
from typing import Any

__all__ = ["new_figure", "save_figure"]


def new_figure(figsize: tuple[float, float]) -> tuple[Any, Any]:
    """A matplotlib ``(Figure, Axes)`` drawn without a display (no pyplot state kept)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    return fig, fig.add_subplot(1, 1, 1)


def save_figure(fig: Any, path: str | Path, dpi: int = 110) -> Path:
    """Save ``fig`` as ``path`` (PNG / SVG / PDF by suffix) and return the path."""
    p = Path(path)
    fig.tight_layout()
    fig.savefig(p, dpi=dpi)
    return p
