"""Lowest modes of ``K phi = omega^2 M phi`` by shift-invert Lanczos, dense fallback.

With a shift ``sigma < 0`` the operator ``(K - sigma M)^-1 M`` is definite whenever every
DOF has mass or stiffness, so rigid-body modes (``omega = 0``) are found together with the
flexible ones, and massless DOFs (``M`` semi-definite) only add infinite eigenvalues that
the solver never reaches. Sparse: ``scipy.sparse.linalg.eigsh(K, k, M, sigma)`` (ARPACK,
mode 3). Dense: ``scipy.linalg.eigh(M, K - sigma M)`` gives ``mu = 1 / (lambda - sigma)``;
its largest ``mu`` are the lowest ``lambda``.

How many eigenvalues lie below a bound ``lambda_c`` is read off one factorisation (Sylvester's
law of inertia, the Sturm count): for ``K`` positive definite and ``M`` semi-definite, the
number of negative pivots of ``P (K - lambda_c M) P' = L D L'`` equals the number of
eigenvalues ``lambda < lambda_c`` (:func:`count_eigenvalues_below`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal, cast

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from modal_twin._types import FloatArray, Matrix
from modal_twin.errors import ConvergenceError, ModelError, OptionError, ShapeError
from modal_twin.models.fe.definite import check_entries, ldl_factor

__all__ = [
    "ModalSolution",
    "count_eigenvalues_below",
    "default_shift",
    "lowest_eigenpairs",
    "solve_modes",
]

_log = logging.getLogger(__name__)

Method = Literal["auto", "sparse", "dense"]


@dataclass(frozen=True, slots=True)
class ModalSolution:
    """Lowest modes of an undamped model.

    Attributes
    ----------
    f_hz : (n_modes,) float array
        Natural frequencies, Hz (``omega / 2 pi``; negative round-off clipped to 0).
    omega : (n_modes,) float array
        Circular frequencies, rad/s.
    eigenvalues : (n_modes,) float array
        ``omega^2`` as computed (rad^2/s^2), not clipped: tells round-off on rigid modes.
    Phi : (n_dof, n_modes) float array
        Mass-normalised mode shapes (``Phi' M Phi = I``), largest entry of each positive.
    method : {"sparse", "dense"}
        Solver used.
    sigma : float
        Shift, rad^2/s^2.
    max_rel_residual : float
        ``max_j ||K phi_j - lambda_j M phi_j|| / ((||K|| + |lambda_j| ||M||) ||phi_j||)``
        (infinity norms of the matrices): a backward error, meaningful for rigid modes too.
    max_orthogonality_error : float
        ``max |Phi' M Phi - I|``.
    """

    f_hz: FloatArray
    omega: FloatArray
    eigenvalues: FloatArray
    Phi: FloatArray
    method: Literal["sparse", "dense"]
    sigma: float
    max_rel_residual: float
    max_orthogonality_error: float


def _square(name: str, A: Matrix, n: int | None) -> int:
    shape = A.shape
    if len(shape) != 2 or shape[0] != shape[1] or (n is not None and shape[0] != n):
        want = "(n, n)" if n is None else f"({n}, {n})"
        msg = f"{name}: expected {want}, got {shape}"
        raise ShapeError(msg)
    return int(shape[0])


def default_shift(K: Matrix, M: Matrix) -> float:
    """Return ``-1e-6`` times the median ``K_jj / M_jj`` over DOFs with both positive.

    Any negative shift gives the lowest modes; its size only sets the conditioning of
    ``K - sigma M``. Returns ``-1.0`` when no DOF has both stiffness and mass.
    """
    kd = np.asarray(K.diagonal(), dtype=float)
    md = np.asarray(M.diagonal(), dtype=float)
    ok = (kd > 0.0) & (md > 0.0)
    if not np.any(ok):
        return -1.0
    return -1e-6 * float(np.median(kd[ok] / md[ok]))


def count_eigenvalues_below(K: Matrix, M: Matrix, lam: float) -> int | None:
    """Return the number of eigenvalues of ``K phi = lambda M phi`` below ``lam`` (Sturm count).

    Sylvester's law of inertia: with ``K`` symmetric positive definite and ``M`` symmetric
    positive semi-definite, ``K - lam M`` has as many negative eigenvalues as the pencil has
    eigenvalues ``< lam`` (massless DOFs give infinite eigenvalues, never counted), and its
    ``L D L'`` factorisation (QDLDL, AMD ordering, no pivoting) as many negative pivots.

    Parameters
    ----------
    K, M : (n, n) sparse or dense arrays
        Stiffness (positive definite, not checked here) and mass.
    lam : float
        Bound, rad^2/s^2 (``(2 pi f)^2``).

    Returns
    -------
    int or None
        The count; None when it cannot be read (non-finite entries, an exactly zero pivot:
        ``lam`` is an eigenvalue, or the unpivoted factorisation broke down). An LDL' without
        pivoting of an indefinite matrix may lose accuracy, so a caller checks the count
        against the eigenvalues it then computes.

    Examples
    --------
    >>> import numpy as np
    >>> count_eigenvalues_below(np.diag([1.0, 4.0, 9.0]), np.eye(3), 5.0)
    2
    """
    A = sp.csc_matrix(K) - float(lam) * sp.csc_matrix(M)
    if not np.all(np.isfinite(A.data)):
        return None
    ldl = ldl_factor(A)
    if ldl is None or not np.all(np.isfinite(ldl[1])) or np.any(ldl[1] == 0.0):
        return None
    return int(np.count_nonzero(ldl[1] < 0.0))


def _shifted_solver(K: sp.csc_array, M: sp.csc_array, sigma: float
                    ) -> Callable[[FloatArray], FloatArray]:
    """Return ``x -> (K - sigma M)^-1 x`` from an LDL' factorisation that cannot crash.

    Refuses (:class:`ModelError`, naming the DOF) a ``K - sigma M`` that is not positive
    definite: then ``sigma`` is not below the lowest eigenvalue (``K`` indefinite) or a DOF
    has neither stiffness nor mass, and shift-invert would not find the lowest modes.
    """
    A = sp.csc_matrix(K - sigma * M)
    name = f"K - sigma M (sigma = {sigma:.3g})"
    check_entries(name, A, positive_diagonal=True)
    ldl = ldl_factor(A)
    d, perm = (np.zeros(1), np.zeros(1, dtype=int)) if ldl is None else ldl[1:]
    bad = np.flatnonzero(~(d > 0.0))
    if ldl is None or bad.size:
        where = f" at DOF {int(perm[bad[0]])}" if ldl is not None else ""
        msg = (f"{name}: expected positive definite, got a non-positive LDL' pivot{where} "
               "(K indefinite, or a DOF without stiffness and mass)")
        raise ModelError(msg)
    solver = ldl[0]
    return lambda x: np.asarray(solver.solve(np.asarray(x, dtype=float)))


def lowest_eigenpairs(
    K: Matrix, M: Matrix, n_modes: int, *, sigma: float, method: Method = "auto",
    solve: Callable[[FloatArray], FloatArray] | None = None, dense_max_dof: int = 400,
) -> tuple[FloatArray, FloatArray, Literal["sparse", "dense"]]:
    """Return the ``n_modes`` lowest ``(lambda, Phi, method)``, ascending, mass-normalised.

    ``solve`` may give ``x -> (K - sigma M)^-1 x`` from an existing factorisation (used by
    Craig-Bampton to factor ``K_ii`` once with ``sigma = 0``).
    """
    n = _square("K", K, None)
    if method not in ("auto", "sparse", "dense"):
        msg = f"method: expected one of ['auto', 'sparse', 'dense'], got {method!r}"
        raise OptionError(msg)
    use_dense = method == "dense" or (method == "auto" and (n <= dense_max_dof
                                                            or n_modes >= n - 1))
    if not use_dense and n_modes >= n - 1:
        msg = f"n_modes: expected < {n - 1} for the sparse solver, got {n_modes}"
        raise OptionError(msg)
    if use_dense:
        # sp.issparse narrows nothing for the checker (scipy has no stubs here)
        Kd = cast("sp.sparray", K).toarray() if sp.issparse(K) else np.asarray(K, dtype=float)
        Md = cast("sp.sparray", M).toarray() if sp.issparse(M) else np.asarray(M, dtype=float)
        try:
            mu, V = sla.eigh(Md, Kd - sigma * Md, subset_by_index=[n - n_modes, n - 1])
        except np.linalg.LinAlgError as err:
            msg = (f"K - sigma M (sigma = {sigma:.3g}): expected positive definite, it is not "
                   "(a DOF without mass and stiffness, or negative stiffness)")
            raise ModelError(msg) from err
        tiny = n * np.finfo(float).eps * float(np.abs(mu).max())  # mu = 0: massless DOF
        if np.any(mu <= tiny):
            msg = (f"n_modes: expected at most the number of DOFs with mass, got {n_modes} "
                   f"({int(np.sum(mu <= tiny))} infinite eigenvalues)")
            raise ModelError(msg)
        lam = sigma + 1.0 / mu[::-1]
        Phi = V[:, ::-1]
        used: Literal["sparse", "dense"] = "dense"
    else:
        Ks = sp.csc_array(K)
        Ms = sp.csc_array(M)
        if solve is None:
            solve = _shifted_solver(Ks, Ms, sigma)
        opinv = spla.LinearOperator((n, n), matvec=solve, dtype=float)
        try:
            # a seeded start vector: ARPACK's own is drawn from a stream that advances with
            # every call in the process, so the modes' last digits hung on the calls before
            v0 = np.random.default_rng(0).standard_normal(n)
            lam, Phi = spla.eigsh(Ks, k=n_modes, M=Ms, sigma=sigma, which="LM", OPinv=opinv,
                                  v0=v0)
        except spla.ArpackNoConvergence as err:
            msg = (f"eigsh: {len(err.eigenvalues)} of {n_modes} modes converged "
                   f"(sigma = {sigma:.3g})")
            raise ConvergenceError(msg) from err
        except RuntimeError as err:  # singular factorisation
            msg = f"K - sigma M (sigma = {sigma:.3g}): expected nonsingular, got: {err}"
            raise ModelError(msg) from err
        order = np.argsort(lam)
        lam, Phi = lam[order], Phi[:, order]
        used = "sparse"
    mPhi = M @ Phi
    norms = np.sqrt(np.einsum("ij,ij->j", Phi, mPhi))
    Phi = Phi / norms
    sign = np.sign(Phi[np.argmax(np.abs(Phi), axis=0), np.arange(Phi.shape[1])])
    return np.asarray(lam, dtype=float), Phi * sign, used


def solve_modes(
    K: Matrix, M: Matrix, n_modes: int, *, sigma: float | None = None,
    method: Method = "auto", dense_max_dof: int = 400,
) -> ModalSolution:
    """Return the ``n_modes`` lowest modes of ``K phi = omega^2 M phi``.

    Parameters
    ----------
    K, M : (n, n) sparse or dense arrays
        Stiffness (N/m) and mass (kg), symmetric; ``M`` may be semi-definite.
    n_modes : int
        Number of modes, ``1 <= n_modes <= n``.
    sigma : float, optional
        Negative shift (rad^2/s^2); default :func:`default_shift`.
    method : {"auto", "sparse", "dense"}
        ``"auto"``: dense when ``n <= dense_max_dof`` or nearly all modes are asked.
    dense_max_dof : int
        Size limit of the automatic dense fallback.

    Returns
    -------
    ModalSolution

    Raises
    ------
    ShapeError
        ``K`` and ``M`` not square of the same size.
    ModelError
        No or negative mass, ``sigma >= 0``, ``K - sigma M`` singular.
    OptionError
        Bad ``n_modes`` or ``method``.
    ConvergenceError
        ARPACK did not converge.

    Examples
    --------
    >>> import numpy as np
    >>> sol = solve_modes(np.diag([4.0, 9.0]), np.eye(2), 2)
    >>> np.round(sol.omega, 12)
    array([2., 3.])
    """
    n = _square("K", K, None)
    _square("M", M, n)
    if not isinstance(n_modes, int | np.integer) or not 1 <= n_modes <= n:
        msg = f"n_modes: expected an int in [1, {n}], got {n_modes!r}"
        raise OptionError(msg)
    md = np.asarray(M.diagonal(), dtype=float)
    if not np.any(md > 0.0):
        msg = "M: expected some positive mass, got a zero diagonal"
        raise ModelError(msg)
    if np.any(md < 0.0):
        msg = f"M: expected a diagonal >= 0, got min {md.min():.6g} at DOF {int(np.argmin(md))}"
        raise ModelError(msg)
    check_entries("M", M, positive_diagonal=False)
    sig = default_shift(K, M) if sigma is None else float(sigma)
    if not sig < 0.0:
        msg = f"sigma: expected a negative shift, got {sig!r}"
        raise ModelError(msg)
    check_entries(f"K - sigma M (sigma = {sig:.3g})", sp.csc_matrix(K) - sig * sp.csc_matrix(M),
                  positive_diagonal=True)
    lam, Phi, used = lowest_eigenpairs(K, M, int(n_modes), sigma=sig, method=method,
                                       dense_max_dof=dense_max_dof)
    kPhi = np.asarray(K @ Phi)
    mPhi = np.asarray(M @ Phi)
    res = np.linalg.norm(kPhi - mPhi * lam, axis=0)
    norm_k = float(abs(K).sum(axis=1).max()) if sp.issparse(K) else float(np.abs(K).sum(1).max())
    norm_m = float(abs(M).sum(axis=1).max()) if sp.issparse(M) else float(np.abs(M).sum(1).max())
    scale = (norm_k + np.abs(lam) * norm_m) * np.linalg.norm(Phi, axis=0)
    rel = float(np.max(res / np.maximum(scale, np.finfo(float).tiny)))
    orth = float(np.abs(Phi.T @ mPhi - np.eye(Phi.shape[1])).max())
    if rel > 1e-6:
        _log.warning("solve_modes: max relative residual %.3g (sigma %.3g)", rel, sig)
    omega = np.sqrt(np.clip(lam, 0.0, None))
    return ModalSolution(
        f_hz=omega / (2.0 * np.pi), omega=omega, eigenvalues=lam, Phi=Phi, method=used,
        sigma=sig, max_rel_residual=rel, max_orthogonality_error=orth)
