"""``modal-twin report FOLDER [--out FILE]``: one self-contained HTML report of a folder.

A run folder (sub-runs ``*/bag``, ``models/`` or the diagnosis's figures) gives the run
report below; any other
folder, an imported record or an ``identify --out`` folder, gives its modes,
stabilization, MAC, FRFs and test geometry where it has them
(:mod:`modal_twin.commands.report_record`). A folder with nothing to show is one line
naming what is missing and exit 2, never an empty page.

A run folder (what ``modal-twin demo`` writes) holds sub-runs ``<name>/bag`` (twin
metrics, channel map, measurement frames), model versions ``models/vNNNN.yaml`` and the
PNGs of the diagnosis. Each present kind of data gives its section
(:func:`modal_twin.viz.report.render_report`); the default output is
``RUN_DIR/report.html`` (an existing one is kept unless ``--force``). Only what the project
wrote is embedded: the figures by their known names (:data:`FIGURES`) as regular PNG files,
never a symbolic link or a FIFO; bags inside the run folder.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin.errors import ConfigError, ModalTwinError, OptionError
from modal_twin.exit_codes import ExitCode
from modal_twin.paths import check_new, open_regular
from modal_twin.progress import step, track
from modal_twin.validation import check_name

__all__ = ["FIGURES", "is_run_folder", "load_run", "make_report", "model_loops", "own_bags",
           "own_figures", "register", "run", "twin_metrics", "unsafe_entry"]

_DEVICE_SUFFIX = ("_dx", "_dy")


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``report`` parser."""
    p = sub.add_parser("report", help="one self-contained HTML report of a run folder")
    p.add_argument("run_dir", type=Path, help="run folder (e.g. runs/demo_...)")
    p.add_argument("--out", type=Path, default=None, help="HTML file (RUN_DIR/report.html)")
    p.add_argument("--n-modes", type=int, default=4, help="model modes in the 3D scene")
    p.add_argument("--force", action="store_true", help="overwrite an existing report")
    p.set_defaults(func=run)


def twin_metrics(bag: Path) -> tuple[Any, dict[str, tuple[str, str, str]]]:
    """Return the bag's last consistent /twin/metrics (None if none) and its channel meta."""
    from modal_twin.commands.residual import metrics_consistent
    from modal_twin.io.bag import bag_info, read_messages
    from modal_twin.io.convert import channel_map_from_msg

    last, meta = None, {}
    present = {t.name for t in bag_info(bag).topics}
    wanted: list[str] = [t for t in ("/twin/metrics", "/measurement/channels") if t in present]
    bad = 0
    for topic, _, msg in read_messages(bag, wanted) if wanted else ():
        if topic == "/twin/metrics":
            if metrics_consistent(msg):
                last = msg
            else:
                bad += 1
        else:
            try:
                meta = {c.name: (c.location, c.direction, c.quantity)
                        for c in channel_map_from_msg(msg)}
            except (ModalTwinError, ValueError, TypeError, AttributeError) as err:
                print(f"report: {bag}, /measurement/channels: skipped a channel map that "
                      f"does not convert ({type(err).__name__}: {err})"[:300], file=sys.stderr)
    if bad:
        print(f"report: {bag}, /twin/metrics: skipped {bad} message(s) with arrays of "
              "unequal length", file=sys.stderr)
    return last, meta


def _device_data(bag: Path, blamed: set[str], devices: Mapping[str, Any] | None = None
                 ) -> tuple[dict[str, Any], dict[str, Any], dict[str, Any]]:
    """Measured loops of every device, force-state samples of the blamed ones.

    And the loops of the model's ``devices`` (name -> Device) driven by the same drift.
    """
    from modal_twin.diagnosis.screening import drift_velocity
    from modal_twin.io.records import record_from_bag

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
    return loops, states, model_loops(rec, devices or {})


def model_loops(rec: Any, devices: Mapping[str, Any]) -> dict[str, Any]:
    """Each model device driven by its measured drift (and velocity): name -> (u, f)."""
    from modal_twin.diagnosis.screening import drift_velocity

    out = {}
    for dev, device in devices.items():
        cols = [f"{dev}_d{a}" for a in "xy"[: device.n_dir]]
        if not all(c in rec.channel_names for c in cols):
            continue
        U = rec.channels(cols)
        V = np.vstack([drift_velocity(x, rec.fs_hz, 25.0)[0] for x in U])
        F = device.respond(U, V, dt=1.0 / rec.fs_hz).f
        for i, a in enumerate("xy"[: device.n_dir]):
            out[f"{dev} {a}"] = (U[i], F[i])
    return out


