r"""Output-only covariance-driven stochastic subspace identification (SSI-cov).

Output correlations :math:`R_k = E[y_{t+k} y_{ref,t}^T] = C A^{k-1} G` fill the block
Toeplitz matrix (Peeters & De Roeck, 1999)

.. math:: T_{1|i} = \begin{bmatrix} R_i & \cdots & R_1 \\ \vdots & & \vdots \\
          R_{2i-1} & \cdots & R_i \end{bmatrix} = \mathcal{O}_i \mathcal{C}_i,

whose SVD :math:`T = U S V^T` (computed as :math:`T T^T = U S^2 U^T`) gives the
observability matrix :math:`U_n S_n^{1/2}` of every order n by truncation: ONE SVD serves
the whole stabilization diagram (only the leading n_max eigenvectors are computed,
:func:`~modal_twin.identification._subspace.leading_eigh`). Poles and shapes follow
from shift invariance (see :mod:`modal_twin.identification._subspace`). The correlations
are exact lag sums computed by segmented FFT (:mod:`modal_twin.identification._lagsums`).

Uncertainty: the record is split into ``n_blocks_std`` blocks; each block's Toeplitz
matrix :math:`T_b` is projected on the common right singular vectors,
:math:`\mathcal{O}_b = T_b V_n S_n^{-1}` (first-order consistent with the full-data basis),
and the spread of the block poles over :math:`\sqrt{n_b}` estimates the standard deviation
of frequency and damping (Reynders et al., 2008, the block "sample covariance" idea).
"""

from __future__ import annotations

import itertools

import numpy as np
import scipy.linalg as sla
from numpy.typing import ArrayLike

from modal_twin._types import FloatArray, IntArray
from modal_twin.errors import OptionError, ShapeError
from modal_twin.identification._lagsums import lag_sums
from modal_twin.identification._subspace import (
    channel_scales,
    check_orders,
    choose_block_rows,
    leading_subspace,
    poles_over_orders,
    std_blocks,
)
from modal_twin.identification.modal_model import PoleSweep
from modal_twin.validation import as_channels, check_positive

__all__ = ["correlations", "ssi_cov"]


def correlations(y: FloatArray, y_ref: FloatArray, n_lags: int) -> FloatArray:
    """Unbiased output correlations :math:`R_k`, k = 0 .. n_lags - 1.

    Returns
    -------
    ndarray, shape (n_lags, l, r)
    """
    n = y.shape[1]
    S = lag_sums(y_ref, y, n_lags, 0, n, n)  # sum_s y_ref,s y_{s+k}^T, exact (FFT)
    R: FloatArray = S.transpose(0, 2, 1) / (n - np.arange(n_lags))[:, None, None]
    return R


def _whole_record(Ys: FloatArray, ref: IntArray | None, Rb: list[FloatArray],
                  edges: FloatArray, n_lags: int) -> FloatArray:
    """Unbiased correlations of the whole record from those of its consecutive blocks.

    ``sum_s y_{s+k} y_ref,s^T`` over the record is the blocks' sums (``R_b (n_b - k)``)
    plus the products whose two samples lie in neighbouring blocks (``k`` per edge).
    """
    n = Ys.shape[1]
    k = np.arange(n_lags)
    S: FloatArray = np.sum([R * (int(b - a) - k)[:, None, None]
                            for R, (a, b) in zip(Rb, itertools.pairwise(edges), strict=True)],
                           axis=0)
    Yr = Ys if ref is None else Ys[ref]
    for e in edges[1:-1]:
        for d in range(1, n_lags):
            S[d] += Ys[:, e:e + d] @ Yr[:, e - d:e].T  # y_{s+d} y_ref,s^T, s in [e-d, e)
    out: FloatArray = S / (n - k)[:, None, None]
    return out


def _toeplitz(R: FloatArray, i: int) -> FloatArray:
    l, r = R.shape[1:]
    T = np.empty((l * i, r * i))
    for a in range(i):
        for b in range(i):
            T[a * l : (a + 1) * l, b * r : (b + 1) * r] = R[i + a - b]
    return T


