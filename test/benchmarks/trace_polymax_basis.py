"""Where output-only PolyMAX's pole bias comes from: half-spectra or sub-band fit (issue 22, 4).

Output-only PolyMAX (``identify --method polymax`` on outputs only) fits positive
half-spectra (``record.half_spectra``: n / 4 correlation lags, exponential window to 1 %,
its damping taken back out) per sub-band (``polymax_oma.polymax_banded``: since session 14
two octaves, each with a basis centring its fitted band on z = j; sessions 10-13 octaves,
each with its own basis). This trace runs ``identify_record`` with the half-spectra and
the sub-band fit varied one at a time:

- ``shipped``: as ``identify`` does (``ratio 4 basis middle``);
- ``octaves own basis``: sessions 10-13 (octaves, Nyquist at each fitted band's top);
- ``one band``: the whole band in one fit (its basis: Nyquist at the band's top);
- ``lags n/8``, ``lags n/2``: octaves, own basis, fewer / more correlation lags (the
  window to 1 % over them);
- ``basis x2``: octaves, each with a basis whose Nyquist is twice the fitted band's top;
- ``ratio 4``, ``ratio 4 basis x2``: sub-bands of two octaves, own basis / x2;
- ``centred``, ``centred basis x2``, ``centred basis middle``, ``centred ratio 4 basis
  x2``: the sub-bands and the half-overlapping bands between their middles, each pole from
  the fit in which it sits nearest the middle (``centred=True``);
- ``basis middle``, ``ratio 3.5 / 4 / 5 basis middle``: each fitted band :math:`[a, b]`
  on the arc symmetric about z = j (Nyquist at a + b, ``basis="middle"``).

Each on the known truth of ``bench_polymax_truth.py`` (a 5-DOF chain: 60 s of base shaking,
and 300 s under white forces; ``--seeds``, six by default; modes within 0.5 % of the
truth, spurious modes more than 2 % from every true mode, median identified / true
damping) and on the earthquake records as ``bench_real_modes.py`` (agreed modes of FDD and
a plain SSI-cov reported within 0.5 %, reported modes neither reference sees within 1 %).

usage: python test/benchmarks/trace_polymax_basis.py [--shared ../shared] [--seeds 6]
[--variants "shipped,centred"] [--truth-only | --real-only]
Last line: JSON, per variant the truth's and the real records' figures.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import contextlib
import json
import sys
import tempfile
import warnings
from collections.abc import Iterator
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_polymax_truth as truth
from _truth.modal_reference import agreed_modes, fdd_peaks, ssi_cov_columns
from bench_real_modes import earthquakes, imported
from trace_real_modes import RECORDS

OWN: dict[str, Any] = {"ratio": 2.0, "basis": None}  # sessions 10-13: octaves, own basis
VARIANTS: dict[str, dict[str, Any]] = {
    "shipped": {},
    "octaves own basis": OWN,
    "one band": {"ratio": 1e9, "basis": None},
    "lags n/8": {**OWN, "lag_div": 8},
    "lags n/2": {**OWN, "lag_div": 2},
    "basis x2": {"ratio": 2.0, "basis": 2.0},
    "ratio 4": {"ratio": 4.0, "basis": None},
    "ratio 4 basis x2": {"ratio": 4.0, "basis": 2.0},
    "centred": {**OWN, "centred": True},
    "centred basis x2": {"ratio": 2.0, "centred": True, "basis": 2.0},
    "basis middle": {"ratio": 2.0, "basis": "middle"},
    "centred basis middle": {"ratio": 2.0, "centred": True, "basis": "middle"},
    "centred ratio 4 basis x2": {"centred": True, "ratio": 4.0, "basis": 2.0},
    "ratio 3.5 basis middle": {"ratio": 3.5, "basis": "middle"},
    "ratio 4 basis middle": {"ratio": 4.0, "basis": "middle"},
    "ratio 5 basis middle": {"ratio": 5.0, "basis": "middle"},
}


@contextlib.contextmanager
def variant(ratio: float | None = None, basis: float | str | None = "default",
            lag_div: float | None = None, centred: bool | None = None) -> Iterator[None]:
    """``identify_record``'s half-spectra and sub-band fit with the given settings."""
    from modal_twin.identification import record as rec

    saved = rec.half_spectra, rec.polymax_banded
    if lag_div is not None:
        hs = saved[0]
        rec.half_spectra = lambda y, fs, _n: hs(y, fs, max(16, int(y.shape[1] / lag_div)))
    kw: dict[str, Any] = {} if ratio is None else {"ratio": ratio}
    if centred is not None:
        kw["centred"] = centred
    if basis != "default":
        kw["basis"] = basis
    rec.polymax_banded = partial(saved[1], **kw)
    try:
        yield
    finally:
        rec.half_spectra, rec.polymax_banded = saved


