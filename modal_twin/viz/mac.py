"""MAC / AutoMAC matrix (Eq. (6) of [002]) as a heat map with its values."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import ArrayLike

from modal_twin.errors import ShapeError
from modal_twin.viz._figure import new_figure, short_labels

__all__ = ["plot_mac"]

_ANNOTATE_MAX = 16  # cells per side up to which the values are written in the cells


def plot_mac(mac: ArrayLike, labels_row: Sequence[str], labels_col: Sequence[str], *,
             title: str = "MAC") -> Figure:
    """Plot a MAC matrix (rows: e.g. identified modes, columns: model modes).

    Parameters
    ----------
    mac : (n_row, n_col) array_like
        Values in [0, 1].
    labels_row, labels_col : sequence of str
        One label per row / column (e.g. ``"1: 0.45 Hz"``).
    title : str

    Returns
    -------
    matplotlib.figure.Figure
        The values are written in the cells up to 16 x 16 (texts of the axes).

    Raises
    ------
    ShapeError
        ``mac`` not 2-D, or label counts that do not match its shape.
    """
    M = np.asarray(mac, dtype=float)
    if M.ndim != 2 or len(labels_row) != M.shape[0] or len(labels_col) != M.shape[1]:
        msg = (f"mac: expected (n_row, n_col) = ({len(labels_row)}, {len(labels_col)}) "
               f"from the labels, got {M.shape}")
        raise ShapeError(msg)
    side = 2.5 + 0.45 * max(M.shape)
    fig = new_figure(min(side + 1.5, 16.0), min(side, 14.0))
    ax = fig.add_subplot()
    im = ax.imshow(M, vmin=0.0, vmax=1.0, cmap="viridis", aspect="equal")
    ax.set_xticks(np.arange(M.shape[1]), short_labels(labels_col), rotation=60, ha="right",
                  fontsize=8)
    ax.set_yticks(np.arange(M.shape[0]), short_labels(labels_row), fontsize=8)
    if max(M.shape) <= _ANNOTATE_MAX:
        for (i, j), v in np.ndenumerate(M):
            ax.text(j, i, f"{v:.2f}", ha="center", va="center", fontsize=7,
                    color="k" if v > 0.6 else "w")
    fig.colorbar(im, ax=ax, label="MAC", shrink=0.8)
    ax.set_title(title)
    return fig
