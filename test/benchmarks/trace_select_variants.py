"""Selection rules tried on the five modes the default misses, with the truth beside them.

Issue 22, point 1 (session 14). On each real record (as ``trace_real_modes.py``) the
default identification (:func:`identify_record`: output-only SSI-cov, the clustering of
``clustering.cluster_modes``) is compared with the references (``_truth/modal_reference``:
modes FDD and a plain SSI-cov agree on within 1 %, "agreed"; a reported mode within 1 % of
neither is "seen by neither"), and so are these candidate rules:

- ``rows d``: the default at block rows i + d (d = -2..2), the same selection;
- ``pooled``: the poles of block rows i-2..i+2 (or i-1..i+1) in one diagram, one order
  after the other (each horizon's orders in turn), clustered once (a physical mode
  repeats over the settings, noise poles scatter);
- ``weak f / m``: a second path for the stable columns the clustering loses: poles stable
  in frequency (next order within 1 %), damped in (0, 20 %), chained in frequency (gaps
  below 1 %, the reference's grouping) into a column at ``f`` or more of the orders; a
  column more than 2 % from every reported mode is added where the first singular value
  of the output PSD matrix peaks within its half-power half-width (``peaks.on_peak``,
  ratio 2, as ``clustering.spectral_peak``) and the shape of the column's median pole has
  MAC >= ``m`` with the first singular vector at that line.

For each missed agreed mode: the nearest weak-path column (frequency, offset, orders,
peak, MAC, MPC) and the horizons d at which the default reports it within 0.5 %. Then the
same rules on the simulated records of ``bench_selection_truth.py`` (true modes found
within 0.5 % / spurious, as there).

usage: python test/benchmarks/trace_select_variants.py [--shared ../shared]  (~1 min)
Last line: JSON, per rule the real records' agreed-within-0.5 % and seen-by-neither
counts and the truth's found / spurious counts.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import json
import sys
import tempfile
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import scipy.signal as sig

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_real_modes import earthquakes, imported
from bench_selection_truth import claim, records
from trace_real_modes import RECORDS, references

WEAK = ((0.5, 0.8), (0.2, 0.8), (0.2, 0.0))  # (fraction of the orders, least MAC)


def _sv1(yq: np.ndarray, fs: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """First singular value and vector of the output PSD matrix per line (Welch, as
    ``clustering.spectral_peak``)."""
    y0 = yq - yq.mean(axis=1, keepdims=True)
    nper = int(2 ** np.floor(np.log2(max(y0.shape[1] / 4.5, 16.0))))
    fg, G = sig.csd(y0[:, None, :], y0[None, :, :], fs=fs, nperseg=nper, axis=-1)
    U, S, _ = np.linalg.svd(np.moveaxis(G, -1, 0))
    return fg, S[:, 0], U[:, :, 0]


def _columns(diag: Any, band: tuple[float, float], frac: float) -> list[dict[str, Any]]:
    """The weak path's 1 % chains of poles stable in frequency (module docstring)."""
    rows = []
    for k, (p, sf) in enumerate(zip(diag.poles, diag.stable_f, strict=True)):
        q = np.nonzero(sf & np.isfinite(p.f_hz) & (p.zeta > 0) & (p.zeta < 0.2)
                       & (p.f_hz >= band[0]) & (p.f_hz <= band[1]))[0]
        rows += [(k, int(j), float(p.f_hz[j]), float(p.zeta[j])) for j in q]
    if not rows:
        return []
    rows.sort(key=lambda r: r[2])
    f = np.array([r[2] for r in rows])
    out = []
    for g in np.split(np.arange(f.size), np.nonzero(np.diff(f) / f[:-1] > 0.01)[0] + 1):
        ords = {rows[i][0] for i in g}
        if len(ords) >= frac * len(diag.poles):
            fm = float(np.median(f[g]))
            k, j = rows[int(g[np.argmin(np.abs(f[g] - fm))])][:2]
            out.append({"f": fm, "z": float(np.median([rows[i][3] for i in g])),
                        "n": len(ords), "shape": diag.poles[k].shapes[:, j]})
    return out


