"""Modes of the real records of ../shared/realdata against an FDD and a plain SSI-cov reference.

Each earthquake record is imported with ``modal-twin import`` (Hayward with and without the
shipped map) and identified by ``modal-twin identify`` as a user would (default method,
then ``--method n4sid | ssi-cov | polymax``). The references
(``_truth/modal_reference.py``, independent of the library; pyOMA2, see there)
run on the same output channels over the band ``identify`` chose: FDD peaks of the first
singular value of the output PSD matrix and the stable columns of a textbook SSI-cov. A
mode both references see within 1 % ("agreed") must be reported within 0.5 % of their mean
(issue 22, point 1); the table says which are and which are not.

usage: python test/benchmarks/bench_real_modes.py [--shared ../shared]
Last line: JSON with, per record, the agreed frequencies (Hz), the default method's
frequencies (Hz), the count of agreed modes it reports within 0.5 %, and that count for
each method (``within_0_5pct_by_method``), and per method the count of reported modes
neither reference sees within 1 % (``n_neither_reference_by_method``: "nothing they both
lack").
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import contextlib
import io
import json
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _truth.modal_reference import agreed_modes, fdd_peaks, ssi_cov_columns

ROOT = Path(__file__).resolve().parents[2]
RECORDS = [
    ("hayward 2021-04-26", "csmip58658_hayward_bridge_2021-04-26.zip", True),
    ("hayward 2021-04-26 no map", "csmip58658_hayward_bridge_2021-04-26.zip", False),
    ("hayward 2021-11-17", "csmip58658_hayward_bridge_2021-11-17.zip", True),
    ("berkeley 2018-01-04", "nsmp1103_berkeley_building_2018-01-04.zip", False),
    ("rio dell 2021-12-20", "csmip89324_riodell_overpass_2021-12-20.zip", False),
]


def _cli(*args: str) -> tuple[int, str]:
    from modal_twin.cli import main

    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
        code = main(list(args))
    return code, out.getvalue()


def _modes(folder: Path) -> np.ndarray:
    p = folder / "modes.json"
    return np.array([m["f_hz"] for m in json.loads(p.read_text())["modes"]]) if p.is_file() \
        else np.zeros(0)


def earthquakes(description: str) -> Path | None:
    """The earthquake folder under ``--shared``; None, said, when it is absent."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    eq: Path = ap.parse_args().shared / "realdata" / "earthquakes"
    if not eq.is_dir():
        print(f"{eq} is absent; nothing to compare")
        return None
    return eq


def imported(tmp: str, eq: Path, records: list[tuple[str, str, bool]] = RECORDS
             ) -> Iterator[tuple[str, Path]]:
    """Import each record as a user would (Hayward with the shipped map where asked)."""
    for tag, zname, with_map in records:
        bag = Path(tmp) / tag.replace(" ", "_")
        extra = ["--map", str(ROOT / "config" / "channel_maps" / "csmip58658_hayward.yaml")
                 ] if with_map else []
        _cli("import", str(eq / zname), "--out", str(bag), *extra)
        yield tag, bag


def main() -> int:
    from modal_twin.acquisition.decimation import decimate
    from modal_twin.io.imported import read_imported

    eq = earthquakes(__doc__.splitlines()[0])
    if eq is None:
        return 0
    summary = {}
    with tempfile.TemporaryDirectory() as tmp:
        for tag, bag in imported(tmp, eq):
            found = {}
            for m in ("default", "n4sid", "ssi-cov", "polymax"):
                out = Path(tmp) / f"{bag.name}_{m}"
                _cli("identify", str(bag), "--out", str(out),
                     *([] if m == "default" else ["--method", m]))
                found[m] = _modes(out)
                if m == "default":
                    doc = json.loads((out / "modes.json").read_text()) if (
                        out / "modes.json").is_file() else {}
                    band = tuple(doc.get("settings", {}).get("band_hz", (0.3, 20.0)))
                    chosen = doc.get("method", "?")
                    dropped = doc.get("not_reported", [])
            blk, ch = read_imported(bag)
            outs = tuple(c.name for c in ch if c.effective_role == "output")
            y = blk.select(outs).data
            q = max(1, int(blk.fs_hz // (2.5 * band[1])))
            yq, fq = decimate(y, blk.fs_hz, q).x, blk.fs_hz / q
            f_fdd = fdd_peaks(yq, fq, band)[0]
            rows = max(10, min(int(fq / (4 * band[0])), 1200 // len(outs)))
            f_ssi = ssi_cov_columns(yq, fq, band, rows=rows, orders=range(10, 61, 2))
            agreed = agreed_modes(f_fdd, f_ssi)
            print(f"\n== {tag}: band {band[0]:.3g}-{band[1]:.3g} Hz, {len(outs)} outputs, "
                  f"default method {chosen}")
            print(f"   FDD peaks: {np.round(f_fdd, 3).tolist()}")
            print(f"   plain SSI-cov columns: {np.round(f_ssi, 3).tolist()}")
            for m, f in found.items():
                print(f"   identify {m}: {np.round(f, 3).tolist()}")
            print(f"   not reported by the default run: "
                  f"{[round(d['f_hz'], 3) for d in dropped]}")
            print(f"   {'agreed [Hz]':>12} {'default':>9} {'dev %':>6} {'ssi-cov':>9} "
                  f"{'polymax':>9}")
            hit = 0
            by_method = {m: int(sum(f.size > 0 and np.min(np.abs(f / fa - 1)) <= 0.005
                                    for fa in agreed)) for m, f in found.items()}
            # reported modes that neither reference sees within 1 % ("nothing they both lack")
            lacked = {m: [round(float(x), 3) for x in f
                          if not (f_fdd.size and np.min(np.abs(f_fdd / x - 1)) <= 0.01)
                          and not (f_ssi.size and np.min(np.abs(f_ssi / x - 1)) <= 0.01)]
                      for m, f in found.items()}
            for fa in agreed:
                cells = []
                for m in ("default", "ssi-cov", "polymax"):
                    f = found[m]
                    k = int(np.argmin(np.abs(f - fa))) if f.size else -1
                    cells.append((f[k], 100 * (f[k] / fa - 1)) if k >= 0 else (np.nan, np.nan))
                hit += int(abs(cells[0][1]) <= 0.5)
                print(f"   {fa:12.3f} {cells[0][0]:9.3f} {cells[0][1]:6.2f} {cells[1][0]:9.3f} "
                      f"{cells[2][0]:9.3f}")
            print(f"   agreed modes reported within 0.5 % by the default run: {hit} of "
                  f"{agreed.size}; by method: {by_method}")
            print(f"   reported, seen by neither reference within 1 %: "
                  f"{ {m: len(v) for m, v in lacked.items()} } (default: {lacked['default']})")
            summary[tag] = {"agreed_hz": np.round(agreed, 3).tolist(),
                            "default_hz": np.round(found["default"], 3).tolist(),
                            "default_method": chosen, "agreed_within_0_5pct": hit,
                            "within_0_5pct_by_method": by_method,
                            "n_reported_by_method": {m: int(f.size) for m, f in found.items()},
                            "n_neither_reference_by_method": {m: len(v)
                                                              for m, v in lacked.items()}}
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
