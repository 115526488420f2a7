"""Where ``identify --method n4sid`` loses the modes the output-only references agree on.

For each real record (imported as ``bench_real_modes.py`` does; the inputs and outputs of
its channel map, decimated to the band ``identify --method n4sid`` chooses):

- per agreed mode (FDD and a plain SSI-cov, ``_truth/modal_reference.py``): how much the
  summed output PSD and the summed input PSD peak there (the largest line within 1 % over
  the median at 3-6 % away) and how much their ratio (a crude transmissibility) peaks;
  a mode the inputs carry as strongly as the outputs is in the ground motion, not a pole
  of the system from the inputs to the outputs;
- the model orders (2..60) with an N4SID pole within 1 % (damped 0-10 %), for the
  PO-MOESP weighting (``oblique``, the only form before session 13) and the
  covariance-driven one (``covariance``);
- each form's stable columns (a 1 % chain of poles at half the orders or more) and the
  modes ``identify --method n4sid`` reports.

usage: python test/benchmarks/trace_n4sid_real.py [--shared ../shared]
Last line: JSON, per record the agreed modes (Hz) with their output / input / ratio peak
prominences and the orders with a pole within 1 % per form.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import sys
from pathlib import Path
from typing import Any

import numpy as np
import scipy.signal as sig

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _truth.modal_reference import agreed_modes, fdd_peaks, ssi_cov_columns
from trace_real_modes import _ref_grouping, run_traces


def _prominence(f: np.ndarray, p: np.ndarray, f0: float) -> float:
    near = np.abs(f / f0 - 1) <= 0.01
    flank = (np.abs(f / f0 - 1) > 0.03) & (np.abs(f / f0 - 1) <= 0.06)
    if not near.any() or not flank.any():
        return float("nan")
    return float(p[near].max() / np.median(p[flank]))


def _record(bag: Path, tag: str) -> tuple[list[str], dict[str, Any]]:
    from modal_twin.acquisition.decimation import decimate
    from modal_twin.identification.n4sid import n4sid
    from modal_twin.identification.record import (
        IdentifyOptions,
        _corners,
        _settings,
        identify_record,
    )
    from modal_twin.io.imported import read_imported

    blk, ch = read_imported(bag)
    outs = [c for c in ch if c.effective_role == "output"]
    ins = [c for c in ch if c.effective_role == "input"]
    y = blk.select(tuple(c.name for c in outs)).data
    u = blk.select(tuple(c.name for c in ins)).data
    s = _settings(y, blk.fs_hz, len(ins), IdentifyOptions(method="n4sid"), _corners(outs + ins))
    yq, uq, fq = decimate(y, blk.fs_hz, s.factor).x, decimate(u, blk.fs_hz, s.factor).x, s.fs_hz
    band = s.band_hz
    rows = max(10, min(int(fq / (4 * band[0])), 1200 // len(outs)))
    agreed = agreed_modes(fdd_peaks(yq, fq, band)[0],
                          ssi_cov_columns(yq, fq, band, rows=rows, orders=range(10, 61, 2)))
    nper = int(2 ** np.floor(np.log2(yq.shape[1] / 6)))
    f, Py = sig.welch(yq - yq.mean(1, keepdims=True), fs=fq, nperseg=nper, nfft=4 * nper)
    _, Pu = sig.welch(uq - uq.mean(1, keepdims=True), fs=fq, nperseg=nper, nfft=4 * nper)
    py, pu = Py.sum(0) / Py.sum(), Pu.sum(0) / Pu.sum()
    sweeps = {w: n4sid(uq, yq, fq, orders=s.orders, block_rows=s.block_rows, n_blocks_std=0,
                       weighting=w) for w in ("oblique", "covariance")}
    rec = identify_record(blk, ch, IdentifyOptions(method="n4sid"))
    out = [f"\n== {tag}: {len(ins)} inputs, {len(outs)} outputs, {s.describe()}",
           f"   agreed (FDD + plain SSI-cov): {np.round(agreed, 3).tolist()}",
           f"   identify --method n4sid: {np.round(rec.modes.f_hz, 3).tolist()}"
           f" ({'covariance' if any('covariance-driven' in n for n in rec.notes) else 'oblique'})"]
    for w, sw in sweeps.items():
        cols = _ref_grouping(sw, band, s.orders)
        out.append(f"   {w:10s} columns (1 % chain, >= half the orders): "
                   f"{[round(c[0], 3) for c in cols]}")
    out.append(f"   {'agreed Hz':>10} {'out pk':>7} {'in pk':>7} {'out/in':>7}  orders with an "
               f"N4SID pole within 1 % (oblique | covariance)")
    rows_j: dict[str, Any] = {}
    for a in agreed:
        po, pi, pr = _prominence(f, py, a), _prominence(f, pu, a), _prominence(f, py / pu, a)
        n_ord = {}
        for w, sw in sweeps.items():
            n_ord[w] = sum(bool(np.any((np.abs(p.f_hz / a - 1) <= 0.01) & (p.zeta > 0)
                                       & (p.zeta < 0.1))) for p in sw.poles)
        out.append(f"   {a:10.3f} {po:7.1f} {pi:7.1f} {pr:7.1f}  {n_ord['oblique']:2d} | "
                   f"{n_ord['covariance']:2d} of {len(s.orders)}")
        rows_j[f"{a:.3f}"] = {"out_peak": round(po, 2), "in_peak": round(pi, 2),
                              "ratio_peak": round(pr, 2), "orders_with_pole": n_ord}
    return out, {"agreed_hz": [round(float(a), 3) for a in agreed], "modes": rows_j,
                 "identify_n4sid_hz": [round(float(x), 3) for x in rec.modes.f_hz]}


def main() -> int:
    return run_traces(__doc__.splitlines()[0], _record)


if __name__ == "__main__":
    sys.exit(main())