def _judge(col: dict[str, Any], fg: np.ndarray, s1: np.ndarray, u1: np.ndarray
           ) -> tuple[bool, float]:
    """Whether the first singular value peaks under the column, and the MAC there."""
    from modal_twin.identification.peaks import on_peak

    fm, zm = col["f"], col["z"]
    w = max(min(zm, 0.02) * fm, 0.005 * fm, 1.5 * float(fg[1] - fg[0]))
    core = np.nonzero(np.abs(fg - fm) <= w)[0]
    k = int(core[np.argmax(s1[core])]) if core.size else int(np.argmin(np.abs(fg - fm)))
    u, v = col["shape"], u1[k]
    mac = float(np.abs(np.vdot(v, u)) ** 2 / (np.vdot(v, v).real * np.vdot(u, u).real))
    return bool(on_peak(fg, s1, fm, w, 2.0)[0]), mac


def _weak(f_rep: np.ndarray, diag: Any, band: tuple[float, float], sv: tuple[Any, ...],
          frac: float, mac_min: float) -> np.ndarray:
    add = []
    for c in _columns(diag, band, frac):
        if f_rep.size and np.min(np.abs(f_rep / c["f"] - 1)) <= 0.02:
            continue
        peak, mac = _judge(c, *sv)
        if peak and mac >= mac_min:
            add.append(c["f"])
    return np.sort(np.r_[f_rep, add])


def _variants(yq: np.ndarray, s: Any, quantities: list[str], f_rep: np.ndarray, diag: Any
              ) -> dict[str, np.ndarray]:
    """Every rule's reported frequencies (Hz) on one record."""
    from modal_twin.identification.clustering import cluster_modes, is_harmonic, spectral_peak
    from modal_twin.identification.modal_model import PoleSweep
    from modal_twin.identification.record import MPC_MIN, scale_groups
    from modal_twin.identification.ssi_cov import ssi_cov
    from modal_twin.identification.stabilization import stabilization_diagram

    groups, _ = scale_groups(yq, quantities)
    sweeps = {d: ssi_cov(yq, s.fs_hz, orders=s.orders, block_rows=s.block_rows + d,
                         n_blocks_std=8, scale_groups=groups) for d in (-2, -1, 0, 1, 2)}
    peak = spectral_peak(yq, s.fs_hz)

    def select(sw: Any) -> np.ndarray:
        cm = cluster_modes(stabilization_diagram(sw), zeta_max=0.2, f_range_hz=s.band_hz,
                           mpc_min=MPC_MIN, harmonic=lambda f: is_harmonic(yq, s.fs_hz, f),
                           spectrum=peak)
        return np.asarray(cm.modes.f_hz)

    out = {"shipped": f_rep} | {f"rows {d:+d}": select(sweeps[d]) for d in (-2, -1, 1, 2)}
    for ds in ((-2, -1, 0, 1, 2), (-1, 0, 1)):
        seq = [(sweeps[d], k) for d in ds for k in range(len(sweeps[d].orders))]
        pooled = PoleSweep("ssi-cov", np.array([sw.orders[k] for sw, k in seq]),
                           tuple(sw.poles[k] for sw, k in seq), sweeps[0].singular_values,
                           sweeps[0].n_blocks_std)
        out[f"pooled rows {ds[0]:+d}..{ds[-1]:+d}"] = select(pooled)
    sv = _sv1(yq, s.fs_hz)
    for frac, m in WEAK:
        out[f"weak {frac:g} / {m:g}"] = _weak(f_rep, diag, s.band_hz, sv, frac, m)
    return out


