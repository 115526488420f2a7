"""Where output-only PolyMAX loses each mode the plain references agree on (issue 22, 1 and 4).

For each real record (as ``bench_real_modes.py``: imported with ``modal-twin import``) the
default method and ``--method polymax`` run through ``identify_record`` and the references
(``_truth/modal_reference.py``: FDD peaks, a plain SSI-cov) on the same outputs and band.
For each agreed mode (both references within 1 %) the cell says how far PolyMAX gets:

- ``REPORTED``: a PolyMAX mode within 0.5 % of the agreed frequency;
- ``OFF x %``: its nearest PolyMAX mode lies 0.5-1.5 % away: a column PolyMAX reports, but
  not where the references put the mode;
- ``DROPPED (reason)``: a column PolyMAX lists as not reported within 1 %, with its reason;
- ``NO COLUMN (k orders)``: poles within 1 % (damped 0-20 %) at only k of the orders.

Beside it, ``peak``: the nearest local maximum of the first singular value of the
half-spectra PolyMAX fits (prominence 1 dB, within 1.5 %), and its deviation from the
agreed frequency: whether PolyMAX's own data put the mode within 0.5 %.

usage: python test/benchmarks/trace_polymax_modes.py [--shared ../shared]
Last line: JSON, per record the agreed modes (Hz) and per agreed mode the default's and
PolyMAX's deviation (%), PolyMAX's code and the half-spectra peak's deviation (%).
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
from trace_real_modes import run_traces


def _dev(f: np.ndarray, f0: float) -> float:
    """Signed deviation (%) of the member of ``f`` nearest ``f0``; NaN when empty."""
    return float(100 * (f[np.argmin(np.abs(f - f0))] / f0 - 1)) if f.size else float("nan")


def _record(bag: Path, tag: str) -> tuple[list[str], dict[str, Any]]:
    from modal_twin.acquisition.decimation import decimate
    from modal_twin.identification.polymax_oma import _first_singular_value
    from modal_twin.identification.record import (
        IdentifyOptions,
        half_spectra,
        identify_record,
    )
    from modal_twin.io.imported import read_imported

    blk, ch = read_imported(bag)
    default = identify_record(blk, ch, IdentifyOptions())
    pm = identify_record(blk, ch, IdentifyOptions(method="polymax"))
    outs = [c.name for c in pm.outputs]
    s = pm.settings
    band = s.band_hz
    yq = decimate(blk.select(tuple(outs)).data, blk.fs_hz, s.factor).x
    rows = max(10, min(int(s.fs_hz / (4 * band[0])), 1200 // len(outs)))
    f_fdd = fdd_peaks(yq, s.fs_hz, band)[0]
    f_ssi = ssi_cov_columns(yq, s.fs_hz, band, rows=rows, orders=range(10, 61, 2))
    agreed = agreed_modes(f_fdd, f_ssi)
    f, S, _ = half_spectra(yq, s.fs_hz, max(16, yq.shape[1] // 4))  # as record._polymax
    db = 10 * np.log10(np.maximum(_first_singular_value(S), 1e-300))
    peaks = f[sig.find_peaks(db, prominence=1.0)[0]]
    fd, fp = default.modes.f_hz, pm.modes.f_hz
    n_ord = len(pm.sweep.orders)
    out = [f"\n== {tag}: band {band[0]:.3f}-{band[1]:.3f} Hz, {len(outs)} outputs, "
           f"PolyMAX orders {pm.sweep.orders[0]}..{pm.sweep.orders[-1]}",
           f"   agreed {np.round(agreed, 3).tolist()}",
           f"   default ({default.method}) {np.round(fd, 3).tolist()}",
           f"   polymax {np.round(fp, 3).tolist()}",
           f"   {'agreed':>8} {'default %':>9} {'polymax %':>9}  {'half-spectra peak':>18}  "
           f"polymax"]
    rows_json = {}
    for a in agreed:
        dp = _dev(fp, a)
        near_pk = peaks[np.abs(peaks / a - 1) <= 0.015]
        pk = _dev(near_pk, a)
        if abs(dp) <= 0.5:
            code = "REPORTED"
        elif abs(dp) <= 1.5:
            code = f"OFF {dp:+.2f} % ({fp[np.argmin(np.abs(fp - a))]:.3f} Hz)"
        else:
            drops = [d for d in pm.dropped if abs(d.f_hz / a - 1) <= 0.01]
            if drops:
                d = min(drops, key=lambda d_: abs(d_.f_hz - a))
                code = f"DROPPED {d.f_hz:.3f} Hz ({d.reason[:70]})"
            else:
                k = sum(bool(np.any((np.abs(p.f_hz / a - 1) <= 0.01) & (p.zeta > 0)
                                    & (p.zeta < 0.2))) for p in pm.sweep.poles)
                code = f"NO COLUMN ({k} of {n_ord} orders)"
        pk_txt = f"{near_pk[np.argmin(np.abs(near_pk - a))]:.3f} ({pk:+.2f} %)" \
            if near_pk.size else "none"
        out.append(f"   {a:8.3f} {_dev(fd, a):+9.2f} {dp:+9.2f}  {pk_txt:>18}  {code}")
        rows_json[f"{a:.3f}"] = {"default_pct": round(_dev(fd, a), 2),
                                 "polymax_pct": round(dp, 2), "polymax": code.split(" (")[0],
                                 "half_spectra_peak_pct": round(pk, 2)}
    return out, {"agreed_hz": [round(float(a), 3) for a in agreed], "modes": rows_json}


def main() -> int:
    return run_traces(__doc__.splitlines()[0], _record)


if __name__ == "__main__":
    sys.exit(main())
