"""MAC matrix figure (auto-MAC of one mode set, or MAC between two).

Plain arrays in, a matplotlib Figure out (:func:`mac_figure`); :func:`save_mac` writes it.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.viz._figure import new_figure, save_figure

__all__ = ["mac_figure", "save_mac"]


def mac_figure(M: FloatArray, row_labels: Sequence[str], col_labels: Sequence[str], *,
               title: str = "MAC") -> Any:
    """A MAC matrix as a heat map with its values written in the cells.

    Parameters
    ----------
    M : ndarray, shape (n_rows, n_cols)
        MAC values in [0, 1].
    row_labels, col_labels : sequences of str
        Labels (e.g. frequencies) of the rows and columns.
    """
    M = np.asarray(M, dtype=float)
    n_r, n_c = M.shape
    fig, ax = new_figure((1.2 + 0.55 * max(n_c, 3), 1.0 + 0.5 * max(n_r, 3)))
    im = ax.imshow(M, vmin=0.0, vmax=1.0, cmap="Blues")
    for r in range(n_r):
        for c in range(n_c):
            ax.text(c, r, f"{M[r, c]:.2f}", ha="center", va="center", fontsize=7,
                    color="white" if M[r, c] > 0.6 else "black")
    ax.set_xticks(range(n_c), list(col_labels), rotation=45, fontsize=7)
    ax.set_yticks(range(n_r), list(row_labels), fontsize=7)
    ax.set_title(title)
    fig.colorbar(im, ax=ax, fraction=0.046)
    return fig


def save_mac(path: str | Path, *args: Any, **kwargs: Any) -> Path:
    """Draw :func:`mac_figure` and save it to ``path``."""
    return save_figure(mac_figure(*args, **kwargs), path)
