r"""Poly-reference least-squares complex frequency-domain method (pLSCF / PolyMAX).

Eqs. (1)-(4) of [002] (Peeters et al., 2004). Right matrix-fraction model of the FRF row of
output o, Eq. (1): :math:`H_o(\omega) = B_o(\omega) A(\omega)^{-1}` with the polynomials
of Eq. (2), :math:`B_o = \sum_r Z^r \beta_{o,r}` (1 x m) and
:math:`A = \sum_r Z^r \alpha_r` (m x m), in the z-domain basis of Eq. (3),
:math:`Z(\omega) = e^{-j\omega\Delta t}`.

Linearised least squares: per output :math:`X = [Z^0 \cdots Z^p]` and
:math:`Y_o = -[Z^0 \cdots Z^p] \otimes H_o`; the normal matrices
:math:`R = \mathrm{Re}(X^H X)`, :math:`S_o = \mathrm{Re}(X^H Y_o)`,
:math:`T_o = \mathrm{Re}(Y_o^H Y_o)` are eliminated for the numerators, giving the reduced
normal equations :math:`M \alpha = 0`, :math:`M = 2 \sum_o (T_o - S_o^T R^{-1} S_o)`,
solved with :math:`\alpha_p = I`. Because :math:`\overline{Z^r} Z^s` depends on s - r
only, R, S_o and T_o are Toeplitz in the polynomial index and are built from 2p + 1 sums
over frequency; the matrices of every lower order are sub-blocks of those of the highest
order, so the frequency sums are done once for the whole stabilization diagram. The
elimination is order-recursive too: with one Cholesky factor of the highest-order R,
:math:`\sum_o S_o^T R^{-1} S_o` of every order is a cumulative sum of per-row Gram
matrices (:func:`_reduced_normal`), so the per-order work is one small solve and one
companion eigenvalue problem (no per-output products per order). Where R is too
ill-conditioned to factor (a sub-band's own basis covers only part of the unit circle), the
same lower factor and rows come from a QR of the basis (:func:`_orthogonal_rows`).

Poles and participation factors come from the companion matrix of Eq. (4); a root
:math:`z_r` of :math:`\det A(z)` gives :math:`\lambda_r = -\ln(z_r) / \Delta t`
(Eq. (3)). Mode shapes per order follow from LSFD, Eq. (5) of [002]
(:func:`modal_twin.identification.lsfd.lsfd`), or, with ``shapes="numerator"``, from the
numerator polynomials at the poles, with LSFD afterwards for the selected modes only
(:func:`modal_twin.identification.lsfd.lsfd_modes`).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import scipy.linalg as sla
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import ArrayLike

from modal_twin._types import ComplexArray, FloatArray
from modal_twin.errors import OptionError, ShapeError, SignalError
from modal_twin.identification._subspace import check_orders
from modal_twin.identification.lsfd import lsfd_shapes
from modal_twin.identification.modal_model import PoleSet, PoleSweep, normalize_shapes
from modal_twin.progress import track

__all__ = ["polymax", "polymax_poles"]


def _companion(
    alpha: FloatArray, m: int, p: int, participation: bool
) -> tuple[ComplexArray, ComplexArray]:
    """Eigen-decomposition of the block companion matrix, Eq. (4) of [002]."""
    Cm = np.zeros((m * p, m * p))
    Cm[: m * (p - 1), m:] = np.eye(m * (p - 1))
    Cm[m * (p - 1) :, :] = -alpha[: m * p].T  # last block row: -alpha_0 ... -alpha_{p-1}
    if not participation:
        return np.asarray(np.linalg.eigvals(Cm), dtype=np.complex128), np.zeros((m, 0), complex)
    z, V = np.linalg.eig(Cm)
    return z, V[:m]  # first block of the eigenvectors = participation factors


def _orthogonal_rows(H: ComplexArray, th: FloatArray, q: int) -> tuple[FloatArray, FloatArray]:
    r""":math:`L` and :math:`W = L^{-1} S` of :func:`_reduced_normal` from a QR of the basis.

    A sub-band fitted with its own basis (:math:`\Delta t = 1 / 2 f_{\max}` of the band,
    Eq. (3) of [002]) covers only the arc :math:`[\pi f_{\min} / f_{\max}, \pi]` of the
    unit circle, on which the powers :math:`Z^0 \ldots Z^p` are nearly dependent: the
    condition number of :math:`R = \mathrm{Re}(X^H X)` grows geometrically with the order
    (1e8 at p = 16 over an octave widened by 15 % on each side, beyond 1e16 at p = 20 over
    8.6-15 Hz) and its Cholesky factorisation fails. The Householder QR of the real-stacked
    basis :math:`[\mathrm{Re}\,X; \mathrm{Im}\,X] = Q R_q` needs only the square root of
    that condition number: :math:`L = R_q^T` and :math:`W = L^{-1} S = Q^T Y`, i.e.
    :math:`W_{r,(o,s,i)} = -\mathrm{Re} \sum_k \overline{Q_{c,kr}} Z_k^s H_{oi,k}` with
    :math:`Q_c` the complex form of :math:`Q`. Its leading columns span the leading
    columns of :math:`X`, so the cumulative per-row Gram sums of every lower order hold
    as with the Cholesky factor.
    """
    n_out, m, nf = H.shape
    Z = np.exp(-1j * np.outer(th, np.arange(q)))  # (n_f, q): Z_k^s
    Q, Rq = np.linalg.qr(np.vstack([Z.real, Z.imag]))
    Qc = Q[:nf] + 1j * Q[nf:]
    Hf = H.reshape(n_out * m, nf).T  # (n_f, (o, i))
    W = np.empty((q, q, n_out, m))
    for r in range(q):  # one row of Q^T Y at a time: (s, (o, i))
        W[r] = -((Qc[:, r].conj()[:, None] * Z).T @ Hf).real.reshape(q, n_out, m)
    return np.ascontiguousarray(Rq.T), W.transpose(0, 2, 1, 3).reshape(q, n_out * q * m)


def _reduced_normal(
    H: ComplexArray, f_hz: FloatArray, pmax: int, dt_s: float
) -> tuple[FloatArray, FloatArray, FloatArray | None, FloatArray]:
    r"""Blocks of every order's reduced normal matrix, from one pass over the data.

    Returns ``T`` (q m x q m, q = pmax + 1), ``C`` (q, q m, q m), a lower factor L of
    :math:`R = L L^T` (Cholesky; from a QR of the basis where R is too ill-conditioned to
    factor, :func:`_orthogonal_rows`) and :math:`W = L^{-1} S` as (q, n_out, q m),
    such that the order-p
    reduced normal matrix is :math:`M_p = 2 (T - C_{p})_{[:(p+1) m, :(p+1) m]}`, i.e.
    :math:`\sum_o S_o^T R^{-1} S_o` for every order at once: with :math:`R = L L^T`
    (Cholesky of the highest order), :math:`R_{:q,:q} = L_{:q,:q} L_{:q,:q}^T` and
    :math:`(L^{-1} S_o)_{:q}` only involves rows :q of :math:`S_o`, so
    :math:`\sum_o S_o^T R_q^{-1} S_o = \sum_{r<q} G_r` restricted to the first q block
    columns, with the per-row Gram matrices :math:`G_r = \sum_o w_{o,r}^T w_{o,r}`
    (cumulative sums :math:`C_p = \sum_{r \le p} G_r`).
    """
    n_out, m, nf = H.shape
    q = pmax + 1
    th = 2 * np.pi * f_hz * dt_s
    d = np.arange(q)
    Cs, Sn = np.cos(np.outer(d, th)), np.sin(np.outer(d, th))  # Z^(s-r) = cos - j sin
    # Re(sum_k Z_k^(+-d) H_k) = sum_k cos(d th_k) Re H_k +- sin(d th_k) Im H_k: one real GEMM
    # on the interleaved (re, im) view of H against [cos, +-sin]
    Wcs = np.empty((nf, 2, 2 * q))
    Wcs[:, 0, :q] = Wcs[:, 0, q:] = Cs.T
    Wcs[:, 1, :q], Wcs[:, 1, q:] = Sn.T, -Sn.T
    Hc = np.ascontiguousarray(H)
    Hri = Hc.reshape(n_out * m, nf).view(np.float64)  # (o i, 2 n_f)
    ab = Hri @ Wcs.reshape(2 * nf, 2 * q)  # [:, :q] = a + b (lag +d), [:, q:] = a - b (-d)
    s0 = -np.concatenate([ab[:, q + 1 :][:, ::-1], ab[:, :q]], axis=1).T.reshape(-1, n_out, m)
    # sum_o conj(H_oi) H_oj = Pr + j Pi per line (upper triangle, then Hermitian)
    Pc = np.empty((nf, m, m), dtype=np.complex128)
    for a in range(m):
        for b in range(a, m):
            Pc[:, a, b] = (Hc[:, a].conj() * Hc[:, b]).sum(axis=0)
            Pc[:, b, a] = Pc[:, a, b].conj()
    ta, tb = Cs @ Pc.real.reshape(nf, m * m), Sn @ Pc.imag.reshape(nf, m * m)
    t0 = np.concatenate([(ta - tb)[:0:-1], ta + tb]).reshape(-1, m, m)
    r0 = Cs.sum(axis=1)
    idx = np.arange(q)
    R = r0[np.abs(idx[None, :] - idx[:, None])]
    # Toeplitz in the polynomial index, entry (r, s) = lag s - r (index s - r + pmax): views
    # T4[r, ..., s] = x[pmax - r + s] of the lag arrays, copied once into the layout
    S = (sliding_window_view(s0, q, axis=0)[::-1].transpose(0, 1, 3, 2)
         .reshape(q, n_out * q * m))  # (r, (o, s, i))
    T = (sliding_window_view(t0, q, axis=0)[::-1].transpose(0, 1, 3, 2)
         .reshape(q * m, q * m))  # (r, i, s, j)
    Lc: FloatArray | None = None
    try:  # R = Re(X^H X) is SPD
        Lc = sla.cholesky(R, lower=True, check_finite=False)
        # W = L^-1 S solved on the transposed (Fortran-ordered) layout: X L^T = S^T, no copy
        W = sla.blas.dtrsm(1.0, Lc, S.T, side=1, lower=1, trans_a=1, overwrite_b=1).T
    except np.linalg.LinAlgError:  # R too ill-conditioned to factor: QR of the basis itself
        Lc, W = _orthogonal_rows(Hc, th, q)
    W3 = W.reshape(q, n_out, q * m)
    # cumulative sum of the per-row Gram matrices (one batched product)
    C = np.cumsum(np.matmul(W3.transpose(0, 2, 1), W3), axis=0)
    return T, C, Lc, W3


def polymax_poles(
    H: ComplexArray,
    f_hz: FloatArray,
    orders: ArrayLike,
    dt_s: float,
    *,
    participation: bool = True,
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
    participation : bool
        Also return the participation factors (eigenvectors of the companion matrix);
        False returns poles only (eigenvalues), with L of shape (n_in, 0).

    Returns
    -------
    list of (p, lambda (n,), L (n_in, n)) with all poles (both of each pair).
    """
    return [(p, lam, L) for p, lam, L, _ in _sweep(H, f_hz, orders, dt_s, participation)]


