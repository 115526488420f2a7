r"""Combined deterministic-stochastic subspace identification with measured inputs.

The N4SID family of Van Overschee & De Moor (1994), as used in sec. 3 of [004] (12 table
accelerations in, 42 structural accelerations out), in its PO-MOESP form (Verhaegen, 1994),
which has the same column space as the N4SID oblique projection weighted by
:math:`\Pi_{U_f^\perp}`:

1. Block Hankel matrices of inputs and outputs with i past and i future block rows,
   stacked as :math:`[U_f; W_p; Y_f]` with :math:`W_p = [U_p; Y_p]`.
2. ONE factorisation of the correlation (Gram) matrix :math:`\Phi = H H^T = L L^T`
   instead of the QR of the tall Hankel transpose. :math:`\Phi` itself is never formed
   from H: its blocks are lag sums of :math:`z = [u; y]` (computed by segmented FFT, about
   2i / 4 times less work than the product and no 2i(m + l) x j copy) plus exact edge
   corrections (:mod:`modal_twin.identification._lagsums`); no Q and no j x j projection
   is formed. :math:`L_{32} L_{32}^T` follows from Schur complements of :math:`\Phi`
   through Cholesky factors (:func:`_l32`).
3. :math:`Y_f \Pi_{U_f^\perp}` projected on the instruments :math:`W_p` has the column
   space of :math:`L_{32}`; the eigen-decomposition :math:`L_{32} L_{32}^T = U S^2 U^T`
   (the SVD of :math:`L_{32}`) gives the extended observability matrix of every model
   order n by truncation, :math:`\Gamma_n = U_n` (up to a diagonal change of basis);
   only the leading n_max eigenvectors are computed (tridiagonal reduction, inverse
   iteration, :func:`~modal_twin.identification._subspace.leading_eigh`).
4. Poles, damping and complex shapes at the outputs for all orders from one QR of
   :math:`\underline{\Gamma}` (:mod:`modal_twin.identification._subspace`).

Covariance-driven form (``weighting="covariance"``): the combined deterministic-stochastic
SSI of Reynders & De Roeck (2008, "Reference-based combined deterministic-stochastic
subspace identification for experimental and operational modal analysis", MSSP 22), the
``IOcov`` Hankel matrix of pyOMA2: the future outputs with the future inputs projected
out, correlated with the past outputs,

.. math:: H = \Phi_{Y_f Y_p | U_f} = \Phi_{Y_f Y_p} - \Phi_{Y_f U_f} \Phi_{U_f U_f}^{-1}
          \Phi_{U_f Y_p},

whose left singular vectors give :math:`\Gamma_n` as in step 3. It drops the weighting
:math:`\Phi_{22|1}^{-1}` of the instruments (the past inputs and outputs whitened, step
3), which on short records with many channels (an earthquake's: 1200 instrument rows,
2.6 times as many Hankel columns) is estimated with a spread of its eigenvalues of about
:math:`(1 \pm \sqrt{p / j})^2` and biases the poles (Hayward 2021-04-26: 3.274 Hz
against 3.33 Hz of pyOMA2's IOcov on the same channels, ``identification/record.py``).

Uncertainty: the Hankel columns are split into ``n_blocks_std`` contiguous blocks whose
Gram matrices sum to :math:`\Phi` (so the blocks cost nothing extra); the block
observability matrices in the common basis,
:math:`\Gamma_b = L_{32,b} L_{32,b}^T U_n S_n^{-2}`, give block poles whose spread
over :math:`\sqrt{n_b}` estimates the standard deviation of frequency and damping.
"""

from __future__ import annotations

import logging
import warnings

import numpy as np
import scipy.linalg as sla
from numpy.typing import ArrayLike

from modal_twin._types import FloatArray
from modal_twin.errors import OptionError, ShapeError
from modal_twin.identification._lagsums import hankel_gram
from modal_twin.identification._subspace import (
    channel_scales,
    check_orders,
    choose_block_rows,
    leading_subspace,
    poles_over_orders,
    std_blocks,
)
from modal_twin.identification.modal_model import PoleSweep
from modal_twin.validation import as_channels, check_positive, check_rank

