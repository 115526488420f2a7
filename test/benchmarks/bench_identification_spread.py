"""Spread of output-only SSI-cov estimates over noise realisations (bench_identification b).

bench_identification judges one record per case. On case (b) (42 outputs, 172 s at 71.4 Hz,
10 modes 0.69-16.5 Hz, 2-3 % damping) the output-only errors are set by the record's length,
not by the estimator: this script repeats the case over ``--seeds`` noise realisations and
over the block rows (lag horizon) and prints, per mode, the RMS frequency and damping error
and how often the mode is missed; a record ``--long`` times longer shows the errors falling
as 1 / sqrt(T) (variance, not bias). N4SID with the measured inputs is printed alongside.

usage: python test/benchmarks/bench_identification_spread.py [--seeds 8] [--long 8]
Last line: JSON with, per block rows, rms_df_pct / rms_dz_pct per mode, missed per mode, and
the median over seeds of the max error over the found modes.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _modal_sim import modal_truth, time_record

from modal_twin.identification import n4sid, select_modes, ssi_cov, stabilization_diagram

F = [0.69, 0.95, 1.6, 2.6, 3.9, 5.3, 7.4, 9.8, 12.9, 16.5]
Z = [0.02, 0.03, 0.02, 0.025, 0.02, 0.03, 0.02, 0.025, 0.03, 0.02]
ORDERS = list(range(2, 67, 2))


def errors(mm, truth) -> np.ndarray:  # type: ignore[no-untyped-def]
    """(n_modes, 2) percent errors of frequency and damping; NaN where missed (> 2 %)."""
    out = np.full((truth.f_hz.size, 2), np.nan)
    for j, (f0, z0) in enumerate(zip(truth.f_hz, truth.zeta, strict=True)):
        if mm.f_hz.size:
            k = int(np.argmin(np.abs(mm.f_hz - f0)))
            if abs(mm.f_hz[k] / f0 - 1) <= 0.02:
                out[j] = 100 * (mm.f_hz[k] / f0 - 1), 100 * (mm.zeta[k] / z0 - 1)
    return out


def summary(e: np.ndarray) -> dict[str, object]:
    """Per-mode RMS and misses over seeds; median over seeds of the max over found modes."""
    with np.errstate(invalid="ignore"):
        rms = np.sqrt(np.nanmean(e**2, axis=0))
        worst = np.nanmax(np.abs(e), axis=1)
    return {"rms_df_pct": np.round(rms[:, 0], 3).tolist(),
            "rms_dz_pct": np.round(rms[:, 1], 1).tolist(),
            "missed": np.isnan(e[:, :, 0]).sum(axis=0).tolist(),
            "median_max_df_pct": round(float(np.nanmedian(worst[:, 0])), 3),
            "median_max_dz_pct": round(float(np.nanmedian(worst[:, 1])), 1)}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--long", type=int, default=8, help="length factor of the long record")
    ap.add_argument("--block-rows", default="13,28")
    a = ap.parse_args()
    truth = modal_truth(F, Z, 42, 12, seed=3)
    brs = [int(b) for b in a.block_rows.split(",")]
    cov: dict[int, list[np.ndarray]] = {b: [] for b in brs}
    io: list[np.ndarray] = []
    for seed in range(4, 4 + a.seeds):  # seed 4 is bench_identification's record
        r = time_record(truth, 71.4, round(71.4 * 172), seed=seed)
        for b in brs:
            sw = ssi_cov(r.y, r.fs_hz, orders=ORDERS, block_rows=b, n_blocks_std=0)
            cov[b].append(errors(select_modes(stabilization_diagram(sw)), truth))
        sw = n4sid(r.u, r.y, r.fs_hz, orders=ORDERS, block_rows=brs[0], n_blocks_std=0)
        io.append(errors(select_modes(stabilization_diagram(sw)), truth))
    out: dict[str, object] = {f"ssi_cov_br{b}": summary(np.array(v)) for b, v in cov.items()}
    out[f"n4sid_br{brs[0]}"] = summary(np.array(io))
    long_r = time_record(truth, 71.4, round(71.4 * 172 * a.long), seed=4)
    sw = ssi_cov(long_r.y, long_r.fs_hz, orders=ORDERS, block_rows=brs[0], n_blocks_std=0)
    out[f"ssi_cov_br{brs[0]}_{a.long}x_longer"] = summary(
        errors(select_modes(stabilization_diagram(sw)), truth)[None])
    for k, v in out.items():
        print(k, v)
    print(json.dumps({"seeds": a.seeds, "record_s": 172, "modes_hz": F, **out}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