def _model_devices(version: Any) -> dict[str, Any]:
    """Devices of a model version's plant by name (none for a model without devices)."""
    from modal_twin.models.loading import load_model

    if version is None or version.path is None:
        return {}
    try:
        system = load_model(version.path).plant().system
    except ModalTwinError as err:  # the report shows what it can: the measured loops
        print(f"report: no model loops ({err})", file=sys.stderr)
        return {}
    return {att.device.name: att.device for att in system.devices}


def _model_frf(structure: Path, names: list[str], f_hz: np.ndarray) -> np.ndarray:
    """Absolute-acceleration FRF of the linear model to table acceleration x.

    ``q'' + C q' + K q = -Gamma a_g``, ``y = C_acc [q; q'; q''] + D_acc a_g`` (Eq. (12) of
    [004] in modal form, :class:`~modal_twin.models.building.ModalBuilding`).
    """
    from modal_twin.models.building import build_building, modal_reduction

    red = modal_reduction(build_building(structure))
    rows = [red.channel_names.index(n) for n in names]
    r = red.n_modes
    H = np.empty((len(names), f_hz.size), complex)
    for k, w in enumerate(2 * np.pi * f_hz):
        Q = np.linalg.solve(-w * w * red.M + 1j * w * red.C + red.K, -red.Gamma[:, 0])
        z = np.concatenate([Q, 1j * w * Q, -w * w * Q])
        H[:, k] = red.C_acc[rows, : 3 * r] @ z + red.D_acc[rows, 0]
    return H


def _identification(bag: Path, structure: Path) -> dict[str, Any]:
    """Identify the modes of a (low-level) record by N4SID and pair them with the model's.

    Also the measured vs model FRF to table x (H1, Welch).
    """
    import scipy.signal as ss

    from modal_twin.identification.metrics import mac
    from modal_twin.identification.window import IdentificationConfig, identify_window
    from modal_twin.io.bag import read_frames
    from modal_twin.models.building import build_building, modal_reduction

    frames = read_frames(bag, "/measurement/frames")
    blk = frames.longest  # a damaged record: its longest contiguous run
    if frames.skipped or frames.gaps:
        print(f"report: {bag}: {frames.note(blk)}", file=sys.stderr)
    rec = identify_window(blk, IdentificationConfig(  # outputs: the channels of role output
        method="n4sid", fs_target_hz=100.0, max_order=40, f_max_hz=40.0))
    modes, diagram, outs = rec.modes, rec.diagram, rec.output_names
    bld = build_building(structure)
    red = modal_reduction(bld, 12)
    rows = [bld.channel_names.index(n) for n in outs]
    Phi_m = (bld.S @ red.Phi)[rows]
    M = mac(modes.shapes, Phi_m)
    best = np.argmax(M, axis=1) if M.size else np.zeros(0, int)
    out: dict[str, Any] = {
        "stabilization": diagram, "selected_f_hz": modes.f_hz,
        "modes": {"f_id_hz": modes.f_hz, "zeta_id": modes.zeta,
                  "f_model_hz": red.f_hz[best], "zeta_model": red.zeta[best],
                  "mac": M[np.arange(best.size), best]},
        "mac": (M, [f"id {k + 1}: {f:.2f} Hz" for k, f in enumerate(modes.f_hz)],
                [f"model {k + 1}: {f:.2f} Hz" for k, f in enumerate(red.f_hz)])}
    names = list(blk.channel_names)
    x = blk.data[names.index("table_ax")]
    fr = [n for n in outs if n.endswith("_x")]
    Y = blk.data[[names.index(n) for n in fr]]
    nper = int(blk.fs_hz * 20.0 / 8)
    f, Pxx = ss.welch(x, blk.fs_hz, nperseg=nper)
    _, Pxy = ss.csd(x[None, :], Y, blk.fs_hz, nperseg=nper)
    band = (f > 0.2) & (f < 20.0)
    out["frf"] = (f[band], (Pxy / Pxx)[:, band], fr, _model_frf(structure, fr, f[band]))
    return out


