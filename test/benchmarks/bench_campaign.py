"""Campaign benchmark: windows identified per second on 1 and 2 local workers.

A synthetic monitoring record (``--channels`` outputs, four modes between 1.2 and 9 Hz,
2 % damping, white-noise excitation, 5 % sensor noise, 50 Hz) is cut into ``--windows``
windows of ``--window`` seconds; :func:`~modal_twin.identification.campaign.run_campaign`
identifies them by SSI-cov (orders 8-40) on a serial executor and on a process pool of two
workers (pool start-up included), best of ``--repeat``. The two runs must give identical
tables. The machine's other load moves the figures: its load average is printed.

usage: python test/benchmarks/bench_campaign.py [--windows 48] [--window 300] [--repeat 2]
Last line: JSON with windows_per_s_1_worker, windows_per_s_2_workers, speedup_2_workers.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import json
import sys
import time

import numpy as np
import scipy.signal as sig

from modal_twin.identification.campaign import WindowIdentifier, run_campaign, split_windows
from modal_twin.signal_block import SignalBlock

FS = 50.0
F_HZ = (1.2, 2.9, 5.1, 8.7)


def record(n_ch: int, seconds: float, seed: int = 0) -> SignalBlock:
    """Four modes with random shapes, white-noise driven (exact ZOH resonators)."""
    rng = np.random.default_rng(seed)
    n = int(seconds * FS)
    q = np.empty((len(F_HZ), n))
    for r, f in enumerate(F_HZ):
        w = 2 * np.pi * f
        num, den, _ = sig.cont2discrete(([w**2], [1.0, 0.04 * w, w**2]), 1 / FS, method="zoh")
        q[r] = sig.lfilter(np.ravel(num), den, rng.standard_normal(n))
    y = rng.standard_normal((n_ch, len(F_HZ))) @ q
    y += 0.05 * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)
    return SignalBlock(tuple(f"a{c:02d}" for c in range(n_ch)), FS, 0, y, source="bench")


def timed(windows, names, workers: int, repeat: int):  # type: ignore[no-untyped-def]
    ident = WindowIdentifier(f_range_hz=(0.5, 20.0))
    best, res = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        res = run_campaign(windows, names, identifier=ident, executor=workers)
        best = min(best, time.perf_counter() - t0)
    return best, res


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--windows", type=int, default=48)
    ap.add_argument("--window", type=float, default=300.0, help="window length, s")
    ap.add_argument("--channels", type=int, default=12)
    ap.add_argument("--repeat", type=int, default=2)
    a = ap.parse_args()
    blk = record(a.channels, a.windows * a.window)
    w = split_windows(blk, a.window, outputs=blk.channel_names)
    load0 = os.getloadavg()[0]
    t1, r1 = timed(w, blk.channel_names, 1, a.repeat)
    t2, r2 = timed(w, blk.channel_names, 2, a.repeat)
    same = r1.rows() == r2.rows()
    f = [float(np.median(r1.track_series(k)[1])) for k in range(r1.n_tracks)]
    figures = {
        "windows": len(w), "window_s": a.window, "channels": a.channels,
        "windows_per_s_1_worker": round(len(w) / t1, 3),
        "windows_per_s_2_workers": round(len(w) / t2, 3),
        "speedup_2_workers": round(t1 / t2, 3),
        "seconds_1_worker": round(t1, 3), "seconds_2_workers": round(t2, 3),
        "identical_tables": same, "n_tracks": r1.n_tracks,
        "load_avg_1min_at_start": round(load0, 2), "cores": len(os.sched_getaffinity(0)),
    }
    print(f"{len(w)} windows of {a.window} s x {a.channels} ch: 1 worker {t1:.2f} s, "
          f"2 workers {t2:.2f} s; tracks at {np.round(f, 3).tolist()} Hz (truth {F_HZ})")
    print(json.dumps(figures))
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
