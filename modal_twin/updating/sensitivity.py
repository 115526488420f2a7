"""Eigenvalue and eigenvector derivatives of ``K phi = lambda M phi`` (Fox-Kapoor, Nelson).

For a mass-normalised mode ``(lambda_j, phi_j)`` and a parameter ``theta_i`` with
``K_i = dK/dtheta_i``, ``M_i = dM/dtheta_i``:

* eigenvalue (Fox and Kapoor 1968)::

      d lambda_j = phi_j' (K_i - lambda_j M_i) phi_j

* eigenvector, Nelson's method (1976): with ``F = -(K_i - lambda_j M_i - d lambda_j M) phi_j``
  solve ``(K - lambda_j M) v = F`` with the entry ``k`` of largest ``|phi_j|`` held at zero
  (row and column ``k`` replaced by the identity), then
  ``d phi_j = v + c phi_j`` with ``c = -phi_j' M v - phi_j' M_i phi_j / 2``. Exact, one
  factorisation per mode.
* eigenvector, Fox-Kapoor modal expansion (truncated to the modes given)::

      d phi_j = sum_{r != j} phi_r (phi_r' F_0) / (lambda_r - lambda_j)
                - phi_j (phi_j' M_i phi_j) / 2

  with ``F_0 = -(K_i - lambda_j M_i) phi_j``; exact only with all modes.

The frequency derivative follows from ``f = sqrt(lambda) / 2 pi``:
``df = d lambda / (8 pi^2 f)``. Distinct eigenvalues are assumed (a repeated pair makes
Nelson's matrix singular and raises :class:`ModelError`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from modal_twin._types import FloatArray, IntArray, Matrix
from modal_twin.errors import ModelError, OptionError, ShapeError

__all__ = ["EigenDerivatives", "eigen_derivatives"]



@dataclass(frozen=True, slots=True)
class EigenDerivatives:
    """Derivatives of the selected modes with respect to every parameter.

    Attributes
    ----------
    dlam : (n_modes, n_theta) float array
        ``d lambda_j / d theta_i`` (rad^2/s^2 per parameter unit).
    df_hz : (n_modes, n_theta) float array
        ``d f_j / d theta_i``, Hz per parameter unit.
    dPhi : (n_rows, n_modes, n_theta) float array
        ``d phi_j / d theta_i`` on the requested rows (all DOFs by default).
    method : str
        ``"nelson"`` or ``"fox"``.
    """

    dlam: FloatArray
    df_hz: FloatArray
    dPhi: FloatArray  # noqa: N815 (matrix symbol)
    method: str


def _mul(A: Matrix | None, x: FloatArray) -> FloatArray:
    if A is None:
        return np.zeros_like(x)
    return np.asarray(A @ x, dtype=float)


def eigen_derivatives(
    K: Matrix, M: Matrix, lam: FloatArray, Phi: FloatArray,
    dK: Sequence[Matrix | None], dM: Sequence[Matrix | None] | None = None, *,
    rows: IntArray | None = None, method: Literal["nelson", "fox"] = "nelson",
) -> EigenDerivatives:
    """Return eigenvalue and eigenvector derivatives of the given modes.

    Parameters
    ----------
    K, M : (n, n) sparse or dense arrays
        Stiffness and mass at the current parameters (``M`` may be semi-definite).
    lam : (m,) float array
        Eigenvalues ``omega^2`` of the modes to differentiate (distinct).
    Phi : (n, m) float array
        Their mass-normalised shapes.
    dK : sequence of (n, n) matrices or None
        ``dK/dtheta_i`` (None: zero).
    dM : sequence of (n, n) matrices or None, optional
        ``dM/dtheta_i``; default all zero.
    rows : int array, optional
        DOFs on which ``dPhi`` is returned (e.g. the measured ones); default all.
    method : {"nelson", "fox"}
        Eigenvector derivative (module docstring). ``"fox"`` is truncated to ``Phi``.

    Returns
    -------
    EigenDerivatives

    Raises
    ------
    ShapeError
        Inconsistent sizes.
    OptionError
        Unknown method.
    ModelError
        ``K - lambda_j M`` singular after Nelson's constraint (repeated eigenvalue).

    Examples
    --------
    >>> K = np.diag([2.0, 5.0]); M = np.eye(2)
    >>> d = eigen_derivatives(K, M, np.array([2.0]), np.array([[1.0], [0.0]]),
    ...                       [np.diag([1.0, 0.0])])
    >>> float(d.dlam[0, 0])
    1.0
    """
    if method not in ("nelson", "fox"):
        msg = f"method: expected one of ['nelson', 'fox'], got {method!r}"
        raise OptionError(msg)
    lam = np.asarray(lam, dtype=float).ravel()
    Phi = np.asarray(Phi, dtype=float)
    n = K.shape[0]
    if Phi.ndim != 2 or Phi.shape != (n, lam.size):
        msg = f"Phi: expected ({n}, {lam.size}), got {Phi.shape}"
        raise ShapeError(msg)
    p = len(dK)
    dMs: Sequence[Matrix | None] = [None] * p if dM is None else dM
    if len(dMs) != p:
        msg = f"dM: expected {p} matrices as dK, got {len(dMs)}"
        raise ShapeError(msg)
    sel = np.arange(n) if rows is None else np.asarray(rows, dtype=np.int64)
    m = lam.size
    dlam = np.zeros((m, p))
    dPhi = np.zeros((sel.size, m, p))
    MPhi = np.asarray(M @ Phi, dtype=float)
    for j in range(m):
        phi = Phi[:, j]
        kphi = np.stack([_mul(A, phi) for A in dK], axis=1)  # (n, p)
        mphi = np.stack([_mul(B, phi) for B in dMs], axis=1)
        F0 = -(kphi - lam[j] * mphi)
        dlam[j] = -phi @ F0  # Fox-Kapoor: phi' (K_i - lambda M_i) phi
        pmp = phi @ mphi  # phi' M_i phi
        if method == "fox":
            others = np.arange(m) != j
            gap = lam[others] - lam[j]
            coef = (Phi[:, others].T @ F0) / gap[:, None]  # (m - 1, p)
            d = Phi[:, others] @ coef - 0.5 * np.outer(phi, pmp)
            dPhi[:, j, :] = d[sel]
            continue
        F = F0 + np.outer(MPhi[:, j], dlam[j])  # Nelson's right-hand side
        V = _nelson_solve(K, M, lam[j], phi, F, j)
        V = np.asarray(V).reshape(n, p)
        if not np.all(np.isfinite(V)):
            msg = f"mode {j} (lambda {lam[j]:.6g}): Nelson solve not finite (repeated mode?)"
            raise ModelError(msg)
        c = -(MPhi[:, j] @ V) - 0.5 * pmp  # Nelson: mass-normalisation constant
        dPhi[:, j, :] = (V + np.outer(phi, c))[sel]
    f = np.sqrt(np.clip(lam, 0.0, None)) / (2.0 * np.pi)
    with np.errstate(divide="ignore", invalid="ignore"):
        df = np.where(f[:, None] > 0, dlam / (8.0 * np.pi**2 * f[:, None]), 0.0)
    return EigenDerivatives(dlam=dlam, df_hz=df, dPhi=dPhi, method=method)


def _nelson_solve(K: Matrix, M: Matrix, lam_j: float, phi: FloatArray, F: FloatArray,
                  j: int) -> FloatArray:
    """Solve Nelson's system ``(K - lam M) V = F`` for one mode.

    The row and column of the largest entry of ``phi`` are replaced by the identity (the
    particular solution; the homogeneous part is added by the caller).

    Raises
    ------
    ModelError
        A singular Nelson matrix (a repeated mode).
    """
    n = K.shape[0]
    F = F.copy()
    k = int(np.argmax(np.abs(phi)))
    F[k] = 0.0
    keep = np.ones(n)
    keep[k] = 0.0
    msg = f"mode {j} (lambda {lam_j:.6g}): Nelson matrix singular"
    if sp.issparse(K):
        A = sp.csc_array(K - lam_j * M)
        D = sp.diags_array(keep)
        Ak = sp.csc_array(D @ A @ D + sp.csc_array(([1.0], ([k], [k])), shape=(n, n)))
        try:
            return np.asarray(spla.splu(Ak).solve(F))
        except RuntimeError as err:
            msg = f"{msg} ({err})"
            raise ModelError(msg) from err
    Ad = np.asarray(K, dtype=float) - lam_j * np.asarray(M, dtype=float)
    Ad = Ad * keep[:, None] * keep[None, :]
    Ad[k, k] = 1.0
    try:
        return np.asarray(sla.solve(Ad, F, assume_a="sym"))
    except (np.linalg.LinAlgError, sla.LinAlgWarning) as err:
        msg = f"{msg} ({err})"
        raise ModelError(msg) from err
