"""Output-only PolyMAX, SSI-cov and FDD against a known truth (issue 22, point 4).

Two records with known modes, each over several seeds:

- ``transient``: a 5-DOF chain (unit masses, springs 1600 N/m: modes 1.81, 5.29, 8.34,
  10.71, 12.22 Hz), 1.5-2.5 % modal damping, shaken at its base for 60 s by
  an earthquake-like ground acceleration (0.2-20 Hz noise under a build-up / strong / decay
  envelope), absolute accelerations of the five masses with 5 % white noise, 100 Hz: as
  the real records, a short transient.
- ``stationary``: the same chain under white forces at every mass for 300 s (ambient).

The chain is integrated here (exact zero-order hold of its own state space, scipy),
written apart from the library. For each record ``identify_record`` runs with
``--method polymax`` and ``--method ssi-cov`` (output-only), and FDD peaks
(``_truth/modal_reference.fdd_peaks``) on the same outputs and band. Figures per method:
modes within 0.5 % of a true mode (each true mode counted once), reported modes more than
2 % from every true mode (spurious), and the median of the identified over the true damping
ratio of the modes found within 0.5 %. FDD's figures are its local peaks (no
selection), so its spurious count is a count of peaks, not a false claim.

usage: python test/benchmarks/bench_polymax_truth.py [--seeds 6] [--kinds transient,stationary]
Last line: JSON of the figures per record and method.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import json
import sys
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import scipy.linalg as sla
import scipy.signal as sig

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _truth.modal_reference import fdd_peaks

FS = 100.0
ZETA = np.array([0.015, 0.02, 0.02, 0.025, 0.025])


def chain() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Stiffness K, damping C (modal damping ZETA), natural frequencies (Hz), shapes."""
    k = np.full(5, 1600.0)
    K = np.diag(np.r_[k[:-1] + k[1:], k[-1]]) - np.diag(k[1:], 1) - np.diag(k[1:], -1)
    w2, V = sla.eigh(K)  # unit masses: V orthonormal
    C = V @ np.diag(2 * ZETA * np.sqrt(w2)) @ V.T
    return K, C, np.sqrt(w2) / (2 * np.pi), V


def _ground(seconds: float, seed: int) -> np.ndarray:
    """Earthquake-like ground acceleration: 0.2-20 Hz noise, build-up / strong / decay."""
    n = round(seconds * FS)
    t = np.arange(n) / FS
    rng = np.random.default_rng(seed)
    sos = sig.butter(2, [0.2, 20.0], btype="band", fs=FS, output="sos")
    a = sig.sosfiltfilt(sos, rng.standard_normal(n))
    t1, t2 = 0.1 * seconds, 0.4 * seconds
    env = np.where(t < t1, (t / t1) ** 2, np.where(t < t2, 1.0, np.exp(-5.0 * (t - t2)
                                                                     / seconds)))
    return a * env / np.abs(a * env).max()


def record(kind: str, seed: int) -> np.ndarray:
    """Absolute accelerations (5, n) of the chain with 5 % white noise."""
    K, C, _, _ = chain()
    rng = np.random.default_rng(1000 + seed)
    A = np.block([[np.zeros((5, 5)), np.eye(5)], [-K, -C]])
    if kind == "transient":
        ag = _ground(60.0, seed)
        # relative coordinates: x'' + C x' + K x = -1 ag; absolute x'' + ag = -K x - C x'
        B = np.vstack([np.zeros((5, 1)), -np.ones((5, 1))])
        Cy, Dy = np.hstack([-K, -C]), np.zeros((5, 1))
        u = ag[:, None]
    else:
        n = round(300.0 * FS)
        B = np.vstack([np.zeros((5, 5)), np.eye(5)])
        Cy, Dy = np.hstack([-K, -C]), np.eye(5)
        u = rng.standard_normal((n, 5))
    sysd = sig.cont2discrete((A, B, Cy, Dy), 1 / FS)
    _, y, _ = sig.dlsim((*sysd[:4], 1 / FS), u)
    y = y.T
    return y + 0.05 * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)


def _score(f: np.ndarray, z: np.ndarray, f_true: np.ndarray) -> dict[str, Any]:
    found, ratios = 0, []
    for k, ft in enumerate(f_true):
        if f.size and np.min(np.abs(f / ft - 1)) <= 0.005:
            found += 1
            if z.size:
                ratios.append(float(z[np.argmin(np.abs(f - ft))] / ZETA[k]))
    spurious = int(sum(np.min(np.abs(x / f_true - 1)) > 0.02 for x in f))
    return {"found": found, "spurious": spurious, "zeta_ratios": ratios}


def run(kind: str, seeds: list[int]) -> dict[str, Any]:
    """Per method: found / spurious summed over the seeds, median damping ratio."""
    from modal_twin.channels import ChannelSpec
    from modal_twin.identification.record import IdentifyOptions, identify_record
    from modal_twin.signal_block import SignalBlock

    _, _, f_true, _ = chain()
    tot: dict[str, dict[str, Any]] = {}
    for seed in seeds:
        y = record(kind, seed)
        names = tuple(f"a{k}" for k in range(5))
        chans = [ChannelSpec(n, "acceleration", direction="x", role="output", node=f"n{k}")
                 for k, n in enumerate(names)]
        blk = SignalBlock(names, FS, 0, y)
        res = {}
        band = (0.0, 0.0)
        for m in ("polymax", "ssi-cov"):
            rec = identify_record(blk, chans, IdentifyOptions(method=m))
            band = rec.settings.band_hz
            res[m] = _score(rec.modes.f_hz, rec.modes.zeta, f_true)
            print(f"{kind} seed {seed} {m:8s} {np.round(rec.modes.f_hz, 3).tolist()} "
                  f"zeta% {np.round(100 * rec.modes.zeta, 2).tolist()}", flush=True)
        fq = float(blk.fs_hz)
        fp = fdd_peaks(y, fq, band)[0]
        res["fdd"] = _score(fp, np.zeros(0), f_true)
        print(f"{kind} seed {seed} fdd      {np.round(fp, 3).tolist()}", flush=True)
        for m, r in res.items():
            t = tot.setdefault(m, {"found": 0, "spurious": 0, "zeta_ratios": []})
            for key in ("found", "spurious"):
                t[key] += r[key]
            t["zeta_ratios"] += r["zeta_ratios"]
    out = {}
    for m, t in tot.items():
        zr = t.pop("zeta_ratios")
        out[m] = {"found_of": f"{t['found']} of {5 * len(seeds)}", "found": t["found"],
                  "spurious": t["spurious"],
                  "zeta_ratio_median": round(float(np.median(zr)), 2) if zr else None,
                  "zeta_ratio_range": [round(float(np.min(zr)), 2),
                                       round(float(np.max(zr)), 2)] if zr else None}
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=6)
    ap.add_argument("--kinds", default="transient,stationary")
    a = ap.parse_args()
    warnings.simplefilter("ignore", RuntimeWarning)
    _, _, f_true, _ = chain()
    print(f"true modes {np.round(f_true, 3).tolist()} Hz, damping {ZETA.tolist()}")
    summary = {k: run(k, list(range(1, a.seeds + 1))) for k in a.kinds.split(",")}
    for k, v in summary.items():
        for m, r in v.items():
            print(f"{k:10s} {m:8s} within 0.5 %: {r['found_of']:9s} spurious {r['spurious']:3d}"
                  f"  zeta / true: median {r['zeta_ratio_median']} range "
                  f"{r['zeta_ratio_range']}")
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
