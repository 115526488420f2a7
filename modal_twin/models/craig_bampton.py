"""Craig-Bampton reduction and its checks.

Partition the DOFs into boundary ``b`` (kept physically) and interior ``i``. With the
constraint modes ``Psi = -K_ii^-1 K_ib`` and the fixed-interface normal modes ``Phi_ik``
(``K_ii phi = omega^2 M_ii phi``, mass-normalised), the full displacement is

    u = T [u_b; q],   T = [[I, 0], [Psi, Phi_ik]]                        (CB eq. 1)

and the reduced matrices are ``Mr = T' M T``, ``Kr = T' K T``, where

    Kr = [[K_bb + K_bi Psi, 0], [0, diag(omega_k^2)]]                    (CB eq. 2)

(the coupling ``K_bq`` vanishes because ``K_ib + K_ii Psi = 0``). ``K_ii`` is factored once
(``L D L'`` by QDLDL when it is positive definite, else sparse LU) and serves both ``Psi``
and the shift-invert eigen-solution (``sigma = 0``). With a cut-off ``f_c`` the number of
fixed-interface modes below it is counted first from the inertia of ``K_ii - (2 pi f_c)^2
M_ii`` (Sylvester's law, :func:`~modal_twin.models.fe.eigen.count_eigenvalues_below`), so
one Lanczos run asks for that many plus one (the next mode proves the count); only when the
count cannot be read or proves short does the search double the number asked.
:func:`cb_check` verifies a reduction the way pyyeti's ``cbcheck`` does: rigid-body mass,
the numerical ``K_bq`` of ``T' K T``, symmetry, and the system frequencies against the full
model.

References
----------
R. R. Craig, M. C. C. Bampton, "Coupling of substructures for dynamic analyses", AIAA J.
6 (1968) 1313-1319. [002] uses a CB carbody in the vehicle model (Sec. 5, Boo et al. 2018).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from modal_twin._types import FloatArray, IntArray
from modal_twin.errors import ModelError, OptionError, ShapeError
from modal_twin.models.fe.definite import ldl_factor
from modal_twin.models.fe.eigen import (
    Matrix,
    count_eigenvalues_below,
    lowest_eigenpairs,
    solve_modes,
)

__all__ = ["CBCheck", "CBReduction", "cb_check", "craig_bampton"]

_log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class CBReduction:
    """A Craig-Bampton reduced model; reduced coordinates are ``[u_b; q]``.

    Attributes
    ----------
    Mr, Kr : (n_b + n_q, n_b + n_q) float arrays
        Reduced mass and stiffness (symmetric; ``Kr[:n_b, n_b:]`` is exactly zero).
    T : (n, n_b + n_q) float array
        Recovery: ``u_full = T @ [u_b; q]`` (rows in the original DOF order).
    boundary_dofs, interior_dofs : int arrays
        Original indices of the boundary and interior DOFs.
    f_fixed_hz : (n_q,) float array
        Fixed-interface natural frequencies, Hz.
    f_cut_hz : float or None
        Cutoff requested (None if the modes were chosen by count).
    """

    Mr: FloatArray
    Kr: FloatArray
    T: FloatArray
    boundary_dofs: IntArray
    interior_dofs: IntArray
    f_fixed_hz: FloatArray
    f_cut_hz: float | None

    @property
    def n_boundary(self) -> int:
        """Number of boundary DOFs."""
        return int(self.boundary_dofs.size)

    @property
    def n_modes(self) -> int:
        """Number of fixed-interface modes kept."""
        return int(self.f_fixed_hz.size)

    def recover(self, x: FloatArray) -> FloatArray:
        """Return full DOF vectors ``T @ x`` for reduced vectors ``x`` ((n_r,) or (n_r, k))."""
        return np.asarray(self.T @ np.asarray(x, dtype=float))

    def project(self, A: Matrix) -> FloatArray:
        """Return ``T' A T`` for a full matrix ``A`` (e.g. a damping matrix)."""
        out = np.asarray(self.T.T @ (A @ self.T))
        return 0.5 * (out + out.T)


def _check_inputs(M: Matrix, K: Matrix, boundary_dofs: object) -> tuple[int, IntArray, IntArray]:
    if len(K.shape) != 2 or K.shape[0] != K.shape[1]:
        msg = f"K: expected (n, n), got {K.shape}"
        raise ShapeError(msg)
    n = int(K.shape[0])
    if M.shape != (n, n):
        msg = f"M: expected ({n}, {n}), got {M.shape}"
        raise ShapeError(msg)
    b = np.asarray(boundary_dofs)
    if b.ndim != 1 or b.size == 0 or not np.issubdtype(b.dtype, np.integer):
        msg = f"boundary_dofs: expected a non-empty 1-D int array, got {boundary_dofs!r}"
        raise ShapeError(msg)
    b = b.astype(np.int64)
    if b.min() < 0 or b.max() >= n:
        msg = f"boundary_dofs: expected indices in [0, {n}), got min {b.min()} max {b.max()}"
        raise ShapeError(msg)
    if np.unique(b).size != b.size:
        msg = "boundary_dofs: expected unique indices, got duplicates"
        raise ShapeError(msg)
    mask = np.ones(n, dtype=bool)
    mask[b] = False
    return n, b, np.flatnonzero(mask).astype(np.int64)


