"""Global search (differential evolution) then bounded gradient refinement.

The global stage plays the role of the genetic algorithm of [002] and [004] (Sec. 5.2 of
[004]: the matched cost is piecewise discontinuous, so a population search goes first): it
minimises Eq. (3) of [004] with ``scipy.optimize.differential_evolution``. Its population
is evaluated through an ``executor`` (:func:`modal_twin.executors.make_executor`: serial, a
process pool, a Dask cluster or any ``concurrent.futures.Executor``), always with deferred
updating, so a seeded search gives the same result on every executor. A multi-start stage
(``n_starts``) refines from the global estimate and from Latin-hypercube starts in parallel
on the same executor and keeps the best.

The refinement minimises the least-squares residual of
:class:`~modal_twin.updating.problem.UpdatingProblem` with
``scipy.optimize.least_squares`` (trust-region reflective, bounded) and the analytic
Jacobian (Fox-Kapoor eigenvalue and Nelson eigenvector derivatives). Both stages work on
scaled variables ``x = (theta - theta0) / scale`` with ``scale`` the bound range, so
moduli in Pa and spring rates in N/m are on an equal footing.
"""

from __future__ import annotations

import logging
import time

import numpy as np
import scipy.optimize as so
from scipy.stats import qmc

from modal_twin._types import FloatArray
from modal_twin.executors import (
    ExecutorSpec,
    SerialExecutor,
    make_executor,
    map_ordered,
    mapper,
)
from modal_twin.progress import Progress
from modal_twin.updating.problem import UpdatingProblem
from modal_twin.updating.reduced_basis import reduced_problem
from modal_twin.updating.results import UpdateResult
from modal_twin.updating.uncertainty import parameter_covariance

__all__ = ["global_search", "multi_start", "refine", "update"]

_log = logging.getLogger(__name__)


class _ScaledCost:
    """Picklable ``x -> problem.cost(theta(x))`` for process pools."""

    def __init__(self, problem: UpdatingProblem) -> None:
        self.problem = problem
        self.lo = problem.lower
        self.rng = problem.upper - problem.lower

    def theta(self, x: FloatArray) -> FloatArray:
        return self.lo + self.rng * np.asarray(x, dtype=float)

    def __call__(self, x: FloatArray) -> float:
        return self.problem.cost(self.theta(x))


def global_search(
    problem: UpdatingProblem, *, maxiter: int = 30, popsize: int = 10, seed: int | None = 0,
    executor: ExecutorSpec = 1, tol: float = 1e-3, x0: FloatArray | None = None,
    label: str = "global search",
) -> tuple[FloatArray, float, int]:
    """Minimise Eq. (3) of [004] by differential evolution within the bounds.

    Parameters
    ----------
    problem : UpdatingProblem
    maxiter, popsize, tol : int, int, float
        ``differential_evolution`` controls (population = ``popsize * p``).
    seed : int, optional
        Seed of the population (reproducible runs).
    executor : ExecutorSpec
        Where the population is evaluated (:func:`~modal_twin.executors.make_executor`);
        the result does not depend on it.
    x0 : (p,) float array, optional
        A starting member (parameter units), e.g. the nominal model.
    label : str
        Name of the step in the progress display (:mod:`modal_twin.progress`; one step per
        generation, the best cost beside it).

    Returns
    -------
    theta : (p,) float array
    cost : float
    nfev : int
    """
    f = _ScaledCost(problem)
    p = problem.theta0.size
    start = None if x0 is None else np.clip((np.asarray(x0) - f.lo) / f.rng, 0.0, 1.0)
    with make_executor(executor) as ex, Progress(label, total=maxiter,
                                                 unit="generation") as bar:

        def generation_done(intermediate_result: so.OptimizeResult) -> None:
            bar.update(note=f"cost {intermediate_result.fun:.4g}")

        res = so.differential_evolution(
            f, [(0.0, 1.0)] * p, maxiter=maxiter, popsize=popsize, tol=tol, seed=seed,
            workers=mapper(ex), updating="deferred", polish=False, x0=start,
            init="latinhypercube", callback=generation_done)
    return f.theta(res.x), float(res.fun), int(res.nfev)