def _numerator_shapes(
    z: ComplexArray, alpha: FloatArray, Lc: FloatArray, W3: FloatArray, p: int
) -> ComplexArray:
    r"""Shapes :math:`\psi_r = B(z_r) v_r` with :math:`A(z_r) v_r = 0`, Eqs. (1)-(2) of [002].

    Near a root :math:`z_r` of :math:`\det A`, :math:`A(z)^{-1} \approx v_r w_r^T /
    (c_r (z - z_r))`, so the FRF row :math:`H_o = B_o A^{-1}` has residue
    :math:`\propto B_o(z_r) v_r`. The numerators are eliminated in the reduced normal
    equations and recovered here as :math:`\beta_o = -R^{-1} S_o \alpha`.
    """
    m = alpha.shape[1]
    q = p + 1
    Wa = W3[:q, :, : q * m] @ alpha  # (q, n_out, m) = L^-1 S_o alpha
    beta = -sla.solve_triangular(Lc[:q, :q].T, Wa.reshape(q, -1), lower=False,
                                 check_finite=False).reshape(q, -1, m)
    Vz = z[:, None] ** np.arange(q)[None, :]  # (n_poles, q): z_r^k
    A = np.einsum("pk,kij->pij", Vz, alpha.reshape(q, m, m))
    v = np.linalg.svd(A)[2][:, -1, :].conj()  # right null vectors of A(z_r)
    B = np.einsum("pk,koi->poi", Vz, beta)
    out: ComplexArray = np.einsum("poi,pi->op", B, v)
    return out


