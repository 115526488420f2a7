"""``modal-twin campaign BAG...``: identify every window of many bags; modes against time."""

from __future__ import annotations

import argparse
import csv
import json
import sys
from datetime import UTC, datetime
from pathlib import Path

from modal_twin.errors import OptionError
from modal_twin.exit_codes import ExitCode
from modal_twin.paths import atomic_file, check_new_in

__all__ = ["OUTPUTS", "register", "run"]

OUTPUTS = ("campaign.csv", "campaign.json", "campaign.png")
"""The files ``--out`` gets; an existing one is kept unless ``--force``."""

DEFAULT_WINDOW_S = 600.0
"""Window length without ``--window``; a record shorter than it is one window."""

HELP = "identify every window of many bags (or parts); modal frequencies and damping vs time"


def _floats(text: str, name: str, n: int) -> list[float]:
    try:
        vals = [float(v) for v in text.replace(":", ",").split(",")]
    except ValueError:
        vals = []
    if len(vals) != n:
        msg = f"{name}: expected {n} numbers separated by ',', got {text!r}"
        raise OptionError(msg)
    return vals


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``campaign`` parser."""
    p = sub.add_parser("campaign", help=HELP, description=HELP)
    p.add_argument("bags", type=Path, nargs="+", help="bags or folders of rotated parts")
    p.add_argument("--window", type=float, default=None,
                   help=f"window length, s (default {DEFAULT_WINDOW_S:g} s, or the whole "
                        "record where it is shorter)")
    p.add_argument("--topic", default="/measurement/frames")
    p.add_argument("--channels", default=None,
                   help="outputs, name,name,... (default: the channels of role output in "
                        "the bag's channel map; without a map all but --inputs)")
    p.add_argument("--inputs", default=None,
                   help="measured inputs, name,name,... (then N4SID; default SSI-cov)")
    p.add_argument("--orders", default=None,
                   help="model orders first:last:step (default: from each window, as "
                        "identify)")
    p.add_argument("--f-range", default=None,
                   help="analysis band, Hz: low,high (default: from each window, as identify)")
    p.add_argument("--executor", default=None,
                   help="dask://HOST:PORT for a cluster (default: local processes)")
    p.add_argument("--jobs", default=None, help="local processes (1 = serial; default auto)")
    p.add_argument("--out", type=Path, default=Path("campaign"), help="output folder")
    p.add_argument("--force", action="store_true", help="overwrite existing outputs")
    p.set_defaults(func=run)


def _outputs(a: argparse.Namespace, bag: Path, names: tuple[str, ...],
             inputs: tuple[str, ...]) -> tuple[str, ...]:
    """Return the outputs of ``bag``: ``--channels``, else its map's role ``output``."""
    from modal_twin.io.imported import bag_channel_map

    if a.channels:
        return tuple(a.channels.split(","))
    roles = {c.name: c.role for c in bag_channel_map(bag)}
    if not roles:  # no map: every channel but the named inputs
        return tuple(c for c in names if c not in inputs)
    outs = tuple(c for c in names if roles.get(c) == "output" and c not in inputs)
    left = [c for c in names if c not in outs and c not in inputs]
    print(f"campaign: {bag}: outputs {len(outs)} of {len(names)} channels, role 'output' "
          f"in its channel map" + (f" ({len(left)} others left out: "
                                   f"{', '.join(sorted({str(roles.get(c)) for c in left}))})"
                                   if left else ""), file=sys.stderr)
    return outs


