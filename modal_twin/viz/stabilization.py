"""Stabilization diagram: poles over model orders, marked by the stability rule of [004].

Stable (frequency, damping and MAC within the tolerances of Sec. 3 of [004]) as filled
dots, stable in frequency only as open circles, the rest as small grey points; selected
modes as vertical lines. Legend outside the axes, so that it never covers poles.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.figure import Figure

from modal_twin.viz._figure import new_figure

__all__ = ["plot_stabilization"]


def plot_stabilization(diagram: Any, *, selected_f_hz: Any = None,
                       f_max_hz: float | None = None, title: str = "",
                       spectrum: tuple[Any, Any] | None = None) -> Figure:
    """Plot a :class:`~modal_twin.identification.modal_model.StabilizationDiagram`.

    Parameters
    ----------
    diagram : StabilizationDiagram
        Poles per order with their ``stable_f`` and ``stable`` flags.
    selected_f_hz : (n_modes,) float array, optional
        Frequencies of the selected modes (vertical lines), Hz.
    f_max_hz : float, optional
        Upper frequency of the axis (default: highest pole).
    title : str
        Figure title (default: the method's name).
    spectrum : (f_hz, s) arrays, optional
        Singular values of the output PSD matrix (``s`` (k, n_f)), drawn in grey behind
        the poles on a log axis of their own (right).

    Returns
    -------
    matplotlib.figure.Figure
        One axes; its collections are, in order: unstable, stable in frequency, stable.
    """
    fig = new_figure(9.0, 5.0)
    ax = fig.add_subplot()
    groups: dict[str, tuple[list[float], list[float]]] = {
        k: ([], []) for k in ("other", "f", "stable")}
    for ps, sf, st in zip(diagram.poles, diagram.stable_f, diagram.stable, strict=True):
        f = np.asarray(ps.f_hz, dtype=float)
        kind = np.where(np.asarray(st), "stable", np.where(np.asarray(sf), "f", "other"))
        for key in groups:
            sel = f[kind == key]
            groups[key][0].extend(sel)
            groups[key][1].extend([ps.order] * sel.size)
    ax.scatter(*groups["other"], s=4, c="0.75", label="new / unstable", zorder=1)
    ax.scatter(*groups["f"], s=18, facecolors="none", edgecolors="tab:blue",
               label=f"stable f ({100 * diagram.rel_tol_f:g} %)", zorder=2)
    ax.scatter(*groups["stable"], s=16, c="tab:red",
               label=f"stable f, zeta, MAC > {diagram.mac_min:g}", zorder=3)
    for k, f in enumerate(np.atleast_1d(selected_f_hz) if selected_f_hz is not None else []):
        ax.axvline(float(f), color="k", lw=0.8, ls="--",
                   label="selected mode" if k == 0 else None, zorder=0)
    all_f = groups["other"][0] + groups["f"][0] + groups["stable"][0]
    top = f_max_hz if f_max_hz is not None else (max(all_f) * 1.05 if all_f else 1.0)
    ax.set_xlim(0.0, top)
    ax.set_xlabel("frequency, Hz")
    ax.set_ylabel("model order")
    ax.grid(True, alpha=0.3)
    ax.set_title(title or f"stabilization diagram ({diagram.method})")
    if spectrum is not None:
        f_s, sv = np.asarray(spectrum[0]), np.atleast_2d(np.asarray(spectrum[1]))
        sel = (f_s > 0) & (f_s <= top)
        ax2 = ax.twinx()
        for k, row in enumerate(sv):
            ax2.semilogy(f_s[sel], row[sel], color="0.45" if k == 0 else "0.75", lw=0.8,
                         zorder=0)
        ax2.set_ylabel("singular values of the PSD matrix")
        ax.set_zorder(ax2.get_zorder() + 1)
        ax.patch.set_visible(False)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    return fig