def ssi_cov(
    y: ArrayLike,
    fs_hz: float,
    *,
    orders: ArrayLike,
    block_rows: int | None = None,
    ref_channels: ArrayLike | None = None,
    n_blocks_std: int = 8,
    f_min_hz: float | None = None,
    scale_groups: ArrayLike | None = None,
) -> PoleSweep:
    """Output-only SSI-cov poles, damping, shapes and their spread for every order.

    Parameters
    ----------
    y : array_like, shape (n_out, n_samples)
        Output responses (any consistent units; each channel is scaled to unit RMS
        internally and the shapes scaled back).
    fs_hz : float
        Sample rate in Hz.
    orders : array_like of int
        Model orders (state dimensions) of the stabilization diagram.
    block_rows : int, optional
        Block rows i of the Toeplitz matrix (2i - 1 lags used). Default
        ``max(ceil((max_order + 1) / n_ref) + 1, 10)``, raised to
        ``ceil(fs_hz / (8 f_min_hz))`` when ``f_min_hz`` is given (capped at
        ``i * n_out <= 1200`` for cost).
    ref_channels : array_like of int, optional
        Reference outputs (default all).
    n_blocks_std : int
        Blocks for the standard deviations (0 or 1 disables them).
    f_min_hz : float, optional
        Lowest natural frequency of interest; sets the default horizon (see
        ``block_rows``). Ignored when ``block_rows`` is given.
    scale_groups : array_like, optional
        A label per channel: the channels of one label share one scale, their joint RMS
        (channels of one quantity keep their relative power, as in the textbook SSI-cov
        of Peeters & De Roeck 1999 and pyOMA2, so a weak, noise-dominated channel is not
        raised to the level of the strong ones). Default: each channel its own scale.

    Returns
    -------
    PoleSweep
        ``method="ssi-cov"``.

    Raises
    ------
    ShapeError
        Too few samples for the lags.
    SignalError
        NaN / Inf or constant channels.
    OptionError
        Orders beyond the Toeplitz rank, bad block rows or reference channels.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> e = rng.standard_normal(20000)
    >>> import scipy.signal as sig
    >>> b, a = sig.iirpeak(2.0, 20.0, fs=50.0)    # narrow resonance at 2 Hz
    >>> sw = ssi_cov(sig.lfilter(b, a, e), 50.0, orders=[2, 4])
    >>> round(float(sw.poles[0].f_hz[0]), 2)
    2.0
    """
    fs = check_positive(fs_hz, "fs_hz")
    Y = as_channels(y, "y", min_samples=4, allow_constant=False)
    l, n = Y.shape
    ref = np.arange(l) if ref_channels is None else np.asarray(ref_channels, dtype=np.int64)
    if ref.ndim != 1 or ref.size == 0 or np.any(ref < 0) or np.any(ref >= l):
        msg = f"ref_channels: expected indices in [0, {l}), got {ref.tolist()}"
        raise OptionError(msg)
    r = ref.size
    i = choose_block_rows(fs, f_min_hz, orders, block_rows, r, l, floor=10)
    nb = std_blocks(n_blocks_std)
    n_lags = 2 * i
    need = 4 * n_lags * max(nb, 1)
    if n < need:
        msg = (
            f"y: expected at least {need} samples for {n_lags} lags"
            + (f" x {nb} std blocks" if nb else "")
            + f", got {n}"
        )
        raise ShapeError(msg)
    o = check_orders(orders, min(l * (i - 1), r * i), f"rank limit of {l * i} x {r * i} Toeplitz")
    scale = channel_scales(Y, scale_groups)
    Ys = (Y - Y.mean(axis=1, keepdims=True)) / scale[:, None]
    T, Tb = _toeplitz_blocks(Ys, ref, i, nb)
    # the one factorisation for every order: T T^T = U S^2 U^T (symmetric eigen-solve,
    # about half the cost of the SVD of T; the leading singular vectors are the same)
    TT = sla.blas.dsyrk(1.0, T.T, trans=1, lower=1)  # T T^T, lower triangle, Fortran order
    s, G, s2_inv = leading_subspace(TT, int(o[-1]))
    TtG = T.T @ G
    G_blocks = [(Tk @ TtG) * s2_inv for Tk in Tb]  # O_b = T_b V S^-1 with V = T^T U S^-1
    poles = poles_over_orders(G, l, o, fs, G_blocks=G_blocks, out_scale=scale)
    return PoleSweep("ssi-cov", o, poles, s, len(G_blocks))


def _toeplitz_blocks(Ys: FloatArray, ref: IntArray, i: int, nb: int
                     ) -> tuple[FloatArray, list[FloatArray]]:
    """Block Toeplitz matrix of output correlations, and one per std block (``nb`` > 1).

    The point estimate comes from the whole record's correlations, as without blocks: the
    blocks' lag sums plus the pairs that straddle their edges (a few per lag).
    """
    l, n = Ys.shape
    n_lags = 2 * i
    all_ref = ref.size == l and bool(np.all(ref == np.arange(l)))  # y_ref IS y

    def corr(a: int, b: int) -> FloatArray:
        yb = Ys[:, a:b]
        return correlations(yb, yb if all_ref else Ys[ref, a:b], n_lags)

    if not nb:
        return _toeplitz(corr(0, n), i), []
    edges = np.linspace(0, n, nb + 1).astype(int)
    Rb = [corr(a, b) for a, b in itertools.pairwise(edges)]
    T = _toeplitz(_whole_record(Ys, None if all_ref else ref, Rb, edges, n_lags), i)
    return T, [_toeplitz(R, i) for R in Rb]