def _real(bag: Path, tag: str, tally: dict[str, list[int]]) -> list[str]:
    from modal_twin.acquisition.decimation import decimate
    from modal_twin.identification.metrics import mpc
    from modal_twin.identification.record import identify_record
    from modal_twin.io.imported import read_imported

    blk, ch = read_imported(bag)
    rec = identify_record(blk, ch)
    s = rec.settings
    y = blk.select(tuple(c.name for c in rec.outputs)).data
    yq = decimate(y, blk.fs_hz, s.factor).x if s.factor > 1 else y
    _, f_fdd, f_ssi, agreed = references(yq, s.fs_hz, s.band_hz)
    res = _variants(yq, s, [c.quantity for c in rec.outputs], rec.modes.f_hz, rec.diagram)
    out = [f"\n== {tag}: agreed {np.round(agreed, 3).tolist()}"]
    for name, f in res.items():
        hit = [a for a in agreed if f.size and np.min(np.abs(f / a - 1)) <= 0.005]
        lack = [round(float(x), 3) for x in f if np.min(np.abs(f_fdd / x - 1)) > 0.01
                and np.min(np.abs(f_ssi / x - 1)) > 0.01]
        t = tally.setdefault(name, [0, 0, 0, 0, 0])
        t[0] += len(hit)
        t[1] += len(lack)
        out.append(f"   {name:20s} {len(hit):2d} of {agreed.size} agreed within 0.5 %, seen by "
                   f"neither {lack}; reports {np.round(f, 3).tolist()}")
    sv = _sv1(yq, s.fs_hz)
    cols = _columns(rec.diagram, s.band_hz, 0.2)
    for a in agreed:
        if np.min(np.abs(rec.modes.f_hz / a - 1)) <= 0.005 if rec.modes.f_hz.size else False:
            continue
        at = [d for d in ("-2", "-1", "+1", "+2")
              if res[f"rows {d}"].size and np.min(np.abs(res[f"rows {d}"] / a - 1)) <= 0.005]
        line = (f"   missed {a:.3f} Hz: the default reports it within 0.5 % at block rows "
                + (", ".join(f"i{d}" for d in at) or "none of i-2..i+2"))
        if cols:
            c = min(cols, key=lambda c_: abs(c_["f"] / a - 1))
            peak, mac = _judge(c, *sv)
            line += (f"; nearest weak-path column {c['f']:.4f} Hz ({100 * (c['f'] / a - 1):+.2f} %"
                     f", {c['n']} orders, SV1 peak {'yes' if peak else 'no'}, MAC {mac:.2f}, "
                     f"MPC {float(mpc(c['shape'][:, None])[0]):.2f})")
        out.append(line)
    return out


def _truth(tally: dict[str, list[int]]) -> list[str]:
    from modal_twin.acquisition.decimation import decimate
    from modal_twin.channels import ChannelSpec
    from modal_twin.identification.record import identify_record
    from modal_twin.signal_block import SignalBlock

    out = ["\n== simulated records with known modes (bench_selection_truth.py)"]
    for name, y, fs, f_true, z_true in records():
        names = tuple(f"a{k}" for k in range(y.shape[0]))
        rec = identify_record(SignalBlock(names, fs, 0, y), [
            ChannelSpec(n, "acceleration", direction="x", role="output") for n in names])
        s = rec.settings
        yq = decimate(y, fs, s.factor).x if s.factor > 1 else y
        inside = (f_true >= s.band_hz[0]) & (f_true <= s.band_hz[1])
        res = _variants(yq, s, ["acceleration"] * y.shape[0], rec.modes.f_hz, rec.diagram)
        cells = []
        for rule, f in res.items():
            found, _, spur = claim(f, f_true[inside], z_true[inside])
            t = tally.setdefault(rule, [0, 0, 0, 0, 0])
            t[2] += len(found)
            t[3] += int(inside.sum())
            t[4] += len(spur)
            cells.append(f"{rule} {len(found)}/{len(spur)}")
        out.append(f"   {name}: " + "; ".join(cells))
    return out


def main() -> int:
    eq = earthquakes(__doc__.splitlines()[0])
    tally: dict[str, list[int]] = {}
    warnings.simplefilter("ignore", RuntimeWarning)
    if eq is not None:
        with tempfile.TemporaryDirectory() as tmp:
            for tag, bag in imported(tmp, eq, RECORDS):
                print("\n".join(_real(bag, tag, tally)), flush=True)
    print("\n".join(_truth(tally)))
    print("\n   rule                 real: agreed within 0.5 % / seen by neither   truth: "
          "found / spurious")
    for rule, (h, n, fd, nt, sp) in tally.items():
        print(f"   {rule:20s} {h:3d} / {n:<3d}{'':30s} {fd:3d} of {nt} / {sp}")
    print(json.dumps({r: {"real_agreed_within_0_5pct": t[0], "real_seen_by_neither": t[1],
                          "truth_found": t[2], "truth_n_true": t[3], "truth_spurious": t[4]}
                      for r, t in tally.items()}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
