"""Staged updating: superstructure first, then the isolation layer (Sec. 5 of [004]).

[004] updates its base-isolated building in two stages: the concrete moduli against the
superstructure modes (whose frequencies hardly depend on the isolators), then the
isolation-layer device stiffnesses against the isolation modes, within the bounds of the
force-drift least squares (Eqs. (1)-(2) of [004], :mod:`.device_ls`). Each stage here is
one :func:`~modal_twin.updating.optimize.update` over its own parameters and modes, started
from the previous stage's estimate (the other parameters are held).
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from modal_twin._types import FloatArray, IntArray
from modal_twin.errors import OptionError
from modal_twin.executors import ExecutorSpec, make_executor
from modal_twin.models.fe import ParametricMatrices
from modal_twin.updating.optimize import update
from modal_twin.updating.problem import Matrix, ModeTargets, UpdatingProblem
from modal_twin.updating.results import UpdateResult

__all__ = ["R_F", "R_MAC", "Stage", "StagedResult", "building_stages", "stage_problem",
           "staged_update"]

R_F = 0.10
"""Default pairing window of :func:`staged_update`: relative frequency difference."""
R_MAC = 0.15
"""Default pairing window of :func:`staged_update`: 1 - MAC."""


@dataclass(frozen=True, slots=True)
class Stage:
    """One updating stage.

    Attributes
    ----------
    name : str
    parameters : tuple of str
        Parameters updated in this stage (the others are held).
    f_range_hz : (float, float), optional
        Identified modes used (all when None).
    bounds : mapping name -> (lower, upper), optional
    rel_bounds : float, optional
        ``theta (1 -/+ rel_bounds)`` for parameters without ``bounds``.
    global_stage : bool
        Run the global search before the gradient refinement.
    w_mac, prior_weight : float
        :class:`~modal_twin.updating.problem.UpdatingProblem` options.
    use_std : bool
        Weight frequencies by their identified standard deviation (``f_scale = std_f / f``,
        where known; others get the median of the known ones).
    """

    name: str
    parameters: tuple[str, ...]
    f_range_hz: tuple[float, float] | None = None
    bounds: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    rel_bounds: float | None = 0.5
    global_stage: bool = True
    w_mac: float = 1.0
    prior_weight: float = 0.0
    use_std: bool = False


@dataclass(frozen=True, slots=True)
class StagedResult:
    """Outcome of :func:`staged_update`.

    Attributes
    ----------
    names : tuple of str
        All parameters of the assembly.
    theta_start, theta : (n_theta,) float arrays
        Full parameter vectors before and after.
    stages : tuple of UpdateResult
        One per stage, in order.
    stage_names : tuple of str
    seconds : float
    n_eigen_solves : int
        Sum over the stages.
    """

    names: tuple[str, ...]
    theta_start: FloatArray
    theta: FloatArray
    stages: tuple[UpdateResult, ...]
    stage_names: tuple[str, ...]
    seconds: float
    n_eigen_solves: int

    def theta_dict(self, only_changed: bool = True) -> dict[str, float]:
        """Parameter values (by default only those a stage updated)."""
        upd = {n for r in self.stages for n in r.names}
        return {n: float(v) for n, v in zip(self.names, self.theta, strict=True)
                if not only_changed or n in upd}


def _select(targets: ModeTargets, f_range: tuple[float, float] | None, name: str) -> ModeTargets:
    if f_range is None:
        return targets
    k = np.flatnonzero((targets.f_hz >= f_range[0]) & (targets.f_hz <= f_range[1]))
    if k.size == 0:
        msg = (f"stage {name!r}: expected identified modes in {f_range} Hz, got none "
               f"(identified: {np.round(targets.f_hz, 3).tolist()})")
        raise OptionError(msg)
    return targets.subset(k.tolist())


def _f_scale(t: ModeTargets, use_std: bool) -> FloatArray:
    if not use_std:
        return np.ones(t.n_modes)
    s = t.std_f_hz / t.f_hz
    ok = np.isfinite(s) & (s > 0)
    fill = float(np.median(s[ok])) if np.any(ok) else 1.0
    return np.where(ok, s, fill)


def stage_problem(
    par: ParametricMatrices, S: Matrix | IntArray, targets: ModeTargets, st: Stage,
    th: FloatArray, *, n_modes: int | None, r_f: float, r_mac: float,
) -> UpdatingProblem:
    """Return the updating problem of one stage at the current estimate ``th``."""
    if not st.parameters:
        msg = f"stage {st.name!r}: expected at least one parameter, got none"
        raise OptionError(msg)
    sub = _select(targets, st.f_range_hz, st.name)
    n_below = int(np.count_nonzero(targets.f_hz < sub.f_hz.min()))
    nm = n_modes if n_modes is not None else max(2 * sub.n_modes, sub.n_modes + 6) + n_below
    return UpdatingProblem.from_parametric(
        par, S, sub, names=st.parameters, bounds=st.bounds, rel_bounds=st.rel_bounds,
        theta=th, n_modes=nm, w_mac=st.w_mac, prior_weight=st.prior_weight, r_f=r_f,
        r_mac=r_mac, f_scale=_f_scale(sub, st.use_std))


def staged_update(
    par: ParametricMatrices, S: Matrix | IntArray, targets: ModeTargets,
    stages: Sequence[Stage], *, theta: Mapping[str, float] | FloatArray | None = None,
    executor: ExecutorSpec = 1, seed: int | None = 0, maxiter: int = 30, popsize: int = 10,
    max_nfev: int = 60, n_modes: int | None = None, r_f: float = R_F, r_mac: float = R_MAC,
    reduced: bool = False, n_starts: int = 0,
) -> StagedResult:
    """Run the stages in order, each from the previous estimate (module docstring).

    Parameters
    ----------
    par : ParametricMatrices
        ``K(theta)``, ``M(theta)`` of the model (Sec. 4 of [004]).
    S : (n_ch, n) matrix or (n_ch,) DOF indices
        Measured DOFs.
    targets : ModeTargets
        All identified modes; each stage keeps those in its ``f_range_hz``.
    stages : sequence of Stage
    theta : mapping or array, optional
        Start (default the nominal ``par.theta0``).
    executor, seed, maxiter, popsize, max_nfev, reduced, n_starts
        :func:`~modal_twin.updating.optimize.update` controls (``executor``:
        :func:`~modal_twin.executors.make_executor`, entered once for all stages).
    n_modes, r_f, r_mac
        :class:`~modal_twin.updating.problem.UpdatingProblem` options (``n_modes`` default:
        enough FEM modes for every target of the stage plus the modes below them).

    Returns
    -------
    StagedResult

    Raises
    ------
    OptionError
        No stages, a stage without modes or parameters, unknown parameters, missing bounds.
    """
    if not stages:
        msg = "stages: expected at least one Stage, got none"
        raise OptionError(msg)
    t0 = time.perf_counter()
    th = par.theta_vector(theta)
    start = th.copy()
    out: list[UpdateResult] = []
    n_solves = 0
    with make_executor(executor) as ex:  # one pool for every stage
        for st in stages:
            pr = stage_problem(par, S, targets, st, th, n_modes=n_modes, r_f=r_f, r_mac=r_mac)
            res = update(pr, global_stage=st.global_stage, maxiter=maxiter, popsize=popsize,
                         seed=seed, executor=ex, max_nfev=max_nfev, reduced=reduced,
                         n_starts=n_starts, label=f"stage {st.name!r}: global search")
            for nme, val in zip(res.names, res.theta, strict=True):
                th[par.index(nme)] = val
            out.append(res)
            n_solves += res.n_eigen_solves
    return StagedResult(names=par.names, theta_start=start, theta=th, stages=tuple(out),
                        stage_names=tuple(s.name for s in stages),
                        seconds=time.perf_counter() - t0, n_eigen_solves=n_solves)


def building_stages(
    par: ParametricMatrices, *, f_split_hz: float, moduli: Sequence[str] | None = None,
    devices: Sequence[str] | None = None,
    device_bounds: Mapping[str, tuple[float, float]] | None = None,
    rel_bounds_moduli: float = 0.5, rel_bounds_devices: float = 0.3,
    prior_weight_devices: float = 0.0, global_stage: bool = True,
) -> tuple[Stage, Stage]:
    """Return the two stages of [004]: moduli on modes above ``f_split_hz``, device ``k`` below.

    Parameters
    ----------
    par : ParametricMatrices
        Assembly parameters (names ``E_*`` and ``k_<device>_<x|y>`` by default).
    f_split_hz : float
        Frequency between the isolation modes and the superstructure modes.
    moduli, devices : sequence of str, optional
        Parameters of each stage (default: every ``E_*``; every ``k_*``).
    device_bounds : mapping, optional
        Bounds of the device parameters, e.g. :func:`~.device_ls.kc_bounds`.
    rel_bounds_moduli, rel_bounds_devices : float
        Relative bounds where none are given.
    prior_weight_devices : float
        Pull of the device stiffnesses towards their nominal values (three isolation modes
        cannot fix twelve spring rates; the prior keeps the undetermined combinations).
    global_stage : bool
        Global search in both stages.

    Raises
    ------
    OptionError
        A stage would have no parameters.
    """
    E = tuple(moduli) if moduli is not None else tuple(n for n in par.names if n.startswith("E_"))
    k = tuple(devices) if devices is not None else tuple(
        n for n in par.names if n.startswith("k_"))
    if not E or not k:
        msg = f"moduli / devices: expected parameters for both stages, got {E} and {k}"
        raise OptionError(msg)
    sup = Stage("superstructure", E, f_range_hz=(f_split_hz, np.inf),
                rel_bounds=rel_bounds_moduli, global_stage=global_stage)
    iso = Stage("isolation", k, f_range_hz=(0.0, f_split_hz), bounds=dict(device_bounds or {}),
                rel_bounds=rel_bounds_devices, global_stage=global_stage,
                prior_weight=prior_weight_devices)
    return sup, iso