__all__ = ["WEIGHTINGS", "n4sid"]

WEIGHTINGS = ("oblique", "covariance")
"""Forms of the projection: PO-MOESP (whitened instruments) or covariance-driven."""

_log = logging.getLogger(__name__)


def _groups(m: int, l: int, i: int) -> list[tuple[slice, slice]]:
    """Rows [U_f; U_p; Y_p; Y_f] of the Hankel of z = [u; y] as (blocks, channels) groups."""
    uc, yc = slice(0, m), slice(m, m + l)
    past, fut = slice(0, i), slice(i, 2 * i)
    return [(fut, uc), (past, uc), (past, yc), (fut, yc)]


def _chol(A: FloatArray, *, overwrite: bool = False) -> FloatArray | None:
    """Lower Cholesky factor of a symmetric PSD A with relative ridge 1e-10 (None if it fails).

    Only the lower triangle of A is read (LAPACK ``dpotrf``); with ``overwrite`` a
    Fortran-ordered A is factorised in place (no copy, no fresh pages).
    """
    n = A.shape[0]
    ridge = 1e-10 * max(float(np.trace(A)) / max(n, 1), np.finfo(float).tiny)
    Ar = A if overwrite and A.flags.f_contiguous else np.array(A, order="F")
    Ar.flat[:: n + 1] += ridge
    Lc, info = sla.lapack.dpotrf(Ar, lower=1, clean=1, overwrite_a=1)
    if info != 0:
        return None
    out: FloatArray = Lc
    return out


def _whiten(A: FloatArray, B: FloatArray) -> FloatArray:
    """W with W^T W = B^T A^-1 B for a symmetric PSD A (Cholesky, else least squares).

    Only the lower triangle of A is read.
    """
    Lc = _chol(A)
    if Lc is None:  # singular beyond the ridge: symmetric square root of the pseudo-inverse
        w, V = np.linalg.eigh(np.tril(A) + np.tril(A, -1).T)
        keep = w > 1e-10 * max(float(w.max()), np.finfo(float).tiny)
        out: FloatArray = (V[:, keep] / np.sqrt(w[keep])).T @ B
        return out
    # W = L^-1 B as W^T = B^T L^-T: the transpose of a C-ordered B is Fortran-ordered
    W: FloatArray = sla.blas.dtrsm(1.0, Lc, B.T, side=1, lower=1, trans_a=1).T
    return W


def _schur22(Phi: FloatArray, W12: FloatArray, mf: int, p: int) -> FloatArray:
    r""":math:`\Phi_{22|1} = \Phi_{22} - W_{12}^T W_{12}` (lower triangle, Fortran order)."""
    Sc22 = np.array(Phi[mf : mf + p, mf : mf + p], order="F")
    out: FloatArray = sla.blas.dsyrk(-1.0, W12, trans=1, beta=1.0, c=Sc22, lower=1,
                                     overwrite_c=1)
    return out


def _l32(Phi: FloatArray, mf: int, p: int) -> FloatArray:
    r"""Return a factor :math:`W` with :math:`W^T W = L_{32} L_{32}^T`, from :math:`\Phi = L L^T`.

    With the LQ factor L of [U_f; W_p; Y_f], the blocks below the first block column are
    the Schur complement :math:`\Phi_{\cdot|1} = \Phi_{rr} - \Phi_{r1}
    \Phi_{11}^{-1} \Phi_{1r}` (data with U_f projected out), and
    :math:`L_{32} L_{32}^T = \Phi_{32|1} \Phi_{22|1}^{-1} \Phi_{23|1}`. Both inverses
    enter through Cholesky factors, and only the rows of the instruments (block 2) of the
    first Schur complement are formed (its symmetric block by a rank-k update, SYRK).
    """
    W1 = _whiten(Phi[:mf, :mf], Phi[:mf, mf:])
    W12, W13 = W1[:, :p], W1[:, p:]
    Sc22 = _schur22(Phi, W12, mf, p)
    # Phi_32|1 = Phi_32 - W13^T W12 (Phi_32 = Phi_23^T), Fortran-ordered, updated in place
    X = np.array(Phi[mf : mf + p, mf + p :].T, order="F")
    X = sla.blas.dgemm(-1.0, W13, W12, trans_a=1, beta=1.0, c=X, overwrite_c=1)
    Lc = _chol(Sc22, overwrite=True)
    if Lc is None:  # singular beyond the ridge (Sc22 overwritten): rebuild it, as _whiten
        return _whiten(_schur22(Phi, W12, mf, p), X.T)
    # W^T = Phi_32|1 L^-T: one in-place triangular solve; W = its transpose (a view)
    X = sla.blas.dtrsm(1.0, Lc, X, side=1, lower=1, trans_a=1, overwrite_b=1)
    W: FloatArray = X.T
    return W


