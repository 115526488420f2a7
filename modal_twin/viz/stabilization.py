"""Stabilization diagram: poles per model order, marked by what they keep stable.

Plain arrays in, a matplotlib Figure out (:func:`stabilization_figure`); the report code
reuses it. :func:`save_stabilization` writes it.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.viz._figure import new_figure, save_figure

__all__ = ["save_stabilization", "stabilization_figure"]


def stabilization_figure(orders: Sequence[int], f_hz: Sequence[FloatArray],
                         stable: Sequence[np.ndarray], *, selected_hz: FloatArray | None
                         = None, band_hz: tuple[float, float] | None = None,
                         spectrum: tuple[FloatArray, FloatArray] | None = None,
                         title: str = "stabilization diagram") -> Any:
    """Poles (x = frequency, y = model order): stable filled, others hollow.

    Parameters
    ----------
    orders : sequence of int
        Model orders, one per row.
    f_hz : sequence of arrays
        Pole frequencies per order, Hz.
    stable : sequence of bool arrays
        Fully stable poles per order (same shapes as ``f_hz``).
    selected_hz : array, optional
        Selected modes, drawn as vertical lines.
    band_hz : (float, float), optional
        x range.
    spectrum : (f_hz, psd), optional
        A spectrum drawn on a second (log) axis behind the poles.
    """
    fig, ax = new_figure((8.0, 5.0))
    for o, f, s in zip(orders, f_hz, stable, strict=True):
        s = np.asarray(s, dtype=bool)
        ax.plot(f[~s], np.full((~s).sum(), o), "o", mfc="none", mec="0.6", ms=3)
        ax.plot(f[s], np.full(s.sum(), o), "o", color="C0", ms=3.5)
    for fm in [] if selected_hz is None else selected_hz:
        ax.axvline(fm, color="C3", lw=0.8, alpha=0.7)
    if spectrum is not None:
        ax2 = ax.twinx()
        ax2.semilogy(spectrum[0], spectrum[1], color="0.4", lw=0.7)
        ax2.set_ylabel("output PSD (sum)")
    if band_hz is not None:
        ax.set_xlim(*band_hz)
    ax.set_xlabel("frequency, Hz")
    ax.set_ylabel("model order")
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    return fig


def save_stabilization(path: str | Path, *args: Any, **kwargs: Any) -> Path:
    """Draw :func:`stabilization_figure` and save it to ``path``."""
    return save_figure(stabilization_figure(*args, **kwargs), path)
