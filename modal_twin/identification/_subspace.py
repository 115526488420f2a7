r"""Poles, damping and shapes from an extended observability matrix, for all orders (private).

Shared by :mod:`.n4sid` and :mod:`.ssi_cov`. With :math:`\Gamma = U_n S_n^{1/2}` from one
SVD, the order-n model uses the first n columns (truncated SVD); the callers pass the
orthonormal basis :math:`U` (a diagonal change of state basis, same poles, better
conditioned when trailing singular values vanish). Shift invariance gives
:math:`A_n = \underline{\Gamma}_n^{+} \overline{\Gamma}_n` and :math:`C_n` = first l rows.
One QR of :math:`\underline{\Gamma}_{n_{max}} = QR` serves every order:
:math:`\underline{\Gamma}_n = Q_{:, :n} R_{:n, :n}`, so
:math:`A_n = R_{:n,:n}^{-1} (Q^T \overline{\Gamma})_{:n,:n}`, and since R is upper
triangular :math:`R_{:n,:n}^{-1} = (R^{-1})_{:n,:n}`: one triangular inverse for all orders.
Discrete poles :math:`\mu` map to :math:`\lambda = f_s \ln \mu`,
:math:`f = |\lambda| / 2\pi`, :math:`\zeta = -\mathrm{Re}\,\lambda / |\lambda|`;
shapes are :math:`C_n V` (eigenvectors :math:`V` of :math:`A_n`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.linalg as sla
from numpy.typing import ArrayLike

from modal_twin._types import ComplexArray, FloatArray, IntArray
from modal_twin.errors import ModelError, OptionError
from modal_twin.identification.modal_model import PoleSet, normalize_shapes
from modal_twin.progress import track

__all__ = ["channel_scales", "check_orders", "choose_block_rows", "default_block_rows",
           "leading_eigh", "leading_subspace", "poles_over_orders", "std_blocks"]


def check_orders(orders: object, max_allowed: int, what: str) -> IntArray:
    """Validate model orders: positive integers, ascending, <= ``max_allowed``."""
    o = np.atleast_1d(np.asarray(orders))
    if o.ndim != 1 or o.size == 0 or not np.issubdtype(o.dtype, np.integer) or np.any(o < 1):
        msg = f"orders: expected a non-empty 1-D sequence of integers >= 1, got {orders!r}"
        raise OptionError(msg)
    o = np.unique(o.astype(np.int64))
    if o[-1] > max_allowed:
        msg = (
            f"orders: expected orders <= {max_allowed} ({what}), got max order {o[-1]}; "
            "lower the order or add block rows / data"
        )
        raise OptionError(msg)
    return o


def default_block_rows(
    fs_hz: float,
    f_min_hz: float | None,
    n_max: int,
    n_rows: int,
    n_width: int,
    *,
    floor: int,
    max_width: int = 1200,
) -> int:
    """Horizon i of the block Hankel / Toeplitz matrix: the documented default rule.

    ``i = max(ceil((n_max + 1) / n_rows) + 1, floor, ceil(fs_hz / (8 f_min_hz)))``: the
    first term is the smallest horizon that supports order ``n_max`` (n_rows = outputs
    per block row); the last, used when the lowest frequency of interest ``f_min_hz`` is
    given, makes the horizon cover an eighth of its period (shorter horizons left the
    damping of a 0.69 Hz mode at 71.4 Hz 11 % off in the benchmark of issue 4; an eighth
    brought it under 2 %). The physical term is capped so that ``i * n_width`` (columns
    per block row times i, which sets the cubic cost) stays <= ``max_width``.
    """
    i_order = -(-(int(n_max) + 1) // int(n_rows)) + 1
    i = max(i_order, int(floor))
    if f_min_hz is not None:
        if not (np.isfinite(f_min_hz) and 0.0 < f_min_hz < fs_hz / 2):
            msg = f"f_min_hz: expected a frequency in (0, fs_hz / 2 = {fs_hz / 2}), got " + repr(
                f_min_hz
            )
            raise OptionError(msg)
        i_phys = int(np.ceil(fs_hz / (8.0 * f_min_hz)))
        i = max(i, min(i_phys, max(int(max_width) // int(n_width), i)))
    return i


def _continuous(mu: ComplexArray, fs_hz: float) -> ComplexArray:
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = np.asarray(np.log(mu.astype(np.complex128)) * fs_hz, dtype=np.complex128)
    return lam


def _keep(mu: ComplexArray) -> np.ndarray:
    """Mask of poles kept: one of each conjugate pair (Im > 0), finite, non-zero."""
    return (mu.imag > 1e-12 * np.abs(mu)) & np.isfinite(mu) & (np.abs(mu) > 0)


def _fz(lam: ComplexArray) -> tuple[FloatArray, FloatArray]:
    w = np.abs(lam)
    return w / (2 * np.pi), -lam.real / np.where(w > 0, w, 1.0)


def _shift_solver(G: FloatArray, l: int) -> tuple[FloatArray, FloatArray]:
    """Return (R^-1, Q^T G_down); the leading n x n block of R^-1 is R[:n, :n]^-1."""
    Q, R = np.linalg.qr(G[:-l])
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        Rinv = sla.solve_triangular(R, np.eye(R.shape[0]), check_finite=False)
    return Rinv, Q.T @ G[l:]


def poles_over_orders(
    G: FloatArray,
    l: int,
    orders: Sequence[int] | IntArray,
    fs_hz: float,
    *,
    G_blocks: Sequence[FloatArray] = (),
    out_scale: FloatArray | None = None,
) -> tuple[PoleSet, ...]:
    """Poles, frequencies, damping, shapes (and block spread) for every order.

    Parameters
    ----------
    G : ndarray, shape (l * i, n_max)
        Observability matrix in a common basis for all orders (columns by importance).
    l : int
        Number of outputs.
    orders : sequence of int
        Model orders, each <= n_max.
    fs_hz : float
        Sample rate.
    G_blocks : sequence of ndarray, each shape (l * i, n_max)
        Observability matrices from data blocks in the same basis; their pole spread
        gives the standard deviation of the full-data estimate (std / sqrt(n_blocks)).
    out_scale : ndarray, shape (l,), optional
        Channel scale to undo on the shapes.

    Returns
    -------
    tuple of PoleSet
    """
    R, M = _shift_solver(G, l)
    blk = [_shift_solver(Gb, l) for Gb in G_blocks]
    nb = len(blk)
    out = []
    for n in track(orders, "model orders", unit="order"):
        A = R[:n, :n] @ M[:n, :n]  # R holds R^-1 here
        if not np.all(np.isfinite(A)):
            msg = f"orders: order {n} exceeds the rank of the observability matrix"
            raise OptionError(msg)
        mu, V = np.linalg.eig(A)
        k = _keep(mu)
        lam = _continuous(mu[k], fs_hz)
        f, z = _fz(lam)
        shapes = G[:l, :n] @ V[:, k]
        if out_scale is not None:
            shapes = shapes * out_scale[:, None]
        sf = np.full(f.shape, np.nan)
        sz = np.full(f.shape, np.nan)
        if nb >= 2 and lam.size:
            fb = np.empty((nb, lam.size))
            zb = np.empty((nb, lam.size))
            for b, (Rb, Mb) in enumerate(blk):
                Ab = Rb[:n, :n] @ Mb[:n, :n]
                mub = np.asarray(np.linalg.eigvals(Ab) if np.all(np.isfinite(Ab)) else np.zeros(0),
                                 dtype=np.complex128)  # a real eigenvalue is dropped either way
                lb = _continuous(mub[_keep(mub)], fs_hz)
                if lb.size == 0:
                    fb[b], zb[b] = np.nan, np.nan
                    continue
                j = np.argmin(np.abs(lb[None, :] - lam[:, None]), axis=1)
                fb[b], zb[b] = _fz(lb[j])
            sf = np.nanstd(fb, axis=0, ddof=1) / np.sqrt(nb)
            sz = np.nanstd(zb, axis=0, ddof=1) / np.sqrt(nb)
        order = np.argsort(f)
        out.append(
            PoleSet(
                int(n),
                f[order],
                z[order],
                normalize_shapes(shapes[:, order]),
                sf[order],
                sz[order],
            )
        )
    return tuple(out)


def _back_transform(c: FloatArray, tau: FloatArray, X: FloatArray) -> FloatArray:
    r""":math:`Q X` for the Q of ``dsytrd`` (lower): what ``dormtr`` does (not in scipy).

    ``dsytrd`` stores :math:`Q = H_1 \cdots H_{n-1}`, :math:`H_k = I - \tau_k v_k v_k^T`
    with :math:`v_k` zero above row k + 1, one at row k + 1 and ``c[k+2:, k]`` below
    (``dsytrd`` documentation, Further Details): the reflectors of a QR factorisation of
    ``c[1:, :n-1]``, so rows 1: of :math:`Q X` are ``dormqr`` applied to rows 1: of X
    (blocked, compact WY) and row 0 is unchanged.
    """
    n = c.shape[0]
    out = np.array(X, order="F")
    if n < 2:
        return out
    a = c[1:, : n - 1]
    lw = int(sla.lapack.dormqr("L", "N", a, tau, out[1:], lwork=-1)[1][0])
    cq, _, info = sla.lapack.dormqr("L", "N", a, tau, out[1:], lwork=max(lw, 1))
    if info != 0:  # pragma: no cover - LAPACK argument error
        msg = f"P: dormqr failed with info {info}"
        raise ModelError(msg)
    out[1:] = cq
    return out


def leading_eigh(
    P: FloatArray, n_max: int, *, overwrite: bool = False
) -> tuple[FloatArray, FloatArray]:
    """Return the eigenpairs of the symmetric ``P`` in descending order.

    The one factorisation a subspace method shares over all orders (``P = U S^2 U^T``).

    Returns the leading ``n_sv`` eigenvalues (all of them up to 500 rows, above that
    ``max(2 n_max, 100)``) and the leading ``n_max`` eigenvectors (the only ones the
    orders use). Above 150 rows only those vectors are computed, by the steps of
    LAPACK's ``syevx`` called one by one (eigenvalues by ``dsterf`` instead of
    bisection): tridiagonal reduction (``dsytrd``, blocked), all eigenvalues of the
    tridiagonal (``dsterf``, O(n^2)), the wanted vectors by
    inverse iteration (``dstein``) and their back transformation (``dormqr``,
    :func:`_back_transform`). This is about half the time of the full ``syevd`` on
    546 rows; ``syevr`` with an index subset is slower still (it switches to bisection).
    Only the lower triangle of ``P`` is read; with ``overwrite`` a Fortran-ordered ``P``
    is reduced in place (its content is destroyed).
    """
    n = P.shape[0]
    n_sv = min(n, max(2 * n_max, 100)) if n > 500 else n
    n_vec = min(n, int(n_max))
    if n <= 150:
        s2, U = np.linalg.eigh(P)  # reads the lower triangle
        return s2[::-1][:n_sv], U[:, ::-1][:, :n_vec]
    lw = int(sla.lapack.dsytrd_lwork(n, lower=1)[0])
    c, d, e, tau, info = sla.lapack.dsytrd(P, lower=1, lwork=max(lw, 1), overwrite_a=overwrite)
    if info != 0:  # pragma: no cover - LAPACK argument error
        msg = f"P: dsytrd failed with info {info}"
        raise ModelError(msg)
    w = sla.eigvalsh_tridiagonal(d, e, lapack_driver="sterf", check_finite=False)
    # vectors of the tridiagonal for the leading eigenvalues by inverse iteration (dstein,
    # reorthogonalised within clusters); MRRR (dstemr) if it does not converge
    one = np.ones(n, dtype=np.int32)
    split = np.zeros(n, dtype=np.int32)
    split[0] = n  # one block
    Z, info = sla.lapack.dstein(d, e, w[n - n_vec :], one, split)
    if info != 0:
        _, Z = sla.eigh_tridiagonal(d, e, select="i", select_range=(n - n_vec, n - 1),
                                    lapack_driver="stemr", check_finite=False)
    U = _back_transform(c, tau, Z[:, ::-1])
    return w[::-1][:n_sv], U


def choose_block_rows(fs_hz: float, f_min_hz: float | None, orders: object,
                      block_rows: int | None, n_ref: int, width: int, *, floor: int) -> int:
    """Return the horizon ``i``: ``block_rows`` when given, else :func:`default_block_rows`.

    Raises
    ------
    OptionError
        A horizon below 2.
    """
    o_req = np.atleast_1d(np.asarray(orders))
    n_max_req = int(o_req.max()) if o_req.size and np.issubdtype(o_req.dtype, np.integer) else 1
    i = (default_block_rows(fs_hz, f_min_hz, n_max_req, n_ref, width, floor=floor)
         if block_rows is None else int(block_rows))
    if i < 2:
        msg = f"block_rows: expected an integer >= 2, got {block_rows!r}"
        raise OptionError(msg)
    return i


def std_blocks(n_blocks_std: int | None) -> int:
    """Return the data blocks for the standard deviations (0: none; 1 means none too)."""
    return int(n_blocks_std) if n_blocks_std and n_blocks_std > 1 else 0


def leading_subspace(P: FloatArray, n_max: int) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(singular values, leading ``n_max`` vectors, their 1 / s^2) of ``P = U S^2 U^T``.

    ``P``'s lower triangle is reduced in place (:func:`leading_eigh`); a zero singular value
    gives 0 in ``1 / s^2``.
    """
    s2, U = leading_eigh(P, n_max, overwrite=True)
    s = np.sqrt(np.clip(s2, 0.0, None))
    s2_inv = 1.0 / np.where(s2[:n_max] > 0, s2[:n_max], np.inf)
    return s, U[:, :n_max], s2_inv


def channel_scales(Y: FloatArray, groups: ArrayLike | None) -> FloatArray:
    """RMS of each channel, or the joint RMS of its group (``scale_groups``)."""
    ms = np.mean((Y - Y.mean(axis=1, keepdims=True)) ** 2, axis=1)
    if groups is None:
        return np.asarray(np.sqrt(ms), dtype=float)
    g = np.asarray(groups)
    if g.shape != (Y.shape[0],):
        msg = f"scale_groups: expected one label per channel ({Y.shape[0]}), got {g.shape}"
        raise OptionError(msg)
    out = np.empty(Y.shape[0])
    for lab in np.unique(g):
        out[g == lab] = np.sqrt(np.mean(ms[g == lab]))
    return out