def _windows(a: argparse.Namespace) -> tuple[list, tuple[str, ...]]:
    from modal_twin.identification.campaign import split_windows
    from modal_twin.io.bag import read_frames

    windows, outputs = [], None
    inputs = tuple(a.inputs.split(",")) if a.inputs else ()
    for bag in a.bags:
        frames = read_frames(bag, a.topic)
        if frames.skipped or frames.gaps:  # windows within each contiguous run
            print(f"campaign: {bag}: {frames.note()}; windows taken within each of the "
                  f"{len(frames.runs)} runs", file=sys.stderr)
        rec = frames.runs[0]
        names = _outputs(a, bag, rec.channel_names, inputs)
        if outputs is not None and names != outputs:
            msg = f"{bag}: expected the channels of {a.bags[0]} {list(outputs)}, got {list(names)}"
            raise OptionError(msg)
        outputs = names
        window_s = a.window
        if window_s is None:  # the default: 600 s, or the whole of a shorter record
            whole = frames.longest.n_samples / frames.longest.fs_hz
            window_s = min(DEFAULT_WINDOW_S, whole)
            if whole < DEFAULT_WINDOW_S:
                print(f"campaign: {bag}: one window of the whole record, {whole:.6g} s "
                      f"(shorter than the default {DEFAULT_WINDOW_S:g} s; --window to "
                      f"choose)", file=sys.stderr)
        runs = [r for r in frames.runs if r.n_samples >= window_s * r.fs_hz] or [
            frames.longest]  # none long enough: split_windows says so
        for run in runs:
            src = str(bag) if len(frames.runs) == 1 else f"{bag}[{run.first_index}:]"
            windows += split_windows(run, window_s, outputs=names, inputs=inputs, source=src)
    return windows, outputs or ()


def _write(result, out: Path, force: bool) -> list[Path]:
    """Write :data:`OUTPUTS` into ``out``, each to a temporary name and renamed."""
    from modal_twin.viz.campaign import plot_campaign

    to_csv, to_json, to_png = (out / n for n in OUTPUTS)
    rows = result.rows()
    from modal_twin.viz.campaign import REAL_TIME_S

    for r in rows:  # the date of a window with a real start (the records' headers)
        t = float(r["t_start_s"])
        r["t_start_utc"] = (datetime.fromtimestamp(t, tz=UTC).isoformat()
                            if t >= REAL_TIME_S else "")
    fields = ["source", "window", "t_start_s", "t_start_utc", "duration_s", "track", "f_hz",
              "zeta", "mac_to_track"]
    with atomic_file(to_csv, force=force) as tmp, tmp.open("w", newline="",
                                                             encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)
    doc = {"channels": list(result.channel_names), "n_windows": len(result.windows),
           "n_tracks": result.n_tracks, "modes": rows,
           "failed_windows": [{"source": x.source, "window": x.index, "error": x.error}
                              for x in result.windows if x.error]}
    with atomic_file(to_json, force=force) as tmp:
        tmp.write_text(json.dumps(doc, indent=1), encoding="utf-8")
    return [to_csv, to_json, plot_campaign(result, to_png, force=force)]


def run(a: argparse.Namespace) -> int:
    """Run the campaign and write campaign.csv / .json / .png into ``--out``."""
    from modal_twin.executors import make_executor
    from modal_twin.identification.campaign import WindowIdentifier, run_campaign
    from modal_twin.viz.campaign import REAL_TIME_S

    if a.executor and a.jobs:
        msg = "give --executor or --jobs, not both"
        raise OptionError(msg)
    check_new_in(a.out, OUTPUTS, a.force)  # before the work
    band = _floats(a.f_range, "--f-range", 2) if a.f_range else None
    orders = None
    if a.orders:
        first, last, step = (int(v) for v in _floats(a.orders, "--orders", 3))
        orders = tuple(range(first, last + 1, step))
    ident = WindowIdentifier(method="n4sid" if a.inputs else "ssi-cov", orders=orders,
                             f_range_hz=None if band is None else (band[0], band[1]))
    with make_executor(a.executor or a.jobs) as ex:  # a bad spec fails before the reading
        windows, outputs = _windows(a)
        res = run_campaign(windows, outputs, identifier=ident, executor=ex,
                           progress=lambda s: print(f"  {s}", file=sys.stderr))
    for path in _write(res, a.out, a.force):
        print(f"wrote {path}")
    n_failed = sum(1 for x in res.windows if x.error)
    print(f"{len(res.windows)} windows ({n_failed} failed), {res.n_tracks} mode tracks")
    for k in range(res.n_tracks):
        t, f, z = res.track_series(k)
        when = ""
        if t.size and float(t.min()) >= REAL_TIME_S:  # real start times from the headers
            d0, d1 = (datetime.fromtimestamp(float(v), tz=UTC).strftime(
                "%Y-%m-%d %H:%M") for v in (t.min(), t.max()))
            when = f", {d0} to {d1} UTC"
        print(f"  track {k}: {t.size} windows{when}, f {f.min():.4g}-{f.max():.4g} Hz, "
              f"zeta {100 * z.min():.2f}-{100 * z.max():.2f} %")
    return ExitCode.OK