def load_run(run_dir: Path, *, n_modes: int = 4) -> Any:
    """Gather a run folder's data into a :class:`~modal_twin.viz.report.RunData`."""
    from modal_twin.models.versions import history
    from modal_twin.viz.report import RecordData, RunData

    versions = history(run_dir / "models") if (run_dir / "models").is_dir() else []
    blamed = {e.component: e.law for e in versions[-1].effects} if versions else {}
    records = []
    devices = _model_devices(versions[-1] if versions else None)
    notes = [f"run folder: {run_dir.resolve()}"]
    bags = own_bags(run_dir, notes)
    for bag in track(bags, "report: records", unit="bag"):
        m, meta = twin_metrics(bag)
        loops, states, model = (({}, {}, {}) if "replay" in bag.parent.name else
                                _device_data(bag, set(blamed), devices))
        records.append(RecordData(
            bag.parent.name,
            tuple(m.channel_names) if m is not None else (),
            np.asarray(m.rms_error, dtype=float) if m is not None else np.zeros(0),
            str(m.model_version) if m is not None else "", meta, loops, states, model))
    images = [(p.stem.replace("_", " "), data) for p, data in own_figures(run_dir, notes)]
    scene = None
    if versions:
        from modal_twin.commands.view import model_scene
        from modal_twin.viz.scene import static_html

        path = versions[-1].path
        if path is None:
            msg = f"{run_dir}: the last model version has no file"
            raise OptionError(msg)
        with step(f"report: 3D scene of {path.name}"):
            cmds, caption = model_scene(path, n_modes)
            scene = static_html(cmds, caption=caption)
    with step("report: the held-out record's 3D view"):
        record_scene = _record_scene(run_dir, versions, notes)
    ident: dict[str, Any] = {}
    low = [b for b in bags if "low" in b.parent.name]
    if low and versions:
        try:
            with step(f"report: identification of {low[0].parent.name} (N4SID)"):
                ident = _identification(low[0], versions[0].structure)
            notes.append(f"identification and FRF: N4SID on {low[0].parent.name} (table x "
                         "input for the FRF), paired with the nominal model by MAC")
        except ModalTwinError as err:
            notes.append(f"identification of {low[0].parent.name} failed: {err}")
    return RunData(f"modal_twin run {run_dir.name}", records, versions, scene, images=images,
                   notes=notes, record_scene_html=record_scene, **ident)


def _record_scene(run_dir: Path, versions: list[Any], notes: list[str]) -> str | None:
    """3D scene of the held-out record: measured beside the first and the last version."""
    from modal_twin.commands.view import bag_scene
    from modal_twin.viz.scene import static_html

    held = [b for b in own_bags(run_dir, []) if "heldout" in b.parent.name]
    if len(versions) < 2 or not held or versions[0].path is None or versions[-1].path is None:
        return None
    try:
        cmds, caption = bag_scene(versions[0].path, held[0], others=(versions[-1].path,),
                                  n_frames=48)
    except ModalTwinError as err:
        notes.append(f"the held-out record's 3D view failed: {err}")
        return None
    return static_html(cmds, caption=caption)


def is_run_folder(folder: Path) -> bool:
    """Return whether ``folder`` is a run folder (``*/bag``, ``models/`` or :data:`FIGURES`)."""
    return ((folder / "models").is_dir() or any(b.is_dir() for b in folder.glob("*/bag"))
            or any(folder.glob(FIGURES)))


def make_report(run_dir: str | Path, out: str | Path | None = None, *, n_modes: int = 4,
                force: bool = True) -> Path:
    """Write the report of ``run_dir`` (default ``run_dir/report.html``); return its path.

    Without ``force`` an existing file is refused before any work.

    Raises
    ------
    ConfigError
        Nothing to report: one line naming what is missing.
    """
    from modal_twin.viz.report import write_report

    rd = Path(run_dir)
    target = check_new(out or rd / "report.html", force)
    with step(f"report: {rd.name}"):  # said once the whole report runs over 2 s
        data = _folder_data(rd, n_modes)
        with step(f"report: writing {target.name}"):
            return write_report(data, target)


