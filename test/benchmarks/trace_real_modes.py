"""Where the product's SSI-cov loses each mode the plain references agree on (issue 22, 1).

For each real record (as ``bench_real_modes.py``: imported with ``modal-twin import``, the
outputs decimated to the band ``identify`` chooses) the plain reference SSI-cov
(``_truth/modal_reference.py``) and the product's ``ssi_cov`` run on the same channels,
and the chain between them is walked one step at a time:

- settings S1..S6: the library's poles with the reference's settings (S1: one scale for
  all channels, i.e. the raw units, the reference's block rows ``int(fs / (4 f_lo))`` and
  orders 10..60), then the product's block rows ``ceil(...)`` (S2), its orders 2..60
  (S3), and the same three with the product's channel scales (``record.scale_groups``:
  S4 with the reference's rows and orders, S5 rows, S6 = the product);
- for each setting, the reference's own grouping of those poles (1 % chain, half the
  orders: ``col`` / ``---``), and how far each agreed mode gets through the product's
  selection (``clustering.cluster_modes``): P1 a pole within 1 % (damped 0-10 %), P2 poles
  that repeat (distance to the next order's nearest pole below the cut-off), P3 a
  single-linkage cluster of at least 3 poles, P5 enough poles after the outliers and the
  order-split join, P6 MPC / damping scatter / spectral peak, P7 duplicates; REPORTED is
  within 0.5 % of the agreed frequency.

Then, per missed mode, the product's poles within 3 % (order, f, zeta, MPC, distance to the
next order), and how the reference's agreed set moves with its own block rows (r-2..r+2).

usage: python test/benchmarks/trace_real_modes.py [--shared ../shared]
Last line: JSON, per record the agreed modes (Hz), the band (Hz) and per agreed mode the code
of each step S1..S6 and whether the reference agrees on it again at rows r-2, r-1, r+1, r+2.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import json
import sys
import tempfile
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import scipy.cluster.hierarchy as sch

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _truth.modal_reference import agreed_modes, fdd_peaks, ssi_cov_columns
from bench_real_modes import RECORDS as BENCH_RECORDS
from bench_real_modes import earthquakes, imported

RECORDS = [r for r in BENCH_RECORDS if not r[0].endswith("no map")]  # the same channels
REF_ORDERS = tuple(range(10, 61, 2))


def _ref_grouping(sweep: Any, band: tuple[float, float], orders: tuple[int, ...]
                  ) -> list[tuple[float, float, float, int]]:
    """The reference's grouping of a sweep's poles: (median, lowest, highest, orders)."""
    found = []
    for o, p in zip(sweep.orders, sweep.poles, strict=True):
        keep = (p.zeta > 0) & (p.zeta < 0.1) & (p.f_hz >= band[0]) & (p.f_hz <= band[1])
        found += [(int(o), float(v)) for v in p.f_hz[keep]]
    if not found:
        return []
    fs = np.sort([v for _, v in found])
    groups = [[fs[0]]]
    for v in fs[1:]:
        if v - groups[-1][-1] <= 0.01 * v:
            groups[-1].append(v)
        else:
            groups.append([v])
    out = []
    for g in groups:
        n_ord = len({o for o, v in found if g[0] <= v <= g[-1]})
        if n_ord >= 0.5 * len(orders):
            out.append((float(np.median(g)), g[0], g[-1], n_ord))
    return out


def _selection_codes(diag: Any, band: tuple[float, float], yq: np.ndarray, fs: float,
                     targets: np.ndarray) -> tuple[dict[float, str], list[float]]:
    """How far each target gets through ``cluster_modes`` (module docstring)."""
    from modal_twin.identification import clustering as clu
    from modal_twin.identification.record import MPC_MIN

    t = clu._pole_table(diag)
    cut = clu._cutoff(t.d_next)
    rep = np.nonzero(t.d_next <= cut)[0]
    D = clu.pole_distances(t.f[rep], t.z[rep], t.u[:, rep], t.f[rep], t.z[rep], t.u[:, rep])
    D = 0.5 * (D + D.T)
    np.fill_diagonal(D, 0.0)
    lab = sch.fcluster(sch.linkage(D[np.triu_indices(rep.size, 1)], method="single"),
                       t=cut, criterion="distance")

    def harmonic(f: float) -> bool:
        return clu.is_harmonic(yq, fs, f)

    spectrum = clu.spectral_peak(yq, fs)
    cm = clu.cluster_modes(diag, zeta_max=0.2, f_range_hz=band, mpc_min=MPC_MIN,
                         harmonic=harmonic, spectrum=spectrum)
    groups = clu._join_order_split(clu._groups(t, rep, lab, clu.ZETA_MIN, 0.2, harmonic), t,
                                 clu.MAC_SPLIT, cm.n_min)
    codes = {}
    for f0 in targets:
        f = cm.modes.f_hz
        dev = np.min(np.abs(f / f0 - 1)) if f.size else np.inf
        near = np.abs(t.f / f0 - 1) <= 0.01
        near_g = [g for g in groups if abs(np.median(t.f[g[3]]) / f0 - 1) <= 0.01
                  or np.any(np.abs(t.f[g[0]] / f0 - 1) <= 0.005)]
        long_g = [g for g in near_g if g[2].size >= cm.n_min]
        whys = [clu._candidate(t, g[3], (0, 0), MPC_MIN, 1.0, spectrum)[1] for g in long_g]
        if dev <= 0.005:
            code = "REPORTED"
        elif dev <= 0.01:
            code = f"reported {100 * dev:.2f} % off"
        elif not np.any(near & (t.z > 0) & (t.z < 0.1)):
            code = "P1 no pole"
        elif not np.any(near[rep]):
            code = "P2 not repeating"
        elif not near_g:
            code = "P3 no cluster"
        elif not long_g:
            code = f"P5 too few ({max(g[2].size for g in near_g)} < {cm.n_min})"
        elif any(w.startswith("MPC") for w in whys):
            code = "P6 MPC"
        elif any("damping not" in w for w in whys):
            code = "P6 zeta scatter"
        elif any("no peak" in w for w in whys):
            code = "P6 no peak"
        else:
            code = "P7 duplicate / other"
        codes[float(f0)] = code
    return codes, [round(float(x), 3) for x in cm.modes.f_hz]


def _poles_near(diag: Any, f0: float, rel: float = 0.03) -> list[str]:
    from modal_twin.identification import clustering as clu
    from modal_twin.identification.metrics import mpc

    t = clu._pole_table(diag)
    return [f"      order {diag.orders[t.order_ix[k]]:3d}  f {t.f[k]:8.4f}  zeta "
            f"{100 * t.z[k]:6.2f} %  MPC {float(mpc(t.u[:, [k]])[0]):.2f}  d_next "
            f"{t.d_next[k]:.4f}" for k in np.nonzero(np.abs(t.f / f0 - 1) <= rel)[0]]


def references(yq: np.ndarray, fq: float, band: tuple[float, float]
               ) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    """The references on decimated outputs, as ``bench_real_modes.py``: (block rows, FDD
    peaks, plain SSI-cov columns, the modes both agree on), frequencies in Hz."""
    rows = max(10, min(int(fq / (4 * band[0])), 1200 // yq.shape[0]))
    f_fdd = fdd_peaks(yq, fq, band)[0]
    f_ssi = ssi_cov_columns(yq, fq, band, rows=rows, orders=range(10, 61, 2))
    return rows, f_fdd, f_ssi, agreed_modes(f_fdd, f_ssi)


def _record(bag: Path, tag: str) -> tuple[list[str], dict[str, Any]]:
    from modal_twin.acquisition.decimation import decimate
    from modal_twin.identification.record import (
        STRICT,
        IdentifyOptions,
        _corners,
        _settings,
        scale_groups,
    )
    from modal_twin.identification.ssi_cov import ssi_cov
    from modal_twin.identification.stabilization import stabilization_diagram
    from modal_twin.io.imported import read_imported

    blk, ch = read_imported(bag)
    outs = [c for c in ch if c.effective_role == "output"]
    y = blk.select(tuple(c.name for c in outs)).data
    s = _settings(y, blk.fs_hz, 0, IdentifyOptions(), _corners(outs))
    band = s.band_hz
    yq, fq = decimate(y, blk.fs_hz, s.factor).x, s.fs_hz
    rows, f_fdd, f_ssi, agreed = references(yq, fq, band)
    groups, note = scale_groups(yq, [c.quantity for c in outs])
    same = ["one"] * len(outs)
    steps = [("S1", same, rows, REF_ORDERS), ("S2", same, s.block_rows, REF_ORDERS),
             ("S3", same, s.block_rows, s.orders), ("S4", groups, rows, REF_ORDERS),
             ("S5", groups, s.block_rows, REF_ORDERS), ("S6", groups, s.block_rows, s.orders)]
    out = [f"\n== {tag}: band {band[0]:.3f}-{band[1]:.3f} Hz, decimation x{s.factor}, "
           f"{len(outs)} outputs; reference rows {rows}, orders 10..60; product rows "
           f"{s.block_rows}, orders {s.orders[0]}..{s.orders[-1]}; product {note}",
           f"   reference columns {np.round(f_ssi, 3).tolist()}",
           f"   agreed {np.round(agreed, 3).tolist()}"]
    table: dict[float, dict[str, str]] = {float(a): {} for a in agreed}
    diags = {}
    for name, g, i, o in steps:
        sw = ssi_cov(yq, fq, orders=o, block_rows=i, n_blocks_std=4, scale_groups=g)
        diag = stabilization_diagram(sw, **STRICT)
        diags[name] = diag
        cols = _ref_grouping(sw, band, o)
        codes, rep = _selection_codes(diag, band, yq, fq, agreed)
        out.append(f"   {name}: reference grouping {[round(c[0], 3) for c in cols]}; "
                   f"product selection {rep}")
        for a in agreed:
            col = [c for c in cols if abs(c[0] / a - 1) <= 0.01]
            table[float(a)][name] = ("col" if col else "---") + " | " + codes[float(a)]
    out.append(f"   mode x step ({' '.join(n for n, *_ in steps)}); cell: the reference's "
               f"grouping of these poles | the product's selection")
    for a, row in table.items():
        out.append(f"   {a:8.3f}  " + "  ".join(f"{v:26s}" for v in row.values()))
    missed = [a for a, row in table.items() if not row["S6"].endswith("| REPORTED")]
    for a in missed:
        out.append(f"   the product's poles within 3 % of {a:.3f} Hz (S6):")
        out += _poles_near(diags["S6"], a)
    seen: dict[float, str] = {float(a): "" for a in agreed}
    for dr in (-2, -1, 1, 2):
        a2 = agreed_modes(f_fdd, ssi_cov_columns(yq, fq, band, rows=rows + dr,
                                                 orders=range(10, 61, 2)))
        out.append(f"   reference at rows {rows + dr}: agreed {np.round(a2, 3).tolist()}")
        for a in seen:
            seen[a] += "+" if a2.size and np.min(np.abs(a2 / a - 1)) <= 0.005 else "."
    out.append("   each agreed mode again within 0.5 % at rows r-2, r-1, r+1, r+2: "
               + ", ".join(f"{a:.3f} {v}" for a, v in seen.items()))
    return out, {"steps_by_agreed_mode_hz": {f"{a:.3f}": row | {"ref_rows_pm2": seen[a]}
                                             for a, row in table.items()},
                 "agreed_hz": [round(float(a), 3) for a in agreed],
                 "band_hz": [round(band[0], 3), round(band[1], 3)]}


def run_traces(description: str,
               record: Callable[[Path, str], tuple[list[str], dict[str, Any]]]) -> int:
    """Import each record of :data:`RECORDS`, print ``record``'s lines, then the JSON."""
    eq = earthquakes(description)
    if eq is None:
        return 0
    summary = {}
    warnings.simplefilter("ignore", RuntimeWarning)
    with tempfile.TemporaryDirectory() as tmp:
        for tag, bag in imported(tmp, eq, RECORDS):
            lines, summary[tag] = record(bag, tag)
            print("\n".join(lines), flush=True)
    print(json.dumps(summary))
    return 0


def main() -> int:
    return run_traces(__doc__.splitlines()[0], _record)


if __name__ == "__main__":
    sys.exit(main())