def craig_bampton(
    M: Matrix, K: Matrix, boundary_dofs: IntArray | list[int], n_modes: int | None = None,
    f_cut_hz: float | None = None, *, dense_max_dof: int = 400,
) -> CBReduction:
    """Reduce ``(M, K)`` to boundary DOFs plus fixed-interface modes (Craig-Bampton).

    Parameters
    ----------
    M, K : (n, n) sparse or dense arrays
        Mass (kg) and stiffness (N/m), symmetric.
    boundary_dofs : (n_b,) int array
        Indices of the DOFs kept physically (interfaces, suspension points, sensors).
    n_modes : int, optional
        Number of fixed-interface modes (0: Guyan reduction). With ``f_cut_hz``: an upper
        limit on the modes below the cutoff.
    f_cut_hz : float, optional
        Keep every fixed-interface mode below this frequency (Hz).
    dense_max_dof : int
        Interior size up to which the eigenproblem is solved densely.

    Returns
    -------
    CBReduction

    Raises
    ------
    ShapeError
        Bad shapes or boundary indices.
    OptionError
        Neither ``n_modes`` nor ``f_cut_hz`` given, or invalid values.
    ModelError
        ``K_ii`` singular: the boundary does not restrain the interior.

    Examples
    --------
    >>> import numpy as np
    >>> K = np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
    >>> cb = craig_bampton(np.eye(3), K, [0], n_modes=2)
    >>> bool(cb.Kr[0, 1:].any())
    False
    """
    n, b, i = _check_inputs(M, K, boundary_dofs)
    if n_modes is None and f_cut_hz is None:
        msg = "n_modes, f_cut_hz: expected at least one of them, got neither"
        raise OptionError(msg)
    if n_modes is not None and (not isinstance(n_modes, int | np.integer)
                                or not 0 <= n_modes <= i.size):
        msg = f"n_modes: expected an int in [0, {i.size}], got {n_modes!r}"
        raise OptionError(msg)
    if f_cut_hz is not None and not (np.isfinite(f_cut_hz) and f_cut_hz > 0.0):
        msg = f"f_cut_hz: expected a finite value > 0, got {f_cut_hz!r}"
        raise OptionError(msg)
    Ks, Ms = sp.csr_array(K), sp.csr_array(M)
    K_ii = sp.csc_array(Ks[i][:, i])
    M_ii = sp.csc_array(Ms[i][:, i])
    K_ib = Ks[i][:, b].toarray()
    solve, definite = _factor(K_ii)  # factor once: constraint modes and eigen-solution
    Psi = -solve(K_ib)  # CB eq. 1: constraint modes Psi = -K_ii^-1 K_ib
    if not np.all(np.isfinite(Psi)):
        msg = "K_ii: expected nonsingular, the constraint modes are not finite"
        raise ModelError(msg)
    lam, Phi = _fixed_interface_modes(K_ii, M_ii, solve, definite, n_modes, f_cut_hz,
                                      dense_max_dof)
    n_b, n_q = b.size, lam.size
    T = np.zeros((n, n_b + n_q))
    T[b, np.arange(n_b)] = 1.0
    T[np.ix_(i, np.arange(n_b))] = Psi
    T[np.ix_(i, n_b + np.arange(n_q))] = Phi
    Mr = np.asarray(T.T @ (Ms @ T))
    Mr = 0.5 * (Mr + Mr.T)
    K_bb = Ks[b][:, b].toarray()
    K_bi = Ks[b][:, i]
    Kbb_hat = K_bb + np.asarray(K_bi @ Psi)  # CB eq. 2: boundary stiffness (Guyan)
    Kr = np.zeros((n_b + n_q, n_b + n_q))
    Kr[:n_b, :n_b] = 0.5 * (Kbb_hat + Kbb_hat.T)
    Kr[n_b:, n_b:] = np.diag(lam)  # CB eq. 2: fixed-interface modal stiffness
    f_fixed = np.sqrt(np.clip(lam, 0.0, None)) / (2.0 * np.pi)
    return CBReduction(Mr=Mr, Kr=Kr, T=T, boundary_dofs=b, interior_dofs=i,
                       f_fixed_hz=f_fixed, f_cut_hz=None if f_cut_hz is None
                       else float(f_cut_hz))