def refine(problem: UpdatingProblem, theta_start: FloatArray, *, max_nfev: int = 60,
           tol: float = 1e-10) -> so.OptimizeResult:
    """Bounded Gauss-Newton refinement with the analytic Jacobian (``least_squares``, TRF).

    Returns the ``OptimizeResult`` with ``x`` in parameter units.
    """
    lo, rng = problem.lower, problem.upper - problem.lower
    x0 = np.clip((np.asarray(theta_start, dtype=float) - lo) / rng, 0.0, 1.0)

    def fun(x: FloatArray) -> FloatArray:
        return problem.residual(lo + rng * x)

    def jac(x: FloatArray) -> FloatArray:
        return problem.jacobian(lo + rng * x) * rng[None, :]

    res = so.least_squares(fun, x0, jac=jac, bounds=(0.0, 1.0), method="trf",
                           x_scale=1.0, ftol=tol, xtol=tol, gtol=tol, max_nfev=max_nfev)
    res.x = lo + rng * res.x
    return res


def _reduced_refine(problem: UpdatingProblem, search: UpdatingProblem, theta: FloatArray,
                    max_nfev: int, seed: int | None) -> tuple[FloatArray, int]:
    """Refine on the Ritz model, enrich its basis there, refine again; best of the three.

    Returns the estimate and the small eigen-solves spent (``search`` counts its own,
    including those of a serial global search before).
    """
    r1 = refine(search, theta, max_nfev=max_nfev)
    rom2 = reduced_problem(problem, seed=0 if seed is None else seed, n_samples=0,
                           extra_points=[r1.x, theta])
    r2 = refine(rom2, r1.x, max_nfev=max_nfev)
    best = min((r1.x, r2.x, theta), key=problem.objective)
    return best, search.n_eigen_solves + rom2.n_eigen_solves


class _RefineTask:
    """Picklable ``start -> (theta, objective, nfev, status)`` of :func:`refine`."""

    def __init__(self, problem: UpdatingProblem, max_nfev: int) -> None:
        self.problem = problem
        self.max_nfev = max_nfev

    def __call__(self, start: FloatArray) -> tuple[FloatArray, float, int, int]:
        r = refine(self.problem, start, max_nfev=self.max_nfev)
        return r.x, float(self.problem.objective(r.x)), int(r.nfev), int(r.status)


def multi_start(
    problem: UpdatingProblem, starts: FloatArray, *, n_random: int = 0, seed: int | None = 0,
    executor: ExecutorSpec = 1, max_nfev: int = 60,
) -> tuple[FloatArray, float, int]:
    """Refine from several starts in parallel and keep the lowest least-squares objective.

    Parameters
    ----------
    problem : UpdatingProblem
    starts : (n, p) float array
        Given starts (parameter units), e.g. the global-search estimate.
    n_random : int
        Further Latin-hypercube starts within the bounds (``scipy.stats.qmc``, ``seed``).
    executor : ExecutorSpec
        Where the refinements run; the result does not depend on it (ties go to the first
        start).

    Returns
    -------
    theta : (p,) float array
    objective : float
    nfev : int
        Residual evaluations over all starts.
    """
    x = np.atleast_2d(np.asarray(starts, dtype=float))
    if n_random > 0:
        u = qmc.LatinHypercube(d=problem.theta0.size, seed=seed).random(n_random)
        x = np.vstack([x, qmc.scale(u, problem.lower, problem.upper)])
    with make_executor(executor) as ex:
        out = map_ordered(ex, _RefineTask(problem, max_nfev), list(x))
    k = int(np.argmin([o[1] for o in out]))
    return out[k][0], out[k][1], sum(o[2] for o in out)


