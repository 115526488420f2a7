"""Modal metrics: MAC, AutoMAC, MPC and modal complexity (Eqs. (6)-(9) of [002]).

All functions take mode shapes with channels on the first axis and modes on the last; a
1-D vector is one mode.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from modal_twin._types import ComplexArray, FloatArray
from modal_twin.errors import ShapeError, SignalError

__all__ = ["automac", "complexity", "mac", "mac_measured", "mpc"]


def _shapes(phi: ArrayLike, name: str) -> ComplexArray:
    a = np.asarray(phi, dtype=np.complex128)
    if a.ndim == 1:
        a = a[:, np.newaxis]
    if a.ndim != 2 or a.shape[0] < 1:
        msg = f"{name}: expected shape (n_ch, n_modes) or (n_ch,), got {a.shape}"
        raise ShapeError(msg)
    if not np.all(np.isfinite(a)):
        msg = f"{name}: expected finite mode shapes, got NaN/Inf"
        raise SignalError(msg)
    return a


def mac(phi_a: ArrayLike, phi_b: ArrayLike) -> FloatArray:
    r"""Modal Assurance Criterion matrix, Eq. (6) of [002] (Eq. (3) of [000]).

    .. math:: \mathrm{MAC}_{kl} = \frac{|\phi_k^H \psi_l|^2}
              {(\phi_k^H \phi_k)(\psi_l^H \psi_l)}

    Parameters
    ----------
    phi_a : array_like, shape (n_ch, n_a) or (n_ch,)
    phi_b : array_like, shape (n_ch, n_b) or (n_ch,)

    Returns
    -------
    ndarray, shape (n_a, n_b)
        Always 2-D, entries in [0, 1]; 0 where a shape is all zero.

    Raises
    ------
    ShapeError
        Different channel counts or rank > 2.

    Examples
    --------
    >>> mac([1.0, 0.0], [[1.0, 1.0], [0.0, 1.0]]).round(3)
    array([[1. , 0.5]])
    """
    a, b = _shapes(phi_a, "phi_a"), _shapes(phi_b, "phi_b")
    if a.shape[0] != b.shape[0]:
        msg = f"phi_b: expected {a.shape[0]} channels as phi_a, got {b.shape[0]}"
        raise ShapeError(msg)
    # scale each shape by its largest entry first (MAC is scale invariant): no under/overflow
    a = a / np.where((ma := np.abs(a).max(axis=0)) > 0, ma, 1.0)
    b = b / np.where((mb := np.abs(b).max(axis=0)) > 0, mb, 1.0)
    num = np.abs(a.conj().T @ b) ** 2  # Eq. (6) of [002]
    na = np.sum(np.abs(a) ** 2, axis=0)
    nb = np.sum(np.abs(b) ** 2, axis=0)
    den = np.outer(na, nb)
    out: FloatArray = np.clip(np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0), 0, 1)
    return out


def automac(phi: ArrayLike) -> FloatArray:
    """MAC of a set of shapes against itself, shape (n_modes, n_modes), unit diagonal."""
    return mac(phi, phi)


def mac_measured(phi_a: ArrayLike, phi_b: ArrayLike) -> FloatArray:
    """MAC (:func:`mac`) of each pair of shapes over the entries both have measured.

    NaN marks an entry not measured (a mode some roving setups lacked, merged from the
    others: :func:`~modal_twin.identification.setups.merge_setups`); each pair's MAC is
    taken over the channels finite in both, NaN where they share none.
    """
    a = np.asarray(phi_a, dtype=np.complex128)
    b = np.asarray(phi_b, dtype=np.complex128)
    a, b = (a[:, None] if a.ndim == 1 else a), (b[:, None] if b.ndim == 1 else b)
    if a.ndim != 2 or b.ndim != 2 or a.shape[0] != b.shape[0]:
        msg = f"mac_measured: expected shapes over the same channels, got {a.shape}, {b.shape}"
        raise ShapeError(msg)
    out = np.full((a.shape[1], b.shape[1]), np.nan)
    for k in range(a.shape[1]):
        for m in range(b.shape[1]):
            both = np.isfinite(a[:, k]) & np.isfinite(b[:, m])
            if both.any():
                out[k, m] = mac(a[both, k], b[both, m])[0, 0]
    return out


def mpc(phi: ArrayLike) -> FloatArray:
    """Modal Phase Collinearity, Eqs. (7)-(9) of [002] (Reynders et al., 2012).

    Eq. (7) as printed yields the energy fraction :math:`e = l_1 / (l_1 + l_2)` of one
    principal axis of the entries' scatter in the complex plane (which axis depends on the
    sign convention of Eq. (9)); the collinearity returned is
    :math:`(1 - 2e)^2 = ((l_1 - l_2) / (l_1 + l_2))^2`, independent of that convention.

    1 for a mode whose entries all lie on one line in the complex plane (real or
    monophase mode), down to 0 for a circularly spread one.

    Parameters
    ----------
    phi : array_like, shape (n_ch, n_modes) or (n_ch,)

    Returns
    -------
    ndarray, shape (n_modes,)

    Examples
    --------
    >>> mpc(np.array([1.0, -2.0, 0.5]) * np.exp(0.3j)).round(6)
    array([1.])
    """
    a = _shapes(phi, "phi")
    re, im = a.real, a.imag
    sxx = np.sum(re * re, axis=0)
    syy = np.sum(im * im, axis=0)
    sxy = np.sum(re * im, axis=0)
    tot = sxx + syy
    e7 = np.where(tot > 0, sxx / np.where(tot > 0, tot, 1.0), 0.5)  # no cross term
    cross = np.abs(sxy) > 1e-14 * np.where(tot > 0, tot, 1.0)
    z = (syy[cross] - sxx[cross]) / (2.0 * sxy[cross])  # Eq. (8) of [002]
    th = np.arctan(np.abs(z) + np.sign(z) * np.sqrt(1.0 + z**2))  # Eq. (9) of [002]
    e7[cross] = (sxx[cross] + sxy[cross] * (2.0 * (z**2 + 1.0) * np.sin(th) ** 2 - 1.0) / z) / tot[
        cross
    ]  # Eq. (7) of [002]
    # Eq. (7) gives the energy fraction on one principal axis of the complex-plane scatter,
    # e = l_1 / (l_1 + l_2); the collinearity (1 - 2 e)^2 = ((l_1 - l_2) / (l_1 + l_2))^2 is
    # the same for either axis (Reynders et al., 2012), 1 for a monophase mode.
    out = (1.0 - 2.0 * e7) ** 2
    out[tot == 0] = 0.0
    res: FloatArray = np.clip(out, 0.0, 1.0)
    return res


def complexity(phi: ArrayLike) -> FloatArray:
    """Modal complexity factor MCF = 1 - MPC (0 = real / monophase mode), shape (n_modes,)."""
    return 1.0 - mpc(phi)