def _factor(K_ii: sp.csc_array) -> tuple[Callable[[FloatArray], FloatArray], bool]:
    """Return ``(x -> K_ii^-1 x, positive definite)`` from one factorisation of ``K_ii``.

    ``L D L'`` (QDLDL, :func:`~modal_twin.models.fe.definite.ldl_factor`) when the entries
    are finite, the diagonal positive and every pivot positive: ``K_ii`` is then positive
    definite (Sylvester) and its solves are about four times cheaper than SuperLU's with
    column pivoting. Anything else goes to SuperLU (an indefinite but nonsingular ``K_ii``),
    which refuses a singular one.
    """
    ok = bool(np.all(np.isfinite(K_ii.data)) and np.all(K_ii.diagonal() > 0.0))
    ldl = ldl_factor(K_ii) if ok else None
    if ldl is not None and np.all(ldl[1] > 0.0):
        factor = ldl[0]

        def solve(x: FloatArray) -> FloatArray:
            x = np.asarray(x, dtype=float)
            if x.ndim == 1:
                return np.asarray(factor.solve(x))
            out = np.empty_like(x)
            for j in range(x.shape[1]):
                out[:, j] = factor.solve(x[:, j])
            return out

        return solve, True
    try:
        lu = spla.splu(K_ii)
    except RuntimeError as err:
        msg = (f"K_ii: expected nonsingular (boundary_dofs must restrain every rigid-body "
               f"motion of the interior), got: {err}")
        raise ModelError(msg) from err
    return lambda x: np.asarray(lu.solve(np.asarray(x, dtype=float))), False


def _fixed_interface_modes(
    K_ii: sp.csc_array, M_ii: sp.csc_array, solve: Callable[[FloatArray], FloatArray],
    definite: bool, n_modes: int | None, f_cut_hz: float | None, dense_max_dof: int,
) -> tuple[FloatArray, FloatArray]:
    """Lowest fixed-interface modes: ``n_modes`` of them, or every one below ``f_cut_hz``.

    With a cut-off and a positive definite ``K_ii`` the count below it (Sturm,
    :func:`count_eigenvalues_below`) sets the number asked of one shift-invert run, plus one
    mode above the cut-off that proves the count; a count that cannot be read or proves
    short falls back to doubling the number asked (12, 24, 48, ...).
    """
    n_i = K_ii.shape[0]
    if n_modes == 0:
        return np.zeros(0), np.zeros((n_i, 0))
    n_mass = int(np.count_nonzero(M_ii.diagonal() > 0.0))
    limit = min(n_i, n_mass) if n_modes is None else min(n_modes, n_i, n_mass)
    if f_cut_hz is None:
        lam, Phi, _ = lowest_eigenpairs(K_ii, M_ii, limit, sigma=0.0, solve=solve,
                                        dense_max_dof=dense_max_dof)
        return lam, Phi
    lam_cut = (2.0 * np.pi * f_cut_hz) ** 2
    count = count_eigenvalues_below(K_ii, M_ii, lam_cut) if definite else None
    k = min(limit, 12 if count is None else count + 1)
    while True:
        lam, Phi, _ = lowest_eigenpairs(K_ii, M_ii, k, sigma=0.0, solve=solve,
                                        dense_max_dof=dense_max_dof)
        if lam[-1] >= lam_cut or k >= limit:
            keep = lam < lam_cut
            return lam[keep], Phi[:, keep]
        if count is not None:
            _log.warning("craig_bampton: the Sturm count (%d below the cut-off) proved short; "
                         "doubling the modes asked", count)
        k = min(limit, 2 * k)


@dataclass(frozen=True, slots=True)
class CBCheck:
    """Diagnostics of a Craig-Bampton reduction (all errors relative).

    Attributes
    ----------
    rb_mass_full, rb_mass_reduced : (6, 6) float arrays or None
        Rigid-body mass ``R' M R`` of the full model and ``R_b' Mr_bb R_b`` of the reduced.
    rb_mass_rel_err : float
        ``||m_red - m_full|| / ||m_full||`` (NaN without rigid-body vectors).
    rb_stiffness_rel : float
        ``||K R|| / (||K|| ||R||)``: how rigid the given vectors are (NaN without them).
    kbq_rel : float
        ``||(T' K T)_bq|| / ||Kr||``: numerical coupling of the recomputed projection.
    kr_sym_rel, mr_sym_rel : float
        ``||A - A'|| / ||A||`` of ``Kr`` and ``Mr``.
    f_compare_hz : float
        Frequencies below this were compared.
    f_full_hz, f_reduced_hz : float arrays
        Lowest system frequencies (Hz) of the full and reduced models, matched by order.
    f_rel_err : float array
        ``|f_red - f_full| / f_full`` per compared mode (NaN for rigid-body modes, those
        below ``1e-3 f_compare_hz``).
    max_f_rel_err : float
        Largest entry of ``f_rel_err`` ignoring NaN (0 if none).
    """

    rb_mass_full: FloatArray | None
    rb_mass_reduced: FloatArray | None
    rb_mass_rel_err: float
    rb_stiffness_rel: float
    kbq_rel: float
    kr_sym_rel: float
    mr_sym_rel: float
    f_compare_hz: float
    f_full_hz: FloatArray
    f_reduced_hz: FloatArray
    f_rel_err: FloatArray
    max_f_rel_err: float


