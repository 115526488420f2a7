"""``modal-twin report RUN_DIR [--out FILE]``: one self-contained HTML report of a run.

A run folder (what ``modal-twin demo`` writes) holds sub-runs ``<name>/bag`` (twin
metrics, channel map, measurement frames), model versions ``models/vNNNN.yaml`` and the
PNGs of the diagnosis. Each present kind of data gives its section
(:func:`modal_twin.viz.report.render_report`); the default output is
``RUN_DIR/report.html``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin.exit_codes import ExitCode
from modal_twin.progress import track

__all__ = ["load_run", "make_report", "register", "run"]

_DEVICE_SUFFIX = ("_dx", "_dy")


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Add the ``report`` parser."""
    p = sub.add_parser("report", help="one self-contained HTML report of a run folder")
    p.add_argument("run_dir", type=Path, help="run folder (e.g. runs/demo_...)")
    p.add_argument("--out", type=Path, default=None, help="HTML file (RUN_DIR/report.html)")
    p.add_argument("--n-modes", type=int, default=4, help="model modes in the 3D scene")
    p.set_defaults(func=run)


def _metrics(bag: Path) -> tuple[Any, dict[str, tuple[str, str, str]]]:
    from modal_twin.io.bag import read_messages
    from modal_twin.io.convert import channel_map_from_msg

    last, meta = None, {}
    for topic, _, msg in read_messages(bag, ["/twin/metrics", "/measurement/channels"]):
        if topic == "/twin/metrics":
            last = msg
        else:
            meta = {c.name: (c.location, c.direction, c.quantity)
                    for c in channel_map_from_msg(msg)}
    return last, meta


def _device_data(bag: Path, blamed: set[str]) -> tuple[dict[str, Any], dict[str, Any]]:
    """Measured loops of every device, force-state samples of the blamed ones."""
    from modal_twin.diagnosis.screening import drift_velocity
    from modal_twin.diagnosis.workflow import record_from_bag

    rec = record_from_bag(bag)
    names = list(rec.channel_names)
    loops, states = {}, {}
    for ch in names:
        if not ch.endswith(_DEVICE_SUFFIX):
            continue
        dev, d = ch[:-3], ch[-1]
        f_name = f"{dev}_f{d}"
        if f_name not in names:
            continue
        u, f = rec.data[names.index(ch)], rec.data[names.index(f_name)]
        loops[f"{dev} {d}"] = (u, f)
        if dev in blamed:
            states[f"{dev} {d}"] = (u, drift_velocity(u, rec.fs_hz, 25.0)[0], f)
    return loops, states


def load_run(run_dir: Path, *, n_modes: int = 4) -> Any:
    """Gather a run folder's data into a :class:`~modal_twin.viz.report.RunData`."""
    from modal_twin.models.versions import history
    from modal_twin.viz.report import RecordData, RunData

    versions = history(run_dir / "models") if (run_dir / "models").is_dir() else []
    blamed = {e.component: e.law for e in versions[-1].effects} if versions else {}
    records = []
    bags = sorted(p for p in run_dir.glob("*/bag") if p.is_dir())
    for bag in track(bags, "report: records", unit="bag"):
        m, meta = _metrics(bag)
        loops, states = ({}, {}) if "replay" in bag.parent.name else _device_data(bag,
                                                                                set(blamed))
        records.append(RecordData(
            bag.parent.name,
            tuple(m.channel_names) if m is not None else (),
            np.asarray(m.rms_error, dtype=float) if m is not None else np.zeros(0),
            str(m.model_version) if m is not None else "", meta, loops, states))
    images = [(p.stem.replace("_", " "), p.read_bytes())
              for p in sorted(run_dir.glob("*.png")) if p.name != "error_history.png"]
    scene = None
    if versions:
        from modal_twin.commands.view import model_scene
        from modal_twin.viz.scene import static_html

        cmds, caption = model_scene(versions[-1].path, n_modes)
        scene = static_html(cmds, caption=caption)
    return RunData(f"modal_twin run {run_dir.name}", records, versions, scene, images=images,
                   notes=[f"run folder: {run_dir.resolve()}"])


def make_report(run_dir: str | Path, out: str | Path | None = None, *, n_modes: int = 4
                ) -> Path:
    """Write the report of ``run_dir`` (default ``run_dir/report.html``); return its path."""
    from modal_twin.viz.report import write_report

    rd = Path(run_dir)
    return write_report(load_run(rd, n_modes=n_modes), out or rd / "report.html")


def run(args: argparse.Namespace) -> int:
    """Write the report and print its path."""
    if not args.run_dir.is_dir():
        print(f"modal-twin report: run folder {args.run_dir} not found", file=sys.stderr)
        return ExitCode.USAGE
    print(f"report: {make_report(args.run_dir, args.out, n_modes=args.n_modes)}")
    return ExitCode.OK
