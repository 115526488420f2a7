"""Automatic mode selection on simulated records with known modes: found and spurious.

The honesty check of a selection rule (issue 22, point 1): a rule that gains on the real
records (``bench_real_modes.py``) must not lose true modes or add false ones where the
modes are known. ``modal-twin identify``'s pipeline (:func:`identify_record`, default
method: output-only SSI-cov and the clustering of the poles) runs on

- ``stationary``: the 6-mode structure of ``bench_identification.py`` record (a)
  (3.2-31 Hz, 1-3 % damped, 20 outputs, 200 s at 100 Hz, 20 dB output noise), its
  outputs only, seeds 1-3;
- ``transient``: a 5-DOF shear chain (1.14-7.68 Hz, 2 % damped) shaken at its base by
  60 s of earthquake-like ground motion (build-up, strong motion, decay; 26 dB output
  noise), absolute floor accelerations, seeds 1-5 (``_modal_sim.chain_earthquake``).

Per record, over the band the run chose (true modes outside it are not counted): each
true mode claims the nearest reported mode within its half-power band (2 zeta f); a
claimed mode within 0.5 % is "found", one further off is "off" (an inaccurate estimate
of a true mode: a 60 s transient holds few cycles of its lowest mode); a reported mode
no true mode claims is "spurious" (noise, or a second mode for one true mode).

usage: python test/benchmarks/bench_selection_truth.py
Last line: JSON with the totals (``found``, ``n_true``, ``spurious``, ``off``) and per
record the true and reported frequencies (Hz).
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _modal_sim import chain_earthquake, modal_truth, time_record

ZETA6 = [0.02, 0.015, 0.03, 0.02, 0.025, 0.01]
F6 = [3.2, 7.9, 12.5, 18.1, 24.6, 31.0]


def records() -> list[tuple[str, np.ndarray, float, np.ndarray, np.ndarray]]:
    """(name, outputs, fs_hz, true frequencies, true damping ratios) of every record."""
    out = []
    truth = modal_truth(F6, ZETA6, 20, 3, seed=0)
    for seed in (1, 2, 3):
        r = time_record(truth, 100.0, 20000, seed=seed)
        out.append((f"stationary seed {seed}", r.y, 100.0, truth.f_hz, truth.zeta))
    for seed in (1, 2, 3, 4, 5):
        y, f, z = chain_earthquake(60.0, 100.0, seed=seed)
        out.append((f"transient seed {seed}", y, 100.0, f, z))
    return out


def claim(f: np.ndarray, f_true: np.ndarray, z_true: np.ndarray
          ) -> tuple[list[float], list[float], list[float]]:
    """(found, off, spurious) of the reported ``f`` against the truth (module docstring)."""
    claimed: dict[int, float] = {}  # reported index -> its true mode
    for a, za in zip(f_true, z_true, strict=True):
        k = int(np.argmin(np.abs(f - a))) if f.size else -1
        if k >= 0 and abs(f[k] / a - 1) <= 2 * za and k not in claimed:
            claimed[k] = float(a)
    found = [a for k, a in claimed.items() if abs(f[k] / a - 1) <= 0.005]
    off = [a for k, a in claimed.items() if abs(f[k] / a - 1) > 0.005]
    spur = [round(float(x), 3) for k, x in enumerate(f) if k not in claimed]
    return found, off, spur


def main() -> int:
    from modal_twin.channels import ChannelSpec
    from modal_twin.identification.record import identify_record
    from modal_twin.signal_block import SignalBlock

    tot = {"found": 0, "n_true": 0, "spurious": 0, "off": 0}
    per = {}
    print(f"{'record':22s} {'band Hz':>13s} {'found':>7s} {'spurious':>8s} {'off':>4s}  "
          "reported [Hz] / missed true [Hz]")
    for name, y, fs, f_true, z_true in records():
        names = tuple(f"a{k}" for k in range(y.shape[0]))
        chans = [ChannelSpec(n, "acceleration", direction="x", role="output") for n in names]
        rec = identify_record(SignalBlock(names, fs, 0, y), chans)
        lo, hi = rec.settings.band_hz
        inside = (f_true >= lo) & (f_true <= hi)
        ft, zt = f_true[inside], z_true[inside]
        f = rec.modes.f_hz
        found, off_, spur = claim(f, ft, zt)
        off = len(off_)
        missed = [round(float(a), 3) for a in ft if a not in found]
        print(f"{name:22s} {lo:6.2f}-{hi:6.2f} {len(found):3d}/{ft.size:<3d} {len(spur):8d} "
              f"{off:4d}  {np.round(f, 3).tolist()} / {missed}")
        tot["found"] += len(found)
        tot["n_true"] += int(ft.size)
        tot["spurious"] += len(spur)
        tot["off"] += int(off)
        per[name] = {"true_hz": np.round(ft, 3).tolist(), "reported_hz": np.round(f, 3).tolist(),
                     "spurious_hz": spur}
    print(f"total: found {tot['found']} of {tot['n_true']}, spurious {tot['spurious']}, "
          f"off (beyond 0.5 %, within 2 zeta) {tot['off']}")
    print(json.dumps({**tot, "records": per}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