def cb_check(
    cb: CBReduction, M: Matrix, K: Matrix, *, rb: FloatArray | None = None,
    f_compare_hz: float | None = None,
) -> CBCheck:
    """Check a Craig-Bampton reduction against its full model.

    Parameters
    ----------
    cb : CBReduction
        The reduction of ``(M, K)``.
    M, K : (n, n) sparse or dense arrays
        The full model that was reduced.
    rb : (n, 6) float array, optional
        Rigid-body vectors of the full model (e.g. ``FEAssembly.rigid_body_modes()``).
        The reduced rigid-body vectors are their boundary rows with ``q = 0``.
    f_compare_hz : float, optional
        Compare system frequencies below this; default ``cb.f_cut_hz``, else the highest
        fixed-interface frequency kept (0 for a Guyan reduction: nothing compared). A CB
        model is accurate to well below its cutoff: pass about half of it for a test.

    Raises
    ------
    ShapeError
        ``M``, ``K`` or ``rb`` do not match ``cb.T``.

    Returns
    -------
    CBCheck
    """
    n = cb.T.shape[0]
    if M.shape != (n, n) or K.shape != (n, n):
        msg = f"M, K: expected ({n}, {n}) like cb.T, got {M.shape} and {K.shape}"
        raise ShapeError(msg)
    nb = cb.n_boundary
    Ks, Ms = sp.csr_array(K), sp.csr_array(M)
    kr_norm = float(np.linalg.norm(cb.Kr))
    kproj = np.asarray(cb.T.T @ (Ks @ cb.T))
    kbq = float(np.linalg.norm(kproj[:nb, nb:])) / kr_norm
    kr_sym = float(np.linalg.norm(cb.Kr - cb.Kr.T)) / kr_norm
    mr_sym = float(np.linalg.norm(cb.Mr - cb.Mr.T)) / float(np.linalg.norm(cb.Mr))
    m_full = m_red = None
    rb_err = rb_k = float("nan")
    if rb is not None:
        R = np.asarray(rb, dtype=float)
        if R.shape != (n, 6):
            msg = f"rb: expected ({n}, 6), got {R.shape}"
            raise ShapeError(msg)
        m_full = R.T @ np.asarray(Ms @ R)
        Rb = R[cb.boundary_dofs]
        m_red = Rb.T @ cb.Mr[:nb, :nb] @ Rb
        rb_err = float(np.linalg.norm(m_red - m_full) / np.linalg.norm(m_full))
        k_inf = float(abs(Ks).sum(axis=1).max())
        rb_k = float(np.linalg.norm(Ks @ R) / (k_inf * np.linalg.norm(R)))
    f_cmp = cb.f_cut_hz if f_compare_hz is None else float(f_compare_hz)
    if f_cmp is None:
        f_cmp = float(cb.f_fixed_hz[-1]) if cb.n_modes else 0.0
    lam_r = sla.eigh(cb.Kr, cb.Mr, eigvals_only=True)
    f_red = np.sqrt(np.clip(lam_r, 0.0, None)) / (2.0 * np.pi)
    n_cmp = int(np.count_nonzero(f_red < f_cmp))
    f_full = np.zeros(0)
    if n_cmp:
        f_full = solve_modes(Ks, Ms, min(n_cmp, n)).f_hz
    f_red = f_red[:n_cmp]
    floor = 1e-3 * f_cmp
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.where(f_full > floor, np.abs(f_red - f_full) / f_full, np.nan)
    max_rel = float(np.nanmax(rel)) if np.any(np.isfinite(rel)) else 0.0
    if rb is not None and rb_err > 1e-8:
        _log.warning("cb_check: rigid-body mass changed by %.3g (relative)", rb_err)
    return CBCheck(
        rb_mass_full=m_full, rb_mass_reduced=m_red, rb_mass_rel_err=rb_err,
        rb_stiffness_rel=rb_k, kbq_rel=kbq, kr_sym_rel=kr_sym, mr_sym_rel=mr_sym,
        f_compare_hz=f_cmp, f_full_hz=f_full, f_reduced_hz=f_red, f_rel_err=rel,
        max_f_rel_err=max_rel)