def _sweep(
    H: ComplexArray,
    f_hz: FloatArray,
    orders: ArrayLike,
    dt_s: float,
    participation: bool,
    numerator: bool = False,
) -> list[tuple[int, ComplexArray, ComplexArray, ComplexArray | None]]:
    """Poles (+ participation factors, + numerator shapes) of every order."""
    m = H.shape[1]
    o = np.asarray(orders, dtype=np.int64)
    T, C, Lc, W3 = _reduced_normal(H, f_hz, int(o.max()), dt_s)
    out = []
    for p in track(o, "polynomial orders", unit="order"):
        mp, qm = m * int(p), m * (int(p) + 1)
        Mp = 2.0 * (T[:qm, :qm] - C[int(p), :qm, :qm])  # reduced normal equations
        Mp = 0.5 * (Mp + Mp.T)
        try:
            a_low = np.linalg.solve(Mp[:mp, :mp], -Mp[:mp, mp:])
        except np.linalg.LinAlgError:
            a_low = np.linalg.lstsq(Mp[:mp, :mp], -Mp[:mp, mp:], rcond=None)[0]
        alpha = np.vstack([a_low, np.eye(m)])  # alpha_p = I
        z, L = _companion(alpha, m, int(p), participation)
        with np.errstate(divide="ignore", invalid="ignore"):
            # Z = exp(-j w dt), Eq. (3)
            lam = np.asarray(-np.log(z.astype(np.complex128)) / dt_s, dtype=np.complex128)
            psi = (
                _numerator_shapes(z, alpha, Lc, W3, int(p))
                if numerator and Lc is not None and np.all(np.isfinite(z))
                else None
            )
        out.append((int(p), lam, L, psi))
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
    shapes: Literal["lsfd", "numerator"] = "lsfd",
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
    shapes : {"lsfd", "numerator"}
        ``"lsfd"``: LSFD shapes (Eq. (5) of [002]) at every order. ``"numerator"``:
        shapes :math:`B(z_r) v_r` from the fitted numerator polynomials (Eqs. (1)-(2)),
        nearly free and good enough for the MAC of the stabilization diagram; then
        :func:`~modal_twin.identification.lsfd.lsfd_modes` fits LSFD shapes for the
        selected modes only (several times faster for many FRFs and orders).

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
    if shapes not in ("lsfd", "numerator"):
        msg = f"shapes: expected one of ['lsfd', 'numerator'], got {shapes!r}"
        raise OptionError(msg)
    numerator = shapes == "numerator"
    sets = []
    n_out = Ha.shape[0]
    rhs = Hb.reshape(n_out * m, -1).T
    rhs_ri = np.vstack([rhs.real, rhs.imag])  # prepared once for the LSFD of every order
    for p, lam, _, psi in _sweep(Hb / scale, fb, o, dt, False, numerator):
        keep = np.isfinite(lam) & (lam.imag > 1e-12 * np.abs(lam))
        lk = lam[keep]
        w = np.abs(lk)
        fr, zr = w / (2 * np.pi), -lk.real / np.where(w > 0, w, 1.0)
        order = np.argsort(fr)
        lk, fr, zr = lk[order], fr[order], zr[order]
        if numerator and psi is not None:
            phi = normalize_shapes(psi[:, keep][:, order])
        elif not numerator and lk.size and 2 * fb.size >= 2 * lk.size + 4 * (lower + upper):
            phi = lsfd_shapes(rhs_ri, fb, lk, n_out, m, lower=lower, upper=upper)
        else:
            phi = np.full((Ha.shape[0], lk.size), np.nan + 0j)
        nan = np.full(fr.shape, np.nan)
        sets.append(PoleSet(p, fr, zr, phi, nan, nan.copy()))
    return PoleSweep("polymax", o, tuple(sets), np.zeros(0), 0)
