"""Device hysteresis loops, measured vs model.

Force against drift, one panel per device and direction (the picture of Figs. 10-12 of [004]).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from matplotlib.figure import Figure

from modal_twin._types import FloatArray
from modal_twin.viz._figure import new_figure

__all__ = ["plot_hysteresis"]

Loop = tuple[FloatArray, FloatArray]


def plot_hysteresis(measured: Mapping[str, Loop], model: Mapping[str, Loop] | None = None,
                    *, max_points: int = 6000, title: str = "device hysteresis") -> Figure:
    """Force-drift loops.

    Parameters
    ----------
    measured : mapping name -> (drift m, force N)
        One loop per panel, e.g. ``{"ESB1 x": (u, f)}``.
    model : mapping name -> (drift m, force N), optional
        Model loops under the same names (drawn dashed, red).
    max_points : int
        Samples per line (evenly thinned).
    title : str

    Returns
    -------
    matplotlib.figure.Figure
        One axes per name, titled with it; drift in mm, force in kN.
    """
    names = list(measured)
    ncols = min(4, max(1, len(names)))
    nrows = int(np.ceil(len(names) / ncols)) or 1
    fig = new_figure(3.2 * ncols + 0.6, 2.8 * nrows + 0.6)
    axes = fig.subplots(nrows, ncols, squeeze=False)
    for k, ax in enumerate(axes.flat):
        if k >= len(names):
            ax.set_visible(False)
            continue
        nm = names[k]
        for src, style in ((measured, dict(color="k", lw=0.6, label="measured")),
                           (model or {}, dict(color="tab:red", lw=0.8, ls="--",
                                              label="model"))):
            if nm not in src:
                continue
            u, f = (np.asarray(a, dtype=float) for a in src[nm])
            step = max(1, u.size // max_points)
            ax.plot(1e3 * u[::step], 1e-3 * f[::step], **style)
        ax.set_title(nm, fontsize=9)
        ax.set_xlabel("drift, mm", fontsize=8)
        ax.set_ylabel("force, kN", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(True, alpha=0.3)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside upper right", fontsize=8, frameon=False)
    fig.suptitle(title, fontsize=10)
    return fig