def _l32_times(Phi: FloatArray, mf: int, p: int, G: FloatArray) -> FloatArray:
    r""":math:`L_{32} L_{32}^T G` for a thin G, without forming :math:`L_{32}` (std blocks).

    Same algebra as :func:`_l32`, ordered so that only products with G (n_max columns)
    and one Cholesky factor of :math:`\Phi_{22|1}` are formed:
    :math:`\Phi_{32|1} \Phi_{22|1}^{-1} (\Phi_{23|1} G)`.
    """
    W1 = _whiten(Phi[:mf, :mf], Phi[:mf, mf:])
    W12, W13 = W1[:, :p], W1[:, p:]
    Sc22 = _schur22(Phi, W12, mf, p)
    ScG = Phi[mf : mf + p, mf + p :] @ G - W12.T @ (W13 @ G)  # Phi_23|1 G
    Lc = _chol(Sc22)
    if Lc is None:
        w, V = np.linalg.eigh(np.tril(Sc22) + np.tril(Sc22, -1).T)
        keep = w > 1e-10 * max(float(w.max()), np.finfo(float).tiny)
        u = V[:, keep] @ ((V[:, keep].T @ ScG) / w[keep][:, None])
    else:
        u = sla.cho_solve((Lc, True), ScG, check_finite=False)
    out: FloatArray = Phi[mf : mf + p, mf + p :].T @ u - W13.T @ (W12 @ u)  # Phi_32|1 u
    return out


