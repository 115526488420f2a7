"""Poly-reference least-squares complex frequency-domain method (pLSCF / PolyMAX).

Eqs. (1)-(4) of [002] (Peeters et al., 2004). Right matrix-fraction model of the FRF row of
output o, Eq. (1): :math:`H_o(\\omega) = B_o(\\omega) A(\\omega)^{-1}` with the polynomials
of Eq. (2), :math:`B_o = \\sum_r Z^r \\beta_{o,r}` (1 x m) and
:math:`A = \\sum_r Z^r \\alpha_r` (m x m), in the z-domain basis of Eq. (3),
:math:`Z(\\omega) = e^{-j\\omega\\Delta t}`.

Linearised least squares: per output :math:`X = [Z^0 \\cdots Z^p]` and
:math:`Y_o = -[Z^0 \\cdots Z^p] \\otimes H_o`; the normal matrices
:math:`R = \\mathrm{Re}(X^H X)`, :math:`S_o = \\mathrm{Re}(X^H Y_o)`,
:math:`T_o = \\mathrm{Re}(Y_o^H Y_o)` are eliminated for the numerators, giving the reduced
normal equations :math:`M \\alpha = 0`, :math:`M = 2 \\sum_o (T_o - S_o^T R^{-1} S_o)`,
solved with :math:`\\alpha_p = I`. Because :math:`\\overline{Z^r} Z^s` depends on s - r
only, R, S_o and T_o are Toeplitz in the polynomial index and are built from 2p + 1 sums
over frequency; the matrices of every lower order are sub-blocks of those of the highest
order, so the frequency sums are done once for the whole stabilization diagram.

Poles and participation factors come from the companion matrix of Eq. (4); a root
:math:`z_r` of :math:`\\det A(z)` gives :math:`\\lambda_r = -\\ln(z_r) / \\Delta t`
(Eq. (3)). Mode shapes per order follow from LSFD, Eq. (5) of [002]
(:func:`modal_twin.identification.lsfd.lsfd`).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
from numpy.typing import ArrayLike

from modal_twin._types import ComplexArray, FloatArray
from modal_twin.errors import OptionError, ShapeError, SignalError
from modal_twin.identification._subspace import check_orders
from modal_twin.identification.lsfd import lsfd_shapes
from modal_twin.identification.modal_model import PoleSet, PoleSweep

__all__ = ["polymax", "polymax_poles"]


def _companion(alpha: FloatArray, m: int, p: int) -> tuple[ComplexArray, ComplexArray]:
    """Eigen-decomposition of the block companion matrix, Eq. (4) of [002]."""
    Cm = np.zeros((m * p, m * p))
    Cm[: m * (p - 1), m:] = np.eye(m * (p - 1))
    Cm[m * (p - 1) :, :] = -alpha[: m * p].T  # last block row: -alpha_0 ... -alpha_{p-1}
    z, V = np.linalg.eig(Cm)
    return z, V[:m]  # first block of the eigenvectors = participation factors


def polymax_poles(
    H: ComplexArray, f_hz: FloatArray, orders: ArrayLike, dt_s: float
) -> list[tuple[int, ComplexArray, ComplexArray]]:
    """Continuous poles and participation factors for each polynomial order.

    Parameters
    ----------
    H : ndarray of complex, shape (n_out, n_in, n_f)
        FRFs on the analysis band (finite).
    f_hz : ndarray, shape (n_f,)
    orders : array_like of int
        Polynomial orders p (each gives p * n_in poles).
    dt_s : float
        Sampling time of the z-domain basis, Eq. (3) of [002].

    Returns
    -------
    list of (p, lambda (n,), L (n_in, n)) with all poles (both of each pair).
    """
    n_out, m, _ = H.shape
    o = np.asarray(orders, dtype=np.int64)
    pmax = int(o.max())
    wdt = 2 * np.pi * f_hz * dt_s
    d = np.arange(-pmax, pmax + 1)
    E = np.exp(-1j * np.outer(d, wdt))  # conj(Z^r) Z^s = Z^(s - r), index s - r + pmax
    r0 = E.sum(axis=1).real  # R Toeplitz generator
    nf = wdt.size
    # the frequency sums as BLAS products (same sums as einsum "dk,oik->odi" etc.)
    s0 = -(E @ H.reshape(n_out * m, nf).T).real.reshape(-1, n_out, m)  # S_o generator
    Hk = H.transpose(2, 0, 1)  # (n_f, n_out, m)
    P = np.matmul(Hk.conj().transpose(0, 2, 1), Hk)  # sum_o conj(H_oi) H_oj per line
    t0 = (E @ P.reshape(nf, m * m)).real.reshape(-1, m, m)  # sum_o T_o generator
    idx = np.arange(pmax + 1)
    D = idx[None, :] - idx[:, None] + pmax  # (r, s) -> s - r + pmax
    R_full = r0[D]
    S_full = np.ascontiguousarray(s0[D].transpose(0, 2, 1, 3))  # (r, o, s, i)
    T_full = t0[D].transpose(0, 2, 1, 3)  # (r, i, s, j)
    out = []
    for p in o:
        q = int(p) + 1
        Rp = R_full[:q, :q]
        Sq = S_full[:q, :, :q, :].reshape(q, n_out * q * m)  # every output in one solve
        Tp = T_full[:q, :, :q, :].reshape(q * m, q * m)
        try:  # R = Re(X^H X) is SPD: sum_o S_o^T R^-1 S_o = W^T W with W = chol(R)^-1 S
            W = sla.solve_triangular(sla.cholesky(Rp, lower=True, check_finite=False), Sq,
                                     lower=True, check_finite=False).reshape(q * n_out, q * m)
            SRS = W.T @ W
        except np.linalg.LinAlgError:
            SRS = Sq.reshape(q * n_out, q * m).T @ np.linalg.solve(Rp, Sq).reshape(
                q * n_out, q * m)
        Mp = 2.0 * (Tp - SRS)  # reduced normal equations, M alpha = 0
        Mp = 0.5 * (Mp + Mp.T)
        a_low = np.linalg.lstsq(Mp[: m * p, : m * p], -Mp[: m * p, m * p :], rcond=None)[0]
        alpha = np.vstack([a_low, np.eye(m)])  # alpha_p = I
        z, L = _companion(alpha, m, int(p))
        with np.errstate(divide="ignore", invalid="ignore"):
            lam = -np.log(z.astype(np.complex128)) / dt_s  # Z = exp(-j w dt), Eq. (3)
        out.append((int(p), lam, L))
    return out


def polymax(
    H: ArrayLike,
    f_hz: ArrayLike,
    *,
    orders: ArrayLike,
    band_hz: tuple[float, float] | None = None,
    dt_s: float | None = None,
    lower: bool = True,
    upper: bool = True,
) -> PoleSweep:
    """PolyMAX (pLSCF) poles with LSFD mode shapes for every polynomial order.

    Parameters
    ----------
    H : array_like of complex, shape (n_out, n_in, n_f)
        FRFs (e.g. ``FRFEstimate.H1``), any consistent units.
    f_hz : array_like, shape (n_f,)
        Frequency lines in Hz.
    orders : array_like of int
        Polynomial orders p; the order-p model has p * n_in poles.
    band_hz : (float, float), optional
        Analysis band (default all lines with f > 0).
    dt_s : float, optional
        Sampling time of the basis of Eq. (3) of [002]; default ``1 / (2 f_max)`` of the
        band, which maps the band onto the upper half of the unit circle.
    lower, upper : bool
        Fit lower / upper residuals in the LSFD shapes (Eq. (5) of [002]).

    Returns
    -------
    PoleSweep
        ``method="polymax"``; standard deviations are NaN (not estimated).

    Raises
    ------
    ShapeError
        Bad shapes, or fewer lines in the band than the order needs.
    SignalError
        Non-finite FRF lines inside the band.
    OptionError
        Bad band or orders.

    Examples
    --------
    >>> lam = -0.2 + 2j * np.pi * 3.0
    >>> f = np.linspace(1.0, 5.0, 200)
    >>> s = 2j * np.pi * f
    >>> Hs = (1 / (s - lam) + 1 / (s - np.conj(lam)))[None, None, :]
    >>> sw = polymax(Hs, f, orders=[6, 8])
    >>> round(float(sw.poles[1].f_hz[0]), 4), round(float(sw.poles[1].zeta[0]), 5)
    (3.0002, 0.01061)
    """
    Ha = np.asarray(H, dtype=np.complex128)
    f = np.asarray(f_hz, dtype=np.float64)
    if Ha.ndim != 3 or f.shape != (Ha.shape[-1],):
        msg = f"H, f_hz: expected (n_out, n_in, n_f) and (n_f,), got {Ha.shape}, {f.shape}"
        raise ShapeError(msg)
    lo, hi = (float(f[f > 0].min()), float(f.max())) if band_hz is None else band_hz
    if not 0 <= lo < hi:
        msg = f"band_hz: expected 0 <= f_lo < f_hi, got {band_hz!r}"
        raise OptionError(msg)
    sel = (f >= lo) & (f <= hi) & (f > 0)
    Hb, fb = Ha[..., sel], f[sel]
    if not np.all(np.isfinite(Hb)):
        bad = fb[~np.all(np.isfinite(Hb), axis=(0, 1))]
        msg = f"H: expected finite FRF lines in the band, got NaN/Inf at {bad[:5].tolist()} Hz"
        raise SignalError(msg)
    m = Ha.shape[1]
    o = check_orders(orders, max((fb.size * Ha.shape[0]) // (m + 1) - 1, 1), "lines in band")
    if fb.size < 2 * int(o[-1]) + 2:
        msg = (
            f"H: expected at least {2 * int(o[-1]) + 2} lines in band {lo}-{hi} Hz, got {fb.size}"
        )
        raise ShapeError(msg)
    dt = 1.0 / (2.0 * float(fb.max())) if dt_s is None else float(dt_s)
    scale = float(np.sqrt(np.mean(np.abs(Hb) ** 2)))
    if scale == 0.0:
        msg = "H: expected a non-zero FRF in the band, got all zeros"
        raise SignalError(msg)
    sets = []
    n_out = Ha.shape[0]
    rhs = Hb.reshape(n_out * m, -1).T
    rhs_ri = np.vstack([rhs.real, rhs.imag])  # prepared once for the LSFD of every order
    for p, lam, _ in polymax_poles(Hb / scale, fb, o, dt):
        keep = np.isfinite(lam) & (lam.imag > 1e-12 * np.abs(lam))
        lk = lam[keep]
        w = np.abs(lk)
        fr, zr = w / (2 * np.pi), -lk.real / np.where(w > 0, w, 1.0)
        order = np.argsort(fr)
        lk, fr, zr = lk[order], fr[order], zr[order]
        if lk.size and 2 * fb.size >= 2 * lk.size + 4 * (lower + upper):
            shapes = lsfd_shapes(rhs_ri, fb, lk, n_out, m, lower=lower, upper=upper)
        else:
            shapes = np.full((Ha.shape[0], lk.size), np.nan + 0j)
        nan = np.full(fr.shape, np.nan)
        sets.append(PoleSet(p, fr, zr, shapes, nan, nan.copy()))
    return PoleSweep("polymax", o, tuple(sets), np.zeros(0), 0)
