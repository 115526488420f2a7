"""Wall time of the diagnosis per case (issue 20: median <= 30 s per case on 2 cores).

A fixed set of cases of ``bench_hidden_effects.py --new`` (:data:`SPEED_CASES`: a mass, a
sensor delay, a Bouc-Wen bearing, a friction damper, the car's damper friction and two
effects at once, whose places are chosen again and paired), each diagnosed through the same
adapter as there (:func:`bench_hidden_effects.run_case`: records from the independent
truth, ``pipeline.diagnose`` with the executor of the free cores, the model found judged on
every record). Per case it prints the wall time of the diagnosis, the CPU time of this
process and its workers over the diagnosis (a loaded machine stretches the wall time, much less
the CPU time), and the verdict with its figures at full precision: the family, place, law
and fitted parameters of every effect named, NRMSE before / after and the noise floor per
record. Two versions of the library run one after the other give the same figure lines
when they diagnose alike (``grep '^  '`` of both outputs, then ``diff``).

Last line, JSON: ``median_wall_s``, ``worst_wall_s``, ``median_cpu_s``, ``worst_cpu_s``,
``per_case_wall_s``, ``per_case_cpu_s``, the 1-minute load average at the start and the end
(``load_average_start`` / ``load_average_end``), the cores, the seed offset.

Run::

    PYTHONPATH=. OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 .venv/bin/python \\
        test/benchmarks/bench_diagnosis_speed.py [--cases A,B] [--seed-offset 200]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_hidden_effects as hidden
from _truth.cases import NEW_CASES

SPEED_CASES = ("new_mass_F3_quiet_devices", "new_sensor_delay_F3_C2",
               "new_hyst_bw1_RB1_seed2", "new_friction_damper_SDP2_broadband",
               "new_veh_damper_friction_front", "new_two_bw_RB2_line_1A")


def _cpu_s() -> float:
    """CPU seconds of this process and of its children waited for (the pool's workers)."""
    me = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


_DIAGNOSIS_CPU: list[float] = []
_run_diagnosis = hidden.run_diagnosis


def _timed_diagnosis(*args: Any) -> dict[str, Any]:
    """The adapter of bench_hidden_effects, its CPU seconds kept in ``_DIAGNOSIS_CPU``."""
    c0 = _cpu_s()
    try:
        return _run_diagnosis(*args)
    finally:
        _DIAGNOSIS_CPU.append(_cpu_s() - c0)


hidden.run_diagnosis = _timed_diagnosis  # run_case calls it by this name


def figure_lines(r: dict[str, Any]) -> list[str]:
    """The verdict and figures of one case at full precision (what must not change)."""
    out = [f"  {r['case']}: named {r['named']['family']} at {r['named']['place'] or '-'}; "
           f"score {json.dumps(r['score'], sort_keys=True)}"]
    out += [f"  {r['case']}: effect {e['family']}@{e['place']} law {e['law']} params "
            f"{json.dumps(e['params'], sort_keys=True)} label {e['label']!r}"
            for e in r["named"]["effects"]]
    out += [f"  {r['case']}: {k} before {r[k]['before']!r} after {r[k]['after']!r} noise "
            f"{r[k]['noise']!r} ch_after {r[k].get('ch_after')!r}"
            for k in ("train", "test", "low")]
    if r["named"].get("error"):
        out.append(f"  {r['case']}: CRASH {r['named']['error']}")
    return out


def main(argv: list[str] | None = None) -> int:
    """Run the cases, print their figure lines and times, and the JSON line."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", default=",".join(SPEED_CASES),
                    help="comma-separated cases of --new (default: SPEED_CASES)")
    ap.add_argument("--seed-offset", type=int, default=200, metavar="N",
                    help="noise and excitation seed offset of every case (default 200)")
    args = ap.parse_args(argv)
    known = {c.name: c for c in NEW_CASES}
    want = [s for s in args.cases.split(",") if s]
    bad = [s for s in want if s not in known]
    if bad or not want:
        print(f"--cases: unknown {bad or 'none given'}; known: {list(known)}",
              file=sys.stderr)
        return 2
    load_start = os.getloadavg()[0]
    walls: dict[str, float] = {}
    cpus: dict[str, float] = {}
    for name in want:
        case = replace(known[name], seed=known[name].seed + args.seed_offset)
        load = os.getloadavg()[0]
        r = hidden.run_case(case, quick=False, truth_only=False)
        cpus[name] = round(_DIAGNOSIS_CPU[-1], 1)
        walls[name] = round(r["diagnosis_s"], 1)
        print("\n".join(figure_lines(r)))
        print(f"{name}: diagnosis wall {walls[name]:.1f} s, CPU {cpus[name]:.1f} s "
              f"(truth {r['truth_s']:.1f} s), load average {load:.2f}", flush=True)
    load_end = os.getloadavg()[0]
    w, c = list(walls.values()), list(cpus.values())
    print(json.dumps({
        "median_wall_s": round(float(np.median(w)), 1), "worst_wall_s": max(w),
        "median_cpu_s": round(float(np.median(c)), 1), "worst_cpu_s": max(c),
        "per_case_wall_s": walls, "per_case_cpu_s": cpus,
        "load_average_start": round(load_start, 2), "load_average_end": round(load_end, 2),
        "cores": len(os.sched_getaffinity(0)), "seed_offset": args.seed_offset,
        "n_cases": len(want)}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