def _folder_data(rd: Path, n_modes: int) -> Any:
    """Return the report data of any folder kind (:func:`make_report`).

    Raises
    ------
    ConfigError
        Nothing to report: one line naming what is missing.
    """
    from modal_twin.commands.report_record import (
        is_launched_run,
        load_launched_run,
        load_record_folder,
    )
    from modal_twin.commands.report_vehicle import load_vehicle_run, vehicle_of_run

    if vehicle_of_run(rd) is not None:  # a launched run of a car (bag/, params/)
        data, missing = load_vehicle_run(rd)
        if data is None:
            raise ConfigError(missing)
    elif is_launched_run(rd) and not is_run_folder(rd):  # launch --run-dir of a structure
        data, missing = load_launched_run(rd)
        if data is None:
            raise ConfigError(missing)
    elif is_run_folder(rd):
        data = load_run(rd, n_modes=n_modes)
        if not (data.records or data.versions or data.images or data.stabilization):
            msg = (f"{rd}: nothing to report: its bags hold no metrics, record or device "
                   "data and it has no model versions or figures")
            raise ConfigError(msg)
    else:
        data, missing = load_record_folder(rd)
        if data is None:
            raise ConfigError(missing)
    return data


FIGURES = "force_state_*.png"
"""The figures of a run folder the report embeds: those the diagnosis writes
(:func:`modal_twin.viz.force_state.force_state_plots`), nothing else."""
FIGURE_MAX_BYTES = 32 * 2**20
_PNG = b"\x89PNG\r\n\x1a\n"


def own_figures(run_dir: Path, notes: list[str]) -> list[tuple[Path, bytes]]:
    """Return the project's figures in ``run_dir``: known names, regular PNGs, not links.

    Anything else under such a name (a symbolic link, a FIFO, a file that is not a PNG, a
    name that is not plain) is left out with a note; nothing is followed or waited on.
    """
    out = []
    for p in sorted(run_dir.glob(FIGURES)):
        try:
            check_name(p.name, "figure")
            with open_regular(p, "figure", follow=False) as fh:
                data = fh.read(FIGURE_MAX_BYTES + 1)
        except (ModalTwinError, OSError) as err:
            notes.append(f"left out {p.name}: not a figure of this run ({_reason(err)})")
            continue
        if len(data) > FIGURE_MAX_BYTES or not data.startswith(_PNG):
            notes.append(f"left out {p.name}: not a PNG figure of at most "
                         f"{FIGURE_MAX_BYTES >> 20} MiB")
            continue
        out.append((p, data))
    return out


def own_bags(run_dir: Path, notes: list[str]) -> list[Path]:
    """Return the bag folders ``run_dir/*/bag`` inside it that hold only regular files.

    A bag behind a symbolic link, or with a link, FIFO or device in it, is left out with a
    note (it would read outside the run folder or block the reader).
    """
    out = []
    for bag in sorted(run_dir.glob("*/bag")):
        if not bag.is_dir():
            continue
        bad = bag if bag.parent.is_symlink() else unsafe_entry(bag, run_dir)
        if bad is not None:
            notes.append(f"left out {bag.relative_to(run_dir)}: {bad.name} is a link, "
                         "FIFO or device, or lies outside the run folder")
            continue
        out.append(bag)
    return out


def unsafe_entry(bag: Path, root: Path) -> Path | None:
    """Return what makes ``bag`` unsafe to read, or None when it holds only regular files.

    The bag itself when it is a symbolic link or lies outside ``root``; else the first link,
    FIFO or device in it (each would read outside the run folder or block the reader).
    """
    if bag.is_symlink() or not bag.resolve().is_relative_to(root.resolve()):
        return bag
    return next((f for f in bag.rglob("*") if f.is_symlink() or not (f.is_file() or f.is_dir())),
                None)


def _reason(err: BaseException) -> str:
    text = str(err)
    return text.rpartition(": ")[2] if ": " in text else text


def run(args: argparse.Namespace) -> int:
    """Write the report and print its path."""
    if not args.run_dir.is_dir():
        print(f"modal-twin report: run folder {args.run_dir} not found", file=sys.stderr)
        return ExitCode.USAGE
    print(f"report: {make_report(args.run_dir, args.out, n_modes=args.n_modes, force=args.force)}")
    return ExitCode.OK
