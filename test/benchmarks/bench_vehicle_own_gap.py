"""Model-form gap between the library's vertical-plane car and the independent truth.

The truth (``_truth/vehicle_own.py``: closed-form free-free beam modes, point suspension
elements, RK4) and the library's car (FE beam reduced by Craig-Bampton, exact modal hold)
run the nominal car on the same track records (8 s; 300 and 350 km/h, the benchmark's
training and held-out speeds). Printed: NRMSE (%) of each floor acceleration, library
against truth, for the file's Craig-Bampton cutoff (40 Hz) and a converged one (300 Hz),
with the truth's carbody damping on the modes of the beam with its bolted item
(``carbody``, the benchmark's) or of the bare beam (``beam``). The benchmark's noise is
1-2 % of each channel's RMS. Last line: one JSON object.

Run: ``PYTHONPATH=$PWD python test/benchmarks/bench_vehicle_own_gap.py``
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _truth.records import track_inputs
from _truth.vehicle_own import INPUTS, VehicleOwn

from modal_twin.diagnosis.fitting import simulate_record
from modal_twin.diagnosis.record import Record
from modal_twin.models.vehicle import assemble_vehicle, build_vehicle, load_vehicle

FS = 200.0


def _nrmse(pred: np.ndarray, ref: np.ndarray) -> np.ndarray:
    return np.sqrt(np.mean((pred - ref) ** 2, axis=1) / np.mean(ref**2, axis=1))


def main() -> None:
    out: dict[str, float] = {}
    plants = {cut: build_vehicle(cutoff_hz=cut) for cut in (40.0, 300.0)}
    for speed, seed in ((300.0, 4), (350.0, 5)):
        u = track_inputs(VehicleOwn().axle_x, speed, 8.0, FS, 1.5e-3, seed)
        for modes in ("carbody", "beam"):
            truth = VehicleOwn(damping_modes=modes)
            y = truth.simulate(u, FS)
            rec = Record(FS, INPUTS, u, truth.channel_names(), y)
            for cut, plant in plants.items():
                err = 100.0 * _nrmse(simulate_record(plant, rec), y)
                print(f"{speed:5.0f} km/h  damping on {modes:7s}  CB cutoff {cut:5.0f} Hz  "
                      "floor NRMSE % " + " ".join(f"{e:5.2f}" for e in err))
                key = f"{int(speed)}kmh_{modes}_cut{int(cut)}"
                out[f"floor_nrmse_max_pct_{key}"] = round(float(err.max()), 3)
                out[f"floor_nrmse_median_pct_{key}"] = round(float(np.median(err)), 3)
    spec = load_vehicle()
    for cut in (40.0, 300.0):
        f = assemble_vehicle(spec, cutoff_hz=cut).f_hz
        out[f"library_third_bending_hz_cut{int(cut)}"] = round(float(f[8]), 3)
    out["truth_third_bending_hz"] = round(float(VehicleOwn().natural_frequencies_hz()[8]), 3)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
