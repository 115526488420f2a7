"""FE model updating benchmark: building, its 10k- and 100k-DOF meshes, the bridge.

Cases, each from start to report (matching, uncertainty, result records):

1. ``building``: the building of [004] (210 DOFs) with moduli 30-38 % low (nominal
   superstructure modes 16-24 % too high, the 004 situation) and isolators 6 % stiff;
   targets = the truth's modes with 0.3 % frequency scatter and 3 % shape noise at the 42
   channels. Two stages (:func:`~modal_twin.updating.stages.building_stages`): moduli with a
   global search on a Ritz reduced model, then the twelve isolator rates.
2. ``building_10k``: the same building with every frame member split into ``--split``
   elements (>= 10,000 DOFs, massless interior nodes), same truth and stages.
3. ``building_100k``: every member in ``--split-100k`` elements (~107,000 DOFs). Its
   members carry no distributed mass, so the interior DOFs condense exactly and affinely
   in theta (:func:`~modal_twin.models.fe.condensation.condense_massless`, to 104 masters);
   the same two stages run on the condensed model and the result is checked once against
   a sparse eigen-solution of all DOFs (reported, not part of the update time).
4. ``bridge``: the pedestrian bridge (946 DOFs, 17 parameters, five measured modes,
   :mod:`modal_twin.io.matfiles`): bounded Gauss-Newton from the nominal model with the
   analytic Jacobian, frequencies weighted by their identified standard deviations and a
   weak pull towards the nominal values (``prior_weight`` 0.3). Skipped when the data
   folder is absent.

Reports wall time, eigen-solves and errors. BLAS runs single-threaded (on this loaded
2-core machine a 238 x 238 eigen-solve took 0.38 s with default threading, 0.01 s with one
thread). Last line: one JSON object with ``seconds_10k_dof``, ``seconds_100k_dof``
(condensation + update), ``seconds_100k_total`` (+ assembly), ``seconds_bridge``,
``bridge_max_abs_df_pct``, ``bridge_min_mac``.

Run: ``.venv/bin/python test/benchmarks/bench_updating.py [--split 19] [--split-100k 190]``
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse
import itertools
import json
import time
from dataclasses import replace
from typing import Any

import numpy as np
import yaml

from modal_twin.io.matfiles import BRIDGE_DIR, load_bridge
from modal_twin.models.building import (
    DEFAULT_BUILDING_YAML,
    BuildingModel,
    build_building,
)
from modal_twin.models.fe import solve_modes
from modal_twin.models.fe.condensation import Condensation, condense_massless
from modal_twin.models.structure_yaml import parse_structure
from modal_twin.updating.optimize import update
from modal_twin.updating.problem import ModeTargets, UpdatingProblem
from modal_twin.updating.stages import building_stages, staged_update

TRUTH_SCALE = {"E_Fc36": 0.70, "E_Fc27": 0.62, "E_Fc21": 0.72}


def split_building(n_split: int) -> BuildingModel:
    """The building with every frame member (between two listed nodes) in ``n_split`` elements."""
    doc = yaml.safe_load(DEFAULT_BUILDING_YAML.read_text())
    frames = []
    for f in doc["frames"]:
        chain = [f["n1"], *f.get("via", []), f["n2"]]
        for a, b in itertools.pairwise(chain):
            g = {k: v for k, v in f.items() if k not in ("n1", "n2", "via")}
            frames.append({**g, "n1": a, "n2": b, "n_elements": n_split})
    doc["frames"] = frames
    # element-group factors overlap the moduli on every column DOF: a condensation that stays
    # affine in theta needs one parameter per massless group, so the meshed variant updates
    # the moduli only
    doc.pop("groups", None)
    return build_building(spec=parse_structure(doc, source=f"building split {n_split}"))


JOBS: str = "1"  # --jobs: executor of the global searches (modal_twin.executors)


def building_case(bld: BuildingModel, *, seed: int = 3,
                  condensed: Condensation | None = None) -> dict[str, Any]:
    """Two-stage update of a building against its perturbed truth (module docstring).

    With ``condensed`` the update runs on the exactly condensed model (its masters).
    """
    t0 = time.perf_counter()
    par = bld.assembly.parametric if condensed is None else condensed.par
    S = bld.S if condensed is None else bld.S[:, condensed.masters]
    truth = {n: par.theta0[par.index(n)] * s for n, s in TRUTH_SCALE.items()}
    for n in par.names:
        if n.startswith("k_"):
            truth[n] = par.theta0[par.index(n)] * 1.06
    th = par.theta_vector(truth)
    s = solve_modes(par.K(th), par.M(th), 12)
    rng = np.random.default_rng(seed)
    f = s.f_hz * (1 + 0.003 * rng.standard_normal(12))
    phi = np.asarray(S @ s.Phi)
    phi = phi + 0.03 * np.abs(phi).max(axis=0) * rng.standard_normal(phi.shape)
    targets = ModeTargets.create(f[:9], phi[:, :9], std_f_hz=0.003 * f[:9])
    t_setup = time.perf_counter() - t0
    sup, iso = building_stages(par, f_split_hz=2.0, prior_weight_devices=1.0)
    out = staged_update(par, S, targets, [replace(sup, rel_bounds=0.6, use_std=True),
                                              replace(iso, global_stage=False, use_std=True)],
                        reduced=True, maxiter=20, executor=JOBS)
    err = {n: float(out.theta[par.index(n)] / th[par.index(n)] - 1.0) for n in TRUTH_SCALE}
    return {
        "n_dof": bld.n_dof,
        "seconds": time.perf_counter() - t0,
        "seconds_truth_setup": t_setup,
        "n_eigen_solves": out.n_eigen_solves,
        "stages": [{"name": nm, "seconds": r.seconds, "n_eigen_solves": r.n_eigen_solves,
                    "n_global_evals": r.n_global_evals,
                    "max_abs_df_pct_before": float(100 * np.nanmax(np.abs(
                        r.pairing_before.df_rel))) if r.pairing_before.n_matched else None,
                    "n_matched_before": r.pairing_before.n_matched,
                    "max_abs_df_pct": r.max_abs_df_pct, "min_mac": r.min_mac}
                   for nm, r in zip(out.stage_names, out.stages, strict=True)],
        "moduli_rel_error_pct": {k: 100 * v for k, v in err.items()},
        "theta": out.theta,
    }


def building_100k(n_split: int) -> dict[str, Any]:
    """The building meshed to ~100,000 DOFs, condensed exactly, updated in two stages.

    The members carry no distributed mass (masses lumped at the joints, [004]), so their
    interior DOFs condense exactly (:mod:`modal_twin.models.fe.condensation`); the update
    then runs on the masters. The updated parameters are checked once on the full model
    (one sparse eigen-solution of all DOFs, not timed with the update).
    """
    t0 = time.perf_counter()
    big = split_building(n_split)
    t_build = time.perf_counter() - t0
    t1 = time.perf_counter()
    keep = np.flatnonzero(np.abs(big.S).sum(axis=0) > 0)
    cond = condense_massless(big.assembly.parametric, keep)
    t_cond = time.perf_counter() - t1
    r = building_case(big, condensed=cond)
    par = big.assembly.parametric
    t2 = time.perf_counter()
    full = solve_modes(par.K(r["theta"]), par.M(r["theta"]), 12)
    t_full = time.perf_counter() - t2
    red = solve_modes(cond.par.K(r["theta"]), cond.par.M(r["theta"]), 12)
    r.update(n_dof=big.n_dof, n_masters=int(cond.masters.size), seconds_assembly=t_build,
             seconds_condensation=t_cond, seconds_update_with_condensation=t_cond + r["seconds"],
             seconds_one_full_eigen_solve=t_full,
             max_rel_df_condensed_vs_full=float(np.max(np.abs(red.f_hz / full.f_hz - 1))))
    return r


def bridge_case() -> dict[str, Any]:
    """Pedestrian bridge update (module docstring)."""
    t0 = time.perf_counter()
    b = load_bridge()
    t = ModeTargets.create(b.f_hz, b.psi, std_f_hz=b.std_f_hz, std_shapes=b.std_psi)
    pr = UpdatingProblem(b.K0, b.M, list(b.K_j), None, np.zeros(17), b.names, b.lower,
                         b.upper, b.measured_dofs, t, f_scale=b.std_f_hz / b.f_hz,
                         prior_weight=0.3)
    res = update(pr, global_stage=False, max_nfev=60)
    u = res.uncertainty
    return {
        "seconds": time.perf_counter() - t0,
        "seconds_update": res.seconds,
        "n_eigen_solves": res.n_eigen_solves,
        "df_pct": (100 * res.pairing_after.df_rel).round(3).tolist(),
        "mac": res.pairing_after.mac.round(4).tolist(),
        "max_abs_df_pct": res.max_abs_df_pct,
        "min_mac": res.min_mac,
        "at_bounds": list(res.at_bounds),
        "determined": [n for n, d in zip(u.names, u.determined, strict=True) if d] if u else [],
        "theta": dict(zip(res.names, np.round(res.theta, 4).tolist(), strict=True)),
    }


def main() -> None:
    """Run the three cases and print the summary JSON last."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--split", type=int, default=19, help="elements per member (10k case)")
    ap.add_argument("--split-100k", type=int, default=190,
                    help="elements per member (100k case; 0 skips it)")
    ap.add_argument("--jobs", default="1",
                    help="global-search workers: 1 (serial), N processes, auto, dask://H:P")
    args = ap.parse_args()
    global JOBS
    JOBS = args.jobs
    summary: dict[str, Any] = {"jobs": args.jobs}

    bld = build_building()
    r = building_case(bld)
    print(f"building ({r['n_dof']} DOFs): {r['seconds']:.2f} s, {r['n_eigen_solves']} "
          f"eigen-solves; stages {json.dumps(r['stages'])}; moduli errors % "
          f"{json.dumps(r['moduli_rel_error_pct'])}")
    summary["seconds_building"] = r["seconds"]

    t0 = time.perf_counter()
    big = split_building(args.split)
    t_build = time.perf_counter() - t0
    r10 = building_case(big)
    print(f"building split {args.split} ({r10['n_dof']} DOFs, assembled in {t_build:.2f} s): "
          f"{r10['seconds']:.2f} s, {r10['n_eigen_solves']} eigen-solves; stages "
          f"{json.dumps(r10['stages'])}; moduli errors % "
          f"{json.dumps(r10['moduli_rel_error_pct'])}")
    summary.update(n_dof_10k=r10["n_dof"], seconds_10k_dof=r10["seconds"],
                   eigen_solves_10k_dof=r10["n_eigen_solves"],
                   max_abs_df_pct_10k=max(s["max_abs_df_pct"] for s in r10["stages"]))

    if args.split_100k > 0:
        r100 = building_100k(args.split_100k)
        print(f"building split {args.split_100k} ({r100['n_dof']} DOFs -> {r100['n_masters']} "
              f"masters): assembly {r100['seconds_assembly']:.2f} s, condensation "
              f"{r100['seconds_condensation']:.2f} s, update {r100['seconds']:.2f} s, "
              f"{r100['n_eigen_solves']} eigen-solves; stages {json.dumps(r100['stages'])}; "
              f"moduli errors % {json.dumps(r100['moduli_rel_error_pct'])}; condensed vs full "
              f"max |df| {r100['max_rel_df_condensed_vs_full']:.2e} (full solve "
              f"{r100['seconds_one_full_eigen_solve']:.1f} s)")
        summary.update(
            n_dof_100k=r100["n_dof"], n_masters_100k=r100["n_masters"],
            seconds_100k_dof=r100["seconds_update_with_condensation"],
            seconds_100k_assembly=r100["seconds_assembly"],
            seconds_100k_total=r100["seconds_assembly"] + r100["seconds_update_with_condensation"],
            max_abs_df_pct_100k=max(st["max_abs_df_pct"] for st in r100["stages"]),
            max_rel_df_condensed_vs_full_100k=r100["max_rel_df_condensed_vs_full"],
            seconds_100k_one_full_eigen_solve=r100["seconds_one_full_eigen_solve"])

    if BRIDGE_DIR.is_dir():
        rb = bridge_case()
        print(f"bridge: {json.dumps(rb)}")
        summary.update(seconds_bridge=rb["seconds"], bridge_max_abs_df_pct=rb["max_abs_df_pct"],
                       bridge_min_mac=rb["min_mac"], eigen_solves_bridge=rb["n_eigen_solves"],
                       bridge_at_bounds=len(rb["at_bounds"]))
    else:
        print(f"bridge: skipped ({BRIDGE_DIR} absent)")
        summary.update(seconds_bridge=None, bridge_max_abs_df_pct=None, bridge_min_mac=None)
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
