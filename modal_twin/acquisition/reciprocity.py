r"""Reciprocity check of FRFs: :math:`H_{ij} = H_{ji}` for a linear, passive structure.

Maxwell-Betti reciprocity requires the response at point i to a force at point j to equal
the response at j to a force at i (same quantity and direction). [002] checks it on the
carbody (Fig. 7c). For each pair of driven points with collocated sensors the check gives

* the normalised difference :math:`e = \|H_{ij} - H_{ji}\| / \sqrt{\|H_{ij}\| \|H_{ji}\|}`
  over the frequency lines (0 for perfect reciprocity), and
* the FRF assurance criterion
  :math:`\mathrm{FRAC} = |H_{ij}^H H_{ji}|^2 / (H_{ij}^H H_{ij}\, H_{ji}^H H_{ji})` (1 best).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from modal_twin._types import FloatArray, IntArray
from modal_twin.errors import ShapeError, SignalError

__all__ = ["ReciprocityCheck", "reciprocity"]


@dataclass(frozen=True, slots=True)
class ReciprocityCheck:
    """Result of :func:`reciprocity`.

    Attributes
    ----------
    pairs : ndarray of int, shape (n_pairs, 2)
        Input indices (i, j), i < j, whose FRFs H_ij and H_ji were compared.
    rel_error : ndarray, shape (n_pairs,)
        Normalised difference (dimensionless, 0 = reciprocal).
    frac : ndarray, shape (n_pairs,)
        FRF assurance criterion in [0, 1].
    """

    pairs: IntArray
    rel_error: FloatArray
    frac: FloatArray


def reciprocity(
    H: ArrayLike, collocated: ArrayLike, *, band: slice | None = None
) -> ReciprocityCheck:
    """Compare :math:`H_{ij}` with :math:`H_{ji}` for every pair of inputs.

    Parameters
    ----------
    H : array_like of complex, shape (n_out, n_in, n_f)
        FRF matrix.
    collocated : array_like of int, shape (n_in,)
        ``collocated[k]`` = index of the output measured at input k's point and direction.
    band : slice, optional
        Frequency lines to use (default all finite lines).

    Returns
    -------
    ReciprocityCheck

    Raises
    ------
    ShapeError
        ``H`` not 3-D, fewer than two inputs, or ``collocated`` of the wrong length / range.
    SignalError
        No finite frequency line shared by a pair.

    Examples
    --------
    >>> H = np.ones((2, 2, 4), complex)
    >>> float(reciprocity(H, [0, 1]).rel_error[0])
    0.0
    """
    Ha = np.asarray(H, dtype=np.complex128)
    if Ha.ndim != 3:
        msg = f"H: expected shape (n_out, n_in, n_f), got {Ha.shape}"
        raise ShapeError(msg)
    n_out, n_in, _ = Ha.shape
    col = np.asarray(collocated, dtype=np.int64)
    if n_in < 2 or col.shape != (n_in,) or np.any(col < 0) or np.any(col >= n_out):
        msg = (
            f"collocated: expected {n_in} (>= 2) output indices in [0, {n_out}), "
            f"got {col.tolist()}"
        )
        raise ShapeError(msg)
    Hb = Ha[..., band] if band is not None else Ha
    i, j = np.triu_indices(n_in, k=1)
    a = Hb[col[i], j, :]  # H_{ij}: response at i due to input j
    b = Hb[col[j], i, :]  # H_{ji}
    fin = np.isfinite(a) & np.isfinite(b)
    if not fin.any(axis=1).all():
        msg = "H: expected finite FRF lines for every pair, got none for some pair"
        raise SignalError(msg)
    a = np.where(fin, a, 0.0)
    b = np.where(fin, b, 0.0)
    na = np.linalg.norm(a, axis=1)
    nb = np.linalg.norm(b, axis=1)
    den = np.sqrt(na * nb)
    rel = np.linalg.norm(a - b, axis=1) / np.where(den > 0, den, 1.0)
    frac = np.abs(np.sum(a.conj() * b, axis=1)) ** 2 / np.where(den > 0, (na * nb) ** 2, 1.0)
    return ReciprocityCheck(np.stack([i, j], axis=1), rel, frac)