def n4sid(
    u: ArrayLike,
    y: ArrayLike,
    fs_hz: float,
    *,
    orders: ArrayLike,
    block_rows: int | None = None,
    n_blocks_std: int = 8,
    f_min_hz: float | None = None,
    weighting: str = "oblique",
    scale_groups: ArrayLike | None = None,
) -> PoleSweep:
    """N4SID (PO-MOESP) poles, damping, shapes and their spread for every model order.

    Parameters
    ----------
    u : array_like, shape (n_in, n_samples)
        Measured inputs (e.g. table accelerations, forces).
    y : array_like, shape (n_out, n_samples)
        Measured outputs. Means are removed and every channel is scaled to unit RMS
        internally; shapes are returned in the units of ``y``.
    fs_hz : float
        Sample rate in Hz.
    orders : array_like of int
        Model orders (state dimensions) of the stabilization diagram.
    block_rows : int, optional
        Past / future horizon i. Default ``max(ceil((max_order + 1) / n_out) + 1, 6)``,
        raised to ``ceil(fs_hz / (8 f_min_hz))`` when ``f_min_hz`` is given (capped at
        ``i (n_in + n_out) <= 1200`` for cost).
    n_blocks_std : int
        Data blocks for the standard deviations (0 or 1 disables). Reduced, with a
        warning, when the record is too short for that many blocks.
    f_min_hz : float, optional
        Lowest natural frequency of interest; sets the default horizon (see
        ``block_rows``). Ignored when ``block_rows`` is given.
    weighting : {"oblique", "covariance"}
        ``"oblique"``: PO-MOESP, the past inputs and outputs whitened as instruments
        (steps 1-4 of the module docstring); ``"covariance"``: the covariance-driven
        combined form (past outputs as references, no whitening; module docstring).
    scale_groups : array_like, optional
        A label per output channel: the outputs of one label share one scale, their joint
        RMS (as :func:`~modal_twin.identification.ssi_cov.ssi_cov`). Default: each output
        its own unit RMS. Inputs are always scaled to unit RMS (the projection on them
        does not depend on their scales).

    Returns
    -------
    PoleSweep
        ``method="n4sid"``.

    Raises
    ------
    ShapeError
        ``u`` and ``y`` differ in length, or fewer samples than the Hankel matrix needs.
    SignalError
        NaN / Inf, constant channels, or linearly dependent inputs.
    OptionError
        Orders beyond ``n_out * (block_rows - 1)``, bad ``block_rows``, ``weighting`` or
        ``scale_groups``.

    Examples
    --------
    >>> import scipy.signal as sig
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(4000)
    >>> b, a = sig.iirpeak(3.0, 30.0, fs=40.0)
    >>> sw = n4sid(u, sig.lfilter(b, a, u), 40.0, orders=[2])
    >>> round(float(sw.poles[0].f_hz[0]), 3)
    3.0
    """
    fs = check_positive(fs_hz, "fs_hz")
    if weighting not in WEIGHTINGS:
        msg = f"weighting: expected one of {list(WEIGHTINGS)}, got {weighting!r}"
        raise OptionError(msg)
    U = as_channels(u, "u", min_samples=4, allow_constant=False)
    Y = as_channels(y, "y", min_samples=4, allow_constant=False)
    if U.shape[1] != Y.shape[1]:
        msg = f"y: expected {U.shape[1]} samples as u, got {Y.shape[1]}"
        raise ShapeError(msg)
    check_rank(U, "u")
    m, l = U.shape[0], Y.shape[0]
    i = choose_block_rows(fs, f_min_hz, orders, block_rows, l, m + l, floor=6)
    k, j = 2 * i * (m + l), Y.shape[1] - 2 * i + 1
    if j < 2 * k:
        msg = (
            f"y: expected at least {2 * k + 2 * i - 1} samples for block_rows = {i} with "
            f"{m} inputs and {l} outputs, got {Y.shape[1]}"
        )
        raise ShapeError(msg)
    o = check_orders(orders, l * (i - 1), f"n_out * (block_rows - 1) = {l} * {i - 1}")
    nb = _fit_blocks(std_blocks(n_blocks_std), j, k)
    z, sy = _unit_rms(U, Y, scale_groups)
    obs = _observability if weighting == "oblique" else _observability_cov
    G, s, G_blocks = obs(z, m, l, i, j, nb, int(o[-1]))
    _log.debug("n4sid: i=%d, hankel %d x %d, %d std blocks", i, k, j, len(G_blocks))
    poles = poles_over_orders(G, l, o, fs, G_blocks=G_blocks, out_scale=sy)
    return PoleSweep("n4sid", o, poles, s, len(G_blocks))


def _fit_blocks(nb: int, j: int, k: int) -> int:
    """Std blocks that keep at least ``k`` Hankel columns each (a warning when fewer)."""
    if nb and j // nb < k:
        nb_fit = j // k
        warnings.warn(
            f"n_blocks_std: {nb} blocks of {j // nb} Hankel columns are fewer than the "
            f"{k} rows; using {nb_fit if nb_fit > 1 else 0} blocks",
            RuntimeWarning,
            stacklevel=3,
        )
        nb = nb_fit if nb_fit > 1 else 0
    return nb


def _unit_rms(U: FloatArray, Y: FloatArray, groups: ArrayLike | None = None
              ) -> tuple[FloatArray, FloatArray]:
    """``z = [u; y]``, means removed, unit RMS per input and per output (or output group).

    Returns ``z`` and the outputs' scales (``channel_scales`` of SSI-cov: each channel's
    RMS, or its group's joint RMS).
    """
    m, n = U.shape[0], U.shape[1]
    z = np.empty((m + Y.shape[0], n))
    np.subtract(U, U.mean(axis=1, keepdims=True), out=z[:m])
    np.subtract(Y, Y.mean(axis=1, keepdims=True), out=z[m:])
    sz = np.sqrt(np.einsum("ij,ij->i", z, z) / n)
    if groups is not None:
        sz[m:] = channel_scales(Y, groups)
    z /= sz[:, None]
    return z, sz[m:]


