"""Figures without pyplot: an Agg canvas per figure (no global state, no display needed)."""

from __future__ import annotations

import base64
import io
import re
from collections.abc import Sequence
from pathlib import Path

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from modal_twin.paths import atomic_file

__all__ = ["channel_parts", "new_figure", "png_bytes", "png_data_uri", "save_figure"]

_PART = re.compile(r"^(?P<place>[A-Za-z]+\d*)(?:_(?P<mid>.+?))?_(?P<code>[a-z]+)$")
_QUANTITY = {"d": "drift", "f": "force", "v": "velocity", "a": "acceleration"}


def new_figure(width_in: float, height_in: float) -> Figure:
    """Return a figure on its own Agg canvas (constrained layout: labels are never cut)."""
    fig = Figure(figsize=(width_in, height_in), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def png_bytes(fig: Figure, *, dpi: int = 100) -> bytes:
    """PNG encoding of ``fig``."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()


def png_data_uri(fig: Figure, *, dpi: int = 100) -> str:
    """``data:image/png;base64,...`` of ``fig`` (for a self-contained HTML page)."""
    return "data:image/png;base64," + base64.b64encode(png_bytes(fig, dpi=dpi)).decode()


def channel_parts(name: str) -> tuple[str, str, str]:
    """Place, direction and quantity of a channel named ``<place>[_<sensor>]_<code>``.

    ``F0_C1_x`` -> ``("F0", "x", "acceleration")``; ``ESB1_dx`` -> ``("ESB1", "x",
    "drift")``; ``ESB1_fy`` -> ``("ESB1", "y", "force")``. Only a fallback for channels
    without metadata (the channel map's location / direction / quantity come first).
    """
    m = _PART.match(name)
    if m is None:
        return name, "?", "?"
    code = m["code"]
    if len(code) == 2 and code[0] in _QUANTITY and code[1] in "xyz":
        return m["place"], code[1], _QUANTITY[code[0]]
    if code in ("x", "y", "z", "rx", "ry", "rz"):
        return m["place"], code, "acceleration"
    return m["place"], code, "?"


def short_labels(labels: Sequence[str], width: int = 14) -> list[str]:
    """Labels cut to ``width`` characters (with an ellipsis) for crowded axes."""
    return [s if len(s) <= width else s[: width - 1] + "\u2026" for s in labels]


def save_figure(fig: Figure, path: str | Path, *, dpi: int = 110, force: bool = True
                ) -> Path:
    """Write ``fig`` as a PNG at ``path`` (parents made) and return the path.

    The command line's figures are the report's, written to files: to a temporary name and
    renamed (:func:`modal_twin.paths.atomic_file`; an existing file refused unless ``force``).
    """
    out = Path(path)
    data = png_bytes(fig, dpi=dpi)
    with atomic_file(out, force=force) as tmp:
        tmp.write_bytes(data)
    return out
