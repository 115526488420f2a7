"""The noise floor the diagnosis estimates against the truth's, per channel (issue 20, item 1).

For each case (default: the noise-form cases of ``_truth/cases.py`` and three white-noise
cases of the first set), its three records (training, held-out, low level) are built by the
truth (written apart from the library) and the diagnosis' noise model is asked for each
channel's floor (``judge.record_noise_floors`` on the nominal model, the channels the model
has); printed: the estimate over the truth's floor RMS(noise) / RMS(measured), 10th
percentile, median and 90th percentile over the channels, per record. 1.00 is exact; the
flat-top estimate reads coloured noise far too low (a low-passed noise at ~0.0003x).

The last line is a JSON object: per case the median over its records of the median ratio
(``median_ratio``) and the extremes over channels and records (``min_ratio`` /
``max_ratio``: dimensionless), and the wall time in s.

Run::

    PYTHONPATH=. OMP_NUM_THREADS=1 .venv/bin/python test/benchmarks/bench_noise_floor.py
        [--cases NAME,...] [--quick] [--seed-offset N] [--changed]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _truth.cases import CASES, NEW_CASES, NOISE_FORM_CASES, records

from modal_twin.diagnosis.fitting import simulate_record
from modal_twin.diagnosis.judge import record_noise_floors
from modal_twin.diagnosis.noise import coloured_noise_sd, noise_sd
from modal_twin.diagnosis.record import Record
from modal_twin.models.loading import load_model

ROOT = Path(__file__).resolve().parents[2]
MODEL_FILES = {"building": ROOT / "config" / "structures" / "building.yaml",
               "vehicle": ROOT / "config" / "vehicles" / "trailer_car.yaml",
               "vehicle3d": ROOT / "config" / "vehicles" / "trailer_car_3d.yaml"}
WHITE = ("control_nothing_1pct", "friction_stribeck_ESB1", "mass_F2_eccentric")


def main(argv: list[str] | None = None) -> int:
    """Print the ratios per case and record, then the JSON line."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", default="", help="comma-separated case names")
    ap.add_argument("--quick", action="store_true", help="shorter records")
    ap.add_argument("--seed-offset", type=int, default=0, metavar="N")
    ap.add_argument("--changed", action="store_true",
                    help="whether the coloured-noise test changes any level (all cases)")
    args = ap.parse_args(argv)
    known = {c.name: c for c in (*CASES, *NEW_CASES)}
    want = [s for s in args.cases.split(",") if s] or (list(known) if args.changed else [
        *(c.name for c in NOISE_FORM_CASES), *WHITE])
    bad = [s for s in want if s not in known]
    if bad:
        print(f"--cases: unknown {bad}", file=sys.stderr)
        return 2
    if args.changed:
        return _changed(want, known, args)
    out = {}
    for name in want:
        t0 = time.perf_counter()
        case = replace(known[name], seed=known[name].seed + args.seed_offset)
        recs = records(case, quick=args.quick)
        plant = load_model(MODEL_FILES[case.model]).plant()
        have = set(plant.channel_names)
        first = next(iter(recs.values()))
        keep = [c for c in first.channel_names if c in have]
        rs = [Record(n.fs_hz, n.input_names, n.inputs, n.channel_names, n.data,
                     n.source).with_channels(keep) for n in recs.values()]
        meds, lo, hi = [], np.inf, 0.0
        for (key, nz), est in zip(recs.items(), record_noise_floors(plant, rs), strict=True):
            truth = np.array([nz.noise_floor[nz.channel_names.index(c)] for c in keep])
            r = est / truth
            p10, p50, p90 = np.percentile(r, [10, 50, 90])
            meds.append(p50)
            lo, hi = min(lo, float(r.min())), max(hi, float(r.max()))
            print(f"{name:<34} {key:<5} estimate / truth: p10 {p10:8.4f} median {p50:8.4f} "
                  f"p90 {p90:8.4f}")
        out[name] = {"median_ratio": round(float(np.median(meds)), 4),
                     "min_ratio": round(lo, 4), "max_ratio": round(hi, 4),
                     "wall_time_s": round(time.perf_counter() - t0, 1)}
    print(json.dumps({"per_case": out, "seed_offset": args.seed_offset,
                      "quick": args.quick}))
    return 0


def _changed(want: list[str], known: dict, args: argparse.Namespace) -> int:
    """Per case and record: does the coloured-noise test change the flat-top levels?"""
    changed: dict[str, list[str]] = {}
    for name in want:
        case = replace(known[name], seed=known[name].seed + args.seed_offset)
        plant = load_model(MODEL_FILES[case.model]).plant()
        recs = records(case, quick=args.quick)
        have = set(plant.channel_names)
        keep = [c for c in next(iter(recs.values())).channel_names if c in have]
        words = []
        for key, nz in recs.items():
            r = Record(nz.fs_hz, nz.input_names, nz.inputs, nz.channel_names, nz.data,
                       nz.source).with_channels(keep)
            resid = r.scored - simulate_record(plant, r)[:, r.skip:]
            flat, col = noise_sd(r.scored, r.fs_hz), coloured_noise_sd(r.scored, resid, r.fs_hz)
            if np.array_equal(flat, col):
                words.append(f"{key}: same")
            else:
                words.append(f"{key}: raised x{float(np.median(col / flat)):.2f}")
                changed.setdefault(name, []).append(key)
        print(f"{name:<40} {'; '.join(words)}", flush=True)
    print(json.dumps({"records_changed": changed, "n_cases": len(want),
                      "seed_offset": args.seed_offset, "quick": args.quick}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