def _observability(z: FloatArray, m: int, l: int, i: int, j: int, nb: int, nm: int
                   ) -> tuple[FloatArray, FloatArray, list[FloatArray]]:
    """Return the observability basis ``G`` (leading ``nm`` vectors), singular values, blocks.

    From the exact Gram matrix of ``[U_f; U_p; Y_p]`` (lag sums), its projection ``L32``
    (PO-MOESP) and the one factorisation ``L32 L32^T = U S^2 U^T``; per std block
    ``Gamma_b = L32b L32b^T U S^-2``.
    """
    mf, p = m * i, (m + l) * i
    edges = np.linspace(0, j, nb + 1).astype(int) if nb else np.array([0, j])
    # exact, from lag sums; rows of [U_f; U_p; Y_p] only (Phi_33 is never used)
    Phi_b = hankel_gram(z, 2 * i, edges, _groups(m, l, i), row_groups=3)
    Phi = Phi_b[0] if len(Phi_b) == 1 else np.sum(Phi_b, axis=0)  # = H H^T = L L^T
    W2 = _l32(Phi, mf, p)
    # the one factorisation: L32 L32^T = U S^2 U^T (lower triangle, by SYRK, in place)
    P = sla.blas.dsyrk(1.0, W2.T, lower=1)
    s, G, s2_inv = leading_subspace(P, nm)
    G_blocks = [_l32_times(Pk, mf, p, G) * s2_inv for Pk in (Phi_b if nb else ())]
    return G, s, G_blocks


def _h_cov(Phi: FloatArray, m: int, l: int, i: int) -> FloatArray:
    r""":math:`H^T = \Phi_{Y_p Y_f | U_f}` (past outputs x future outputs) from :math:`\Phi`.

    The Schur complement of :math:`\Phi_{U_f U_f}` (through its Cholesky factor,
    :func:`_whiten`) in the rows of :math:`Y_p` and the columns of :math:`Y_f`.
    """
    mf, p = m * i, (m + l) * i
    yp, yf = slice(mf + m * i, mf + p), slice(mf + p, mf + p + l * i)
    W1 = _whiten(Phi[:mf, :mf], np.ascontiguousarray(Phi[:mf, mf:]))
    Wp, Wf = W1[:, yp.start - mf : yp.stop - mf], W1[:, yf.start - mf : yf.stop - mf]
    out: FloatArray = Phi[yp, yf] - Wp.T @ Wf
    return out


def _observability_cov(z: FloatArray, m: int, l: int, i: int, j: int, nb: int, nm: int
                       ) -> tuple[FloatArray, FloatArray, list[FloatArray]]:
    """As :func:`_observability` for the covariance-driven form (module docstring).

    ``H H^T = U S^2 U^T`` gives ``G``; per std block ``Gamma_b = H_b H^T U S^-2`` (the
    block Hankel projected on the common right singular vectors, as SSI-cov's blocks).
    """
    edges = np.linspace(0, j, nb + 1).astype(int) if nb else np.array([0, j])
    Phi_b = hankel_gram(z, 2 * i, edges, _groups(m, l, i), row_groups=3)
    Phi = Phi_b[0] if len(Phi_b) == 1 else np.sum(Phi_b, axis=0)
    Ht = _h_cov(Phi, m, l, i)  # H^T: (l i past) x (l i future)
    P = sla.blas.dsyrk(1.0, Ht, trans=1, lower=1)  # H H^T = Ht^T Ht, lower triangle
    s, G, s2_inv = leading_subspace(P, nm)
    HtG = Ht @ G
    G_blocks = [(_h_cov(Pk, m, l, i).T @ HtG) * s2_inv for Pk in (Phi_b if nb else ())]
    return G, s, G_blocks