def update(
    problem: UpdatingProblem, *, theta_start: FloatArray | None = None,
    global_stage: bool = True, maxiter: int = 30, popsize: int = 10, seed: int | None = 0,
    executor: ExecutorSpec = 1, max_nfev: int = 60, fraction: float = 0.1,
    reduced: bool = False, full_nfev: int = 8, n_starts: int = 0,
    label: str = "global search",
) -> UpdateResult:
    """Update the parameters: global search (optional), gradient refinement, uncertainty.

    Parameters
    ----------
    problem : UpdatingProblem
    theta_start : (p,) float array, optional
        Start (default ``problem.theta0``, clipped into the bounds).
    global_stage : bool
        Run :func:`global_search` first (the nominal model is one member of its population).
    maxiter, popsize, seed
        Global-search controls.
    executor : ExecutorSpec
        Where the global-search population and the multi-start refinements run
        (:func:`~modal_twin.executors.make_executor`); the result does not depend on it.
    max_nfev : int
        Refinement evaluations.
    fraction : float
        "Determined" threshold of :func:`parameter_covariance`.
    reduced : bool
        Run the global search and a first refinement on a Ritz reduced model
        (:func:`~modal_twin.updating.reduced_basis.reduced_problem`), enrich its basis at that
        estimate, refine again, then finish with at most ``full_nfev`` full-model steps.
    n_starts : int
        Latin-hypercube starts refined beside the best estimate so far (:func:`multi_start`,
        on the full model, before the final refinement); 0 = none.
    label : str
        Name of the global search in the progress display.

    Returns
    -------
    UpdateResult
        The parameters never leave their bounds; the least-squares objective
        (:meth:`UpdatingProblem.objective`) never rises (when the search fails to improve,
        the start is returned).
    """
    t0 = time.perf_counter()
    n0 = problem.n_eigen_solves
    start = problem.theta0 if theta_start is None else np.asarray(theta_start, dtype=float)
    start = np.clip(start, problem.lower, problem.upper)
    cost0 = problem.cost(start)
    pair0 = problem.pairing(start) if cost0 < 10.0 * problem.targets.n_modes else None
    theta, msg, n_other = start.copy(), "", 0
    n_glob = n_in_process = 0
    search = reduced_problem(problem, seed=0 if seed is None else seed) if reduced else problem
    with make_executor(executor) as ex:
        if global_stage:
            n_before = search.n_eigen_solves
            th_g, c_g, n_glob = global_search(search, maxiter=maxiter, popsize=popsize,
                                              seed=seed, executor=ex, x0=start, label=label)
            n_in_process = search.n_eigen_solves - n_before
            if problem.cost(th_g) < cost0:
                theta = th_g
            msg = f"global: cost {cost0:.4g} -> {c_g:.4g} in {n_glob} evaluations; "
        if reduced:
            theta, n_rom = _reduced_refine(problem, search, theta, max_nfev, seed)
            n_other += n_rom
            msg += f"reduced model: {n_rom} small eigen-solves; "
            max_nfev = full_nfev
        if n_starts > 0:
            theta, _, n_ms = multi_start(problem, theta[None, :], n_random=n_starts, seed=seed,
                                         executor=ex, max_nfev=max_nfev)
            n_other += n_ms if not isinstance(ex, SerialExecutor) else 0
            msg += f"multi-start: {n_starts + 1} starts, {n_ms} evaluations; "
    n_other += n_glob - n_in_process  # those in this process are counted by the problems
    res = refine(problem, theta, max_nfev=max_nfev)
    # candidates are compared on what the refinement minimises (residuals + prior)
    best = res.x if problem.objective(res.x) <= problem.objective(theta) else theta
    msg += f"refine: {res.message}"
    if problem.objective(best) > problem.objective(start):
        best = start
    cost1 = problem.cost(best)
    pair1 = problem.pairing(best)
    unc = None
    sig = problem.residual_sigma()
    if np.any(np.isfinite(sig)):
        unc = parameter_covariance(problem.jacobian(best), sig, names=problem.names,
                                   lower=problem.lower, upper=problem.upper, fraction=fraction)
    rng = problem.upper - problem.lower
    near = (best - problem.lower < 1e-3 * rng) | (problem.upper - best < 1e-3 * rng)
    return UpdateResult(
        names=problem.names, theta_start=start, theta=best, lower=problem.lower.copy(),
        upper=problem.upper.copy(), f_id=problem.targets.f_hz.copy(),
        pairing_before=pair0 if pair0 is not None else pair1, pairing_after=pair1,
        cost_before=cost0, cost_after=cost1,
        n_eigen_solves=problem.n_eigen_solves - n0 + n_other,
        n_global_evals=n_glob, seconds=time.perf_counter() - t0,
        converged=bool(res.status > 0), message=msg,
        at_bounds=tuple(n for n, b in zip(problem.names, near, strict=True) if b),
        uncertainty=unc)
