"""Global search (differential evolution) then bounded gradient refinement.

The global stage plays the role of the genetic algorithm of [002] and [004] (Sec. 5.2 of
[004]: the matched cost is piecewise discontinuous, so a population search goes first): it
minimises Eq. (3) of [004] with ``scipy.optimize.differential_evolution``. Its population
is evaluated through ``workers``: an int (1 = serial, -1 = all cores, as scipy), any
``map``-like callable, or a :class:`concurrent.futures.Executor` (its ``map`` is used),
so a process pool here or a Dask / Ray executor on a cluster runs it unchanged.

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
from collections.abc import Callable, Iterable
from concurrent.futures import Executor
from typing import Any

import numpy as np
import scipy.optimize as so

from modal_twin._types import FloatArray
from modal_twin.errors import OptionError
from modal_twin.progress import Progress
from modal_twin.updating.problem import UpdatingProblem
from modal_twin.updating.reduced_basis import reduced_problem
from modal_twin.updating.results import UpdateResult
from modal_twin.updating.uncertainty import parameter_covariance

__all__ = ["global_search", "refine", "update"]

_log = logging.getLogger(__name__)
Workers = int | Executor | Callable[[Callable[[Any], Any], Iterable[Any]], Iterable[Any]]


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


def _map_of(workers: Workers) -> int | Callable[..., Any]:
    if isinstance(workers, Executor):
        return workers.map
    if isinstance(workers, bool) or not (isinstance(workers, int) or callable(workers)):
        msg = f"workers: expected an int, an Executor or a map-like callable, got {workers!r}"
        raise OptionError(msg)
    return workers


def global_search(
    problem: UpdatingProblem, *, maxiter: int = 30, popsize: int = 10, seed: int | None = 0,
    workers: Workers = 1, tol: float = 1e-3, x0: FloatArray | None = None,
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
    workers : int, Executor or map-like callable
        Where the population is evaluated (module docstring).
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
    mapper = _map_of(workers)
    p = problem.theta0.size
    start = None if x0 is None else np.clip((np.asarray(x0) - f.lo) / f.rng, 0.0, 1.0)
    with Progress(label, total=maxiter, unit="generation") as bar:

        def generation_done(intermediate_result: so.OptimizeResult) -> None:
            bar.update(note=f"cost {intermediate_result.fun:.4g}")

        res = so.differential_evolution(
            f, [(0.0, 1.0)] * p, maxiter=maxiter, popsize=popsize, tol=tol, seed=seed,
            workers=mapper, updating="immediate" if mapper == 1 else "deferred", polish=False,
            x0=start, init="latinhypercube", callback=generation_done)
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


def update(
    problem: UpdatingProblem, *, theta_start: FloatArray | None = None,
    global_stage: bool = True, maxiter: int = 30, popsize: int = 10, seed: int | None = 0,
    workers: Workers = 1, max_nfev: int = 60, fraction: float = 0.1,
    reduced: bool = False, full_nfev: int = 8, label: str = "global search",
) -> UpdateResult:
    """Update the parameters: global search (optional), gradient refinement, uncertainty.

    Parameters
    ----------
    problem : UpdatingProblem
    theta_start : (p,) float array, optional
        Start (default ``problem.theta0``, clipped into the bounds).
    global_stage : bool
        Run :func:`global_search` first (the nominal model is one member of its population).
    maxiter, popsize, seed, workers
        Global-search controls.
    max_nfev : int
        Refinement evaluations.
    fraction : float
        "Determined" threshold of :func:`parameter_covariance`.
    reduced : bool
        Run the global search and a first refinement on a Ritz reduced model
        (:func:`~modal_twin.updating.reduced_basis.reduced_problem`), enrich its basis at that
        estimate, refine again, then finish with at most ``full_nfev`` full-model steps.
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
    theta, n_glob, msg = start.copy(), 0, ""
    search = problem
    n_rom = 0
    if reduced:
        search = reduced_problem(problem, seed=0 if seed is None else seed)
    if global_stage:
        th_g, c_g, n_glob = global_search(search, maxiter=maxiter, popsize=popsize,
                                          seed=seed, workers=workers, x0=start, label=label)
        if problem.cost(th_g) < cost0:
            theta = th_g
        msg = f"global: cost {cost0:.4g} -> {c_g:.4g} in {n_glob} evaluations; "
    if reduced:
        r1 = refine(search, theta, max_nfev=max_nfev)
        n_rom += search.n_eigen_solves
        rom2 = reduced_problem(problem, seed=0 if seed is None else seed, n_samples=0,
                               extra_points=[r1.x, theta])
        r2 = refine(rom2, r1.x, max_nfev=max_nfev)
        n_rom += rom2.n_eigen_solves
        cand = min((r1.x, r2.x, theta), key=problem.objective)
        theta = cand
        msg += f"reduced model: {n_rom} small eigen-solves; "
        max_nfev = full_nfev
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
        n_eigen_solves=problem.n_eigen_solves - n0 + n_rom
        + (n_glob if (workers != 1 or reduced) else 0),
        n_global_evals=n_glob, seconds=time.perf_counter() - t0,
        converged=bool(res.status > 0), message=msg,
        at_bounds=tuple(n for n, b in zip(problem.names, near, strict=True) if b),
        uncertainty=unc)