def _references(bags: list[tuple[str, Path]]) -> dict[str, dict[str, np.ndarray]]:
    """FDD peaks, plain SSI-cov columns and their agreed modes (as bench_real_modes)."""
    from modal_twin.acquisition.decimation import decimate
    from modal_twin.identification.record import IdentifyOptions, identify_record
    from modal_twin.io.imported import read_imported

    out = {}
    for tag, bag in bags:
        blk, ch = read_imported(bag)
        band = identify_record(blk, ch, IdentifyOptions()).settings.band_hz
        outs = tuple(c.name for c in ch if c.effective_role == "output")
        q = max(1, int(blk.fs_hz // (2.5 * band[1])))
        yq, fq = decimate(blk.select(outs).data, blk.fs_hz, q).x, blk.fs_hz / q
        ff = fdd_peaks(yq, fq, band)[0]
        rows = max(10, min(int(fq / (4 * band[0])), 1200 // len(outs)))
        fs = ssi_cov_columns(yq, fq, band, rows=rows, orders=range(10, 61, 2))
        out[tag] = {"fdd": ff, "ssi": fs, "agreed": agreed_modes(ff, fs)}
    return out


def _real(bags: list[tuple[str, Path]], refs: dict[str, dict[str, np.ndarray]]
          ) -> tuple[dict[str, Any], list[str]]:
    from modal_twin.identification.record import IdentifyOptions, identify_record
    from modal_twin.io.imported import read_imported

    hit = neither = 0
    lines = []
    for tag, bag in bags:
        f = identify_record(*read_imported(bag), IdentifyOptions(method="polymax")).modes.f_hz
        r = refs[tag]
        dev = [100 * (f[np.argmin(np.abs(f - a))] / a - 1) if f.size else np.nan
               for a in r["agreed"]]
        h = int(sum(abs(d) <= 0.5 for d in dev))
        n = int(sum(not (r["fdd"].size and np.min(np.abs(r["fdd"] / x - 1)) <= 0.01)
                and not (r["ssi"].size and np.min(np.abs(r["ssi"] / x - 1)) <= 0.01)
                for x in f))
        hit, neither = hit + h, neither + n
        lines.append(f"     {tag:22s} {h} of {len(r['agreed'])}, neither {n}; nearest mode "
                     "(%): " + " ".join(f"{a:.2f}:{d:+.2f}"
                                        for a, d in zip(r["agreed"], dev, strict=True)))
    n_agreed = sum(len(r["agreed"]) for r in refs.values())
    return {"agreed_within_0_5pct": hit, "of": n_agreed, "neither": neither}, lines


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=6)
    ap.add_argument("--variants", default=",".join(VARIANTS),
                    help="comma-separated names of VARIANTS")
    ap.add_argument("--truth-only", action="store_true")
    ap.add_argument("--real-only", action="store_true")
    a, rest = ap.parse_known_args()
    sys.argv[1:] = rest
    eq = None if a.truth_only else earthquakes(__doc__.splitlines()[0])
    warnings.simplefilter("ignore", RuntimeWarning)
    seeds = list(range(1, a.seeds + 1))
    summary: dict[str, Any] = {}
    with tempfile.TemporaryDirectory() as tmp:
        bags = list(imported(tmp, eq, RECORDS)) if eq is not None else []
        refs = _references(bags)
        for name in a.variants.split(","):
            kw = VARIANTS[name]
            with variant(**kw), contextlib.redirect_stdout(None):
                t = {} if a.real_only else {k: truth.run(k, seeds)
                                            for k in ("transient", "stationary")}
            print(f"\n== {name}")
            row: dict[str, Any] = {}
            for k, v in t.items():
                pm, sc = v["polymax"], v["ssi-cov"]
                print(f"   truth {k:10s}: PolyMAX {pm['found_of']} within 0.5 %, spurious "
                      f"{pm['spurious']}, damping x{pm['zeta_ratio_median']} "
                      f"(SSI-cov {sc['found_of']}, {sc['spurious']}, "
                      f"x{sc['zeta_ratio_median']})")
                row[k] = {key: pm[key] for key in ("found", "spurious", "zeta_ratio_median")}
            if bags:
                with variant(**kw):
                    real, lines = _real(bags, refs)
                print(f"   real records: {real['agreed_within_0_5pct']} of {real['of']} agreed "
                      f"within 0.5 %, {real['neither']} seen by neither reference")
                print("\n".join(lines), flush=True)
                row["real"] = real
            summary[name] = row
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
