"""Parametric reduced-order model (Ritz basis) of an updating problem, for fast searches.

Because ``K(theta) = K0 + sum_i K_i (theta_i - theta0_i)`` is affine (Sec. 4 of [004]),
projecting on a fixed basis ``V`` (n x r) keeps it affine with r x r matrices computed
once: ``K_r(theta) = V' K0 V + sum_i V' K_i V (theta_i - theta0_i)``. The basis holds the
lowest modes at the nominal point and at a few Latin-hypercube points of the bounds, and
the Nelson derivatives of the nominal modes (:mod:`.sensitivity`), so the Ritz values are
accurate to second order near the nominal point and exact at the sample points. A global
search then costs an r x r eigen-solution per candidate instead of a sparse one of size n;
the refinement and the reported figures use the full model.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.stats import qmc

from modal_twin._types import FloatArray
from modal_twin.errors import ConvergenceError, ModelError
from modal_twin.updating.problem import UpdatingProblem
from modal_twin.updating.sensitivity import eigen_derivatives

__all__ = ["reduced_problem"]


def _project(V: FloatArray, A: object) -> FloatArray | None:
    if A is None:
        return None
    out = V.T @ np.asarray(A @ V)  # type: ignore[operator]
    return np.asarray(0.5 * (out + out.T))


def reduced_problem(problem: UpdatingProblem, *, n_samples: int = 4, seed: int = 0,
                    extra_points: list[FloatArray] | None = None, tol: float = 1e-9
                    ) -> UpdatingProblem:
    """Return the Ritz-projected copy of ``problem`` (module docstring).

    Parameters
    ----------
    problem : UpdatingProblem
    n_samples : int
        Latin-hypercube points whose modes join the basis.
    seed : int
        Seed of the sampling.
    extra_points : list of (p,) arrays, optional
        More parameter points whose modes join the basis (e.g. a previous estimate).
    tol : float
        Basis vectors with singular value below ``tol`` times the largest are dropped.

    Returns
    -------
    UpdatingProblem
        Dense r x r matrices; the same names, bounds, targets and options.
    """
    md = problem.modes(problem.theta0)
    cols = [md.Phi]
    der = eigen_derivatives(md.K, md.M, md.lam, md.Phi, problem.dK, problem.dM)
    cols.append(der.dPhi.reshape(md.Phi.shape[0], -1))
    pts = list(extra_points or [])
    if n_samples > 0:
        u = qmc.LatinHypercube(d=problem.theta0.size, seed=seed).random(n_samples)
        pts += list(problem.lower + u * (problem.upper - problem.lower))
    for th in pts:
        try:
            cols.append(problem.modes(np.asarray(th, dtype=float)).Phi)
        except (ModelError, ConvergenceError):
            continue
    B = np.hstack(cols)
    B = B / np.maximum(np.linalg.norm(B, axis=0), np.finfo(float).tiny)
    U, s, _ = np.linalg.svd(B, full_matrices=False)
    V = U[:, s > tol * s[0]]
    K0r = _project(V, problem.K0)
    M0r = _project(V, problem.M0)
    dK = [_project(V, A) for A in problem.dK]
    dM = [_project(V, A) for A in problem.dM]
    S = np.asarray(problem.S @ V)
    n_modes = min(problem.n_modes, V.shape[1] - 2)
    return UpdatingProblem(
        K0r, M0r, dK, dM, problem.theta0, problem.names, problem.lower, problem.upper,
        sp.csr_array(S), problem.targets, n_modes=n_modes, w_mac=problem.w_mac,
        f_scale=problem.f_scale, r_f=problem.r_f, r_mac=problem.r_mac,
        prior_weight=problem.prior_weight)
