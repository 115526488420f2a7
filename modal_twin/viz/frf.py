"""FRF overlay, measured vs model: small multiples, one panel per channel (magnitude)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import ArrayLike

from modal_twin.errors import ShapeError
from modal_twin.viz._figure import new_figure

__all__ = ["plot_frf_overlay"]


def plot_frf_overlay(f_hz: ArrayLike, H_measured: ArrayLike, channel_names: Sequence[str],
                     H_model: ArrayLike | None = None, *, max_panels: int = 24,
                     ncols: int = 4, unit: str = "", title: str = "FRF") -> Figure:
    """Magnitude of measured (and model) FRFs, one small panel per output channel.

    Parameters
    ----------
    f_hz : (n_f,) array_like
        Frequency lines, Hz.
    H_measured : (n_ch, n_f) complex array_like
        Measured FRFs (one input), e.g. H1.
    channel_names : sequence of str
        One name per row.
    H_model : (n_ch, n_f) complex array_like, optional
        Model FRFs on the same lines.
    max_panels : int
        With more channels, those whose model misfit (or magnitude) is largest are shown.
    ncols : int
        Panels per row.
    unit : str
        Unit of the FRF (axis label).
    title : str

    Returns
    -------
    matplotlib.figure.Figure
        One axes per shown channel, titled with its name; measured line first.

    Raises
    ------
    ShapeError
        Shapes that do not agree.
    """
    f = np.asarray(f_hz, dtype=float)
    Hm = np.atleast_2d(np.asarray(H_measured))
    if Hm.shape != (len(channel_names), f.size):
        msg = f"H_measured: expected ({len(channel_names)}, {f.size}), got {Hm.shape}"
        raise ShapeError(msg)
    Hp = None if H_model is None else np.atleast_2d(np.asarray(H_model))
    if Hp is not None and Hp.shape != Hm.shape:
        msg = f"H_model: expected {Hm.shape} like H_measured, got {Hp.shape}"
        raise ShapeError(msg)
    if Hp is not None:
        score = np.mean(np.abs(np.log10((np.abs(Hp) + 1e-300) / (np.abs(Hm) + 1e-300))), axis=1)
    else:
        score = np.max(np.abs(Hm), axis=1)
    show = np.sort(np.argsort(-score)[:max_panels])
    ncols = max(1, min(ncols, show.size))
    nrows = int(np.ceil(show.size / ncols))
    fig = new_figure(3.0 * ncols + 0.5, 2.2 * nrows + 0.8)
    axes = fig.subplots(nrows, ncols, squeeze=False, sharex=True)
    for k, ax in enumerate(axes.flat):
        if k >= show.size:
            ax.set_visible(False)
            continue
        i = int(show[k])
        ax.semilogy(f, np.abs(Hm[i]), color="k", lw=0.9, label="measured")
        if Hp is not None:
            ax.semilogy(f, np.abs(Hp[i]), color="tab:red", lw=0.9, ls="--", label="model")
        ax.set_title(channel_names[i], fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(True, which="both", alpha=0.25)
    for ax in axes[-1]:
        ax.set_xlabel("frequency, Hz", fontsize=8)
    axes[0, 0].set_ylabel(f"|H| {unit}".strip(), fontsize=8)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside upper right", fontsize=8, frameon=False)
    more = f" ({show.size} of {Hm.shape[0]} channels, largest misfit first)" \
        if show.size < Hm.shape[0] else ""
    fig.suptitle(title + more, fontsize=10)
    return fig
