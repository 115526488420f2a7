r"""Least-squares frequency-domain (LSFD) estimation of residues, Eq. (5) of [002].

With the poles :math:`\lambda_r` fixed (from PolyMAX or SSI), the FRF model

.. math:: H(\omega) = \sum_{r=1}^{N} \left[\frac{R_r}{j\omega - \lambda_r}
          + \frac{R_r^*}{j\omega - \lambda_r^*}\right] - \frac{R_L}{\omega^2} + R_U

with residues :math:`R_r = \psi_r L_r^T` is linear in the real and imaginary parts of
:math:`R_r` and in the lower / upper residuals :math:`R_L, R_U` (complex here). All FRFs
share one design matrix, so one real least-squares solve with n_out * n_in right-hand
sides gives every residue. Mode shapes :math:`\psi_r` and participation factors
:math:`L_r` are the rank-1 factors (dominant singular pair) of :math:`R_r`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg as sla
from numpy.typing import ArrayLike, NDArray

from modal_twin._types import ComplexArray, FloatArray
from modal_twin.errors import ShapeError, SignalError
from modal_twin.identification.modal_model import ModalModel, normalize_shapes

__all__ = ["LSFDResult", "lsfd", "lsfd_modes", "lsfd_shapes", "rank1_factors"]


@dataclass(frozen=True, slots=True)
class LSFDResult:
    r"""Residues, shapes and residuals of :func:`lsfd`.

    Attributes
    ----------
    residues : ndarray of complex, shape (n_modes, n_out, n_in)
    shapes : ndarray of complex, shape (n_out, n_modes)
        Normalised mode shapes (largest entry 1).
    participation : ndarray of complex, shape (n_in, n_modes)
    lower : ndarray of complex, shape (n_out, n_in)
        Lower residual :math:`R_L` (zeros when not fitted).
    upper : ndarray of complex, shape (n_out, n_in)
        Upper residual :math:`R_U` (zeros when not fitted).
    rel_residual : float
        :math:`\|H - \hat H\| / \|H\|` over the fitted lines.
    """

    residues: ComplexArray
    shapes: ComplexArray
    participation: ComplexArray
    lower: ComplexArray
    upper: ComplexArray
    rel_residual: float


def lsfd(
    H: ArrayLike,
    f_hz: ArrayLike,
    poles: ArrayLike,
    *,
    lower: bool = True,
    upper: bool = True,
) -> LSFDResult:
    r"""Fit residues and residuals of Eq. (5) of [002] to FRFs for known poles.

    Parameters
    ----------
    H : array_like of complex, shape (n_out, n_in, n_f)
        FRFs on the lines ``f_hz`` (only finite lines with f > 0 are used).
    f_hz : array_like, shape (n_f,)
    poles : array_like of complex, shape (n_modes,)
        Continuous-time poles :math:`\lambda_r` in rad/s (one per conjugate pair).
    lower, upper : bool
        Fit the lower (:math:`-R_L / \omega^2`) and upper (:math:`R_U`) residuals.

    Returns
    -------
    LSFDResult

    Raises
    ------
    ShapeError
        Inconsistent shapes or fewer usable lines than unknowns.
    SignalError
        Non-finite poles.

    Examples
    --------
    >>> lam = -0.1 + 2j * np.pi
    >>> f = np.linspace(0.5, 1.5, 50)
    >>> s = 2j * np.pi * f
    >>> Hs = (1 / (s - lam) + 1 / (s - np.conj(lam)))[None, None, :]
    >>> r = lsfd(Hs, f, [lam])
    >>> round(float(abs(r.residues[0, 0, 0])), 6)
    1.0
    """
    Ha = np.asarray(H, dtype=np.complex128)
    f = np.asarray(f_hz, dtype=np.float64)
    lam = np.atleast_1d(np.asarray(poles, dtype=np.complex128))
    if Ha.ndim != 3 or f.shape != (Ha.shape[2],) or lam.ndim != 1:
        msg = (
            f"H, f_hz, poles: expected (n_out, n_in, n_f), (n_f,), (n_modes,), got "
            f"{Ha.shape}, {f.shape}, {lam.shape}"
        )
        raise ShapeError(msg)
    if not np.all(np.isfinite(lam)):
        msg = "poles: expected finite poles, got NaN/Inf"
        raise SignalError(msg)
    n_out, n_in, _ = Ha.shape
    use = (f > 0) & np.all(np.isfinite(Ha), axis=(0, 1))
    s = 2j * np.pi * f[use]
    n_unk = 2 * lam.size + 2 * (int(lower) + int(upper))
    if 2 * s.size < n_unk:
        msg = f"H: expected at least {n_unk // 2 + 1} finite lines with f > 0, got {s.size}"
        raise ShapeError(msg)
    rhs = Ha[..., use].reshape(n_out * n_in, -1).T
    D, x = _solve(s, lam, np.vstack([rhs.real, rhs.imag]), lower, upper)
    nm = lam.size
    Rr = (x[:nm] + 1j * x[nm : 2 * nm]).reshape(nm, n_out, n_in)
    k = 2 * nm
    RL = np.zeros((n_out, n_in), complex)
    RU = np.zeros((n_out, n_in), complex)
    if lower:
        RL = (x[k] + 1j * x[k + 1]).reshape(n_out, n_in)
        k += 2
    if upper:
        RU = (x[k] + 1j * x[k + 1]).reshape(n_out, n_in)
    model = (D @ x).T.reshape(n_out, n_in, -1)
    res = float(np.linalg.norm(model - Ha[..., use])
                / max(float(np.linalg.norm(Ha[..., use])), 1e-300))
    psi, L = rank1_factors(Rr)
    return LSFDResult(Rr, normalize_shapes(psi), L, RL, RU, res)


def _solve(
    s: ComplexArray, lam: ComplexArray, rhs_ri: FloatArray, lower: bool, upper: bool
) -> tuple[ComplexArray, FloatArray]:
    """Design matrix of Eq. (5) of [002] and the real least-squares solution.

    ``rhs_ri`` is ``[Re H; Im H]`` with lines on the rows (shape (2 n_f, n_frf)); returns
    the complex design matrix D (n_f, n_unk) and the stacked unknowns x (n_unk, n_frf).
    """
    a = 1.0 / (s[:, None] - lam[None, :])  # Eq. (5) of [002]
    b = 1.0 / (s[:, None] - lam.conj()[None, :])
    cols: list[NDArray[np.inexact]] = [a + b, 1j * (a - b)]
    if lower:
        w2 = -1.0 / (s.imag**2)
        cols += [w2[:, None], 1j * w2[:, None]]
    if upper:
        one = np.ones((s.size, 1))
        cols += [one, 1j * one]
    D = np.concatenate(cols, axis=1)
    Dr = np.vstack([D.real, D.imag])
    cn = np.linalg.norm(Dr, axis=0)
    cn = np.where(cn > 0, cn, 1.0)
    Dn = Dr / cn
    q, r = np.linalg.qr(Dn)  # Householder QR: the least-squares solution of lstsq when
    d = np.abs(np.diag(r))  # Dn has full column rank, at half the cost of its SVD
    if d.size and d.min() > 1e-10 * d.max():
        x = sla.solve_triangular(r, q.T @ rhs_ri, check_finite=False)
    else:  # (near) rank deficient, e.g. repeated poles: minimum-norm solution
        x = np.linalg.lstsq(Dn, rhs_ri, rcond=None)[0]
    return D, x / cn[:, None]


def rank1_factors(Rr: ComplexArray) -> tuple[ComplexArray, ComplexArray]:
    """Return shapes psi (n_out, n_modes) and participations L (n_in, n_modes) of residues.

    R_r = psi_r L_r^T: the dominant singular pair of each (n_out, n_in) residue matrix.
    """
    U, sv, Vh = np.linalg.svd(Rr)
    return (U[:, :, 0] * sv[:, :1]).T, Vh[:, 0, :].T


def lsfd_shapes(
    rhs_ri: FloatArray, f_hz: FloatArray, poles: ComplexArray, n_out: int, n_in: int,
    *, lower: bool = True, upper: bool = True,
) -> ComplexArray:
    """Normalised LSFD mode shapes only (the fast path used per order by PolyMAX).

    Same solution as :func:`lsfd` for finite lines with f > 0; ``rhs_ri`` is the stacked
    ``[Re H; Im H]`` of shape (2 n_f, n_out * n_in), prepared once for every order.
    """
    nm = poles.size
    _, x = _solve(np.asarray(2j * np.pi * f_hz, dtype=np.complex128), poles, rhs_ri, lower, upper)
    Rr = (x[:nm] + 1j * x[nm : 2 * nm]).reshape(nm, n_out, n_in)
    return normalize_shapes(rank1_factors(Rr)[0])


def lsfd_modes(
    model: ModalModel, H: ArrayLike, f_hz: ArrayLike, *, lower: bool = True, upper: bool = True
) -> ModalModel:
    r"""Return the same modes with LSFD shapes (Eq. (5) of [002]) fitted for those poles only.

    Use after ``select_modes(stabilization_diagram(polymax(..., shapes="numerator")))``:
    one LSFD solve for the selected poles instead of one per model order.

    Parameters
    ----------
    model : ModalModel
        Selected modes; their poles are :math:`\lambda = 2\pi f (-\zeta + j
        \sqrt{1 - \zeta^2})`.
    H : array_like of complex, shape (n_out, n_in, n_f)
        FRFs (the band used for the poles, or wider).
    f_hz : array_like, shape (n_f,)
    lower, upper : bool
        Fit lower / upper residuals.

    Returns
    -------
    ModalModel
        ``model`` with ``shapes`` replaced (normalised, largest entry 1).

    Raises
    ------
    ShapeError, SignalError
        As :func:`lsfd`.
    """
    if model.f_hz.size == 0:
        return model
    w = 2 * np.pi * model.f_hz
    z = model.zeta
    lam = w * (-z + 1j * np.sqrt(np.clip(1.0 - z**2, 0.0, None)))
    return replace(model, shapes=lsfd(H, f_hz, lam, lower=lower, upper=upper).shapes)
