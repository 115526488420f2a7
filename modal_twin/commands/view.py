"""``modal-twin view MODEL [--modes FILE | --bag BAG] [--html OUT]``: the 3D scene of a model.

With ``--modes`` (the JSON ``modal-twin identify`` writes) every identified mode is drawn
on the structure (expanded from its channels with the model's modes, SEREP) in blue,
beside the model mode it pairs with by MAC in orange; the caption gives f, zeta and MAC.

With ``--bag`` (a recorded or imported bag) the record's strongest stretch is drawn on the
structure twice: measured (blue) and the twin's prediction for the same measured inputs
(orange; the model file's effects included), both expanded from the sensors with the
model's modes and scaled alike, the sensors coloured by the twin's NRMSE there (green
below 10 %, yellow, red from 30 %).

MODEL may be a vehicle file: the car seen from the side (carbody, bogies, wheelsets,
suspensions, equipment) with its coupled modes (:mod:`modal_twin.viz.vehicle_scene`); with
``--bag`` its floor sensors' motion is expanded with as many coupled modes as sensors.
A 3D vehicle file (``kind: vehicle3d``) is drawn with the shell carbody's mesh, bogies and
wheelsets (:mod:`modal_twin.viz.vehicle3d_scene`), animating its carbody modes at the
file's speed: the lowest ``--n-modes``, or those named by ``--carbody-mode`` (e.g.
``"vertical bending 1"``; ``--carbody-params`` applies an updating's zone factors); with
``--bag`` the shell car's deflection on the record's track (:func:`vehicle3d_bag_scene`).
Its ``--html`` page moves each copy's line set by its own script (drawn once).

MODEL may also be a test geometry: a UFF file with nodes and trace lines, or a bag
``modal-twin import`` wrote with one (its channels' nodes are the sensors); ``--modes`` (the
identify JSON of that bag) then draws each identified mode at the nodes and directions its
channels measure.

With ``--html`` the scene (structure, sensors, devices, animated model modes, the places a
model version added effects at in red) is written as one static HTML page and no server
is started. Without it, meshcat's server is started on 127.0.0.1 (stopped by PID on
exit, Ctrl-C ends the view) and its address printed.
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
from pathlib import Path
from typing import Any

from modal_twin.exit_codes import ExitCode
from modal_twin.paths import atomic_file, check_new

__all__ = ["register", "run"]


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``view`` parser."""
    p = sub.add_parser("view", help="3D scene of a model: structure, sensors, devices, modes")
    p.add_argument("model", type=Path,
                   help="structure file, model version file, or a test geometry: a UFF file "
                        "(15 / 82 / 2411) or a bag imported with one")
    p.add_argument("--n-modes", type=int, default=6, help="model modes to animate")
    p.add_argument("--modes", type=Path, default=None,
                   help="identified modes (identify JSON): drawn beside their model pairs")
    p.add_argument("--bag", type=Path, default=None,
                   help="recorded or imported bag: its motion, measured beside the twin")
    p.add_argument("--window", type=float, default=0.0,
                   help="--bag: seconds shown (default three periods of the first mode)")
    p.add_argument("--carbody-mode", action="append", default=None, metavar="LABEL",
                   help="3D vehicle: a carbody mode to animate by name (repeatable), e.g. "
                        "'vertical bending 1', 'diamond 1', 'bounce'")
    p.add_argument("--carbody-params", type=Path, default=None, metavar="FILE",
                   help="3D vehicle: zone factors of the shell carbody (carbody updating)")
    p.add_argument("--html", type=Path, default=None,
                   help="write a static HTML page instead of starting a server")
    p.add_argument("--force", action="store_true", help="--html: overwrite an existing file")
    p.add_argument("--web-port", type=int, default=7000)
    p.add_argument("--zmq-port", type=int, default=6000)
    p.set_defaults(func=run)


def model_scene(model: Path, n_modes: int) -> tuple[list[object], str]:
    """meshcat commands and caption of a structure or model version file."""
    from modal_twin.models.versions import read_version
    from modal_twin.viz.scene import (
        building_geometry,
        building_modes,
        overlay_html,
        scene_commands,
    )

    mv = read_version(model)
    blamed = {e.component: e.law for e in mv.effects}
    if _is_vehicle(mv.structure):
        vm, vs = _vehicle(mv)
        geom, modes = vs.geom, (vs.modes(vm, n_modes) if n_modes > 0 else None)
    else:
        geom = building_geometry(mv.structure)
        modes = building_modes(mv.structure, n_modes) if n_modes > 0 else None
    return (scene_commands(geom, modes, blamed=blamed),
            overlay_html(geom, modes, blamed))


def vehicle3d_scene_commands(args: argparse.Namespace) -> tuple[list[object], str]:
    """meshcat commands and caption of a 3D vehicle file with the shell carbody.

    Its carbody modes, or with ``--bag`` the car's deflection over the record's strongest
    stretch (:func:`vehicle3d_bag_scene`). With ``--html`` the moving copies are line sets
    moved by the page's script (:class:`~modal_twin.viz.scene.VertexAnimation`).
    """
    from modal_twin.commands.ride import with_carbody_options
    from modal_twin.errors import ConfigError
    from modal_twin.models.vehicle3d import build_vehicle3d
    from modal_twin.models.vehicle3d_spec import load_vehicle3d
    from modal_twin.viz.scene import overlay_html, scene_commands
    from modal_twin.viz.vehicle3d_scene import vehicle3d_scene

    if args.modes is not None:
        msg = (f"{args.model}: a 3D vehicle shows its carbody modes (--carbody-mode) or a "
               "record's deflection (--bag); --modes is for a building or a test geometry")
        raise ConfigError(msg)
    spec = load_vehicle3d(args.model).with_carbody("shell")
    spec = with_carbody_options(spec, args)
    veh = build_vehicle3d(spec)
    vs = vehicle3d_scene(veh)
    vertex = args.html is not None
    if args.bag is not None:
        return vehicle3d_bag_scene(args.model, args.bag, veh, vs, window_s=args.window,
                                   vertex_frames=vertex)
    modes = vs.modes(veh, spec.speed, labels=args.carbody_mode, n_modes=args.n_modes)
    return (scene_commands(vs.geom, modes, vertex_frames=vertex),
            overlay_html(vs.geom, modes))


def vehicle3d_bag_scene(model: Path, bag: Path, veh: Any, vs: Any, *, window_s: float = 0.0,
                        n_frames: int = 96, vertex_frames: bool = False
                        ) -> tuple[list[object], str]:
    """meshcat commands and caption of the shell car's deflection on a record's track.

    The record's track inputs (by role, as ``residual``) drive the car ``veh`` (the file's
    with the shell carbody) from rest; its strongest ``window_s`` (default three periods
    of the lowest carbody mode) is drawn in real time on every node; the floor sensors
    are coloured by the model's NRMSE of the recorded floor accelerations.

    Raises
    ------
    ModalTwinError
        A bag that does not read or has none of the car's track inputs.
    """
    import html

    import numpy as np

    from modal_twin.io.records import record_from_bag
    from modal_twin.models.loading import load_model
    from modal_twin.models.vehicle3d_ride import carbody_modes
    from modal_twin.viz.live import residual_colour
    from modal_twin.viz.motion import nrmse_per_sensor
    from modal_twin.viz.scene import SceneMotion, caption_html, scene_commands
    from modal_twin.viz.vehicle3d_scene import record_deflection

    plant = load_model(model).plant()  # the file's car: the record's channels by role
    rec = record_from_bag(bag, plant=plant)
    w = plant.input_matrix(rec.input_names, rec.inputs)
    f1 = min((m.f_hz for m in carbody_modes(veh, veh.spec.speed)), default=1.0)
    span = window_s if window_s > 0 else 3.0 / f1
    d = record_deflection(vs, veh, w, rec.fs_hz, window_s=span, n_frames=n_frames)
    floor = [c for c in d.floor_names if c in rec.channel_names]
    rows = [d.floor_names.index(c) for c in floor]
    worst = nrmse_per_sensor([c.removeprefix("floor_") for c in floor],
                             rec.channels(floor) if floor else np.zeros((0, 1)),
                             d.floor[rows] if floor else np.zeros((0, 1)))
    colours = {s: residual_colour(r) for s, r in worst.items()}
    motion = SceneMotion(d.frames[None], 1.0 / d.dt_s, (0xE4572E,), colours)
    t1 = d.t0_s + d.dt_s * d.frames.shape[0]
    peak = float(np.abs(d.frames).max())
    label = bag.parent.name if bag.name == "bag" else bag.name
    items = [f"<b>{html.escape(label)}</b> on {html.escape(veh.spec.name)} (shell carbody): "
             f"the car's deflection on the record's track, {d.t0_s:.2f}-{t1:.2f} s in real "
             f"time ({d.frames.shape[0]} frames), largest node motion {1e3 * peak:.2f} mm "
             "(drawn enlarged)",
             "floor sensors coloured by the model's NRMSE of the recorded floor "
             "accelerations: " + (", ".join(f"{html.escape(s)} {100 * v:.1f} %"
                                           for s, v in worst.items()) or "none recorded")]
    cmds = scene_commands(vs.geom, motion=motion, vertex_frames=vertex_frames,
                          motion_times=(d.t0_s, d.dt_s))
    return cmds, caption_html(items)


def _is_vehicle3d(path: Path) -> bool:
    from modal_twin.models.vehicle3d_spec import is_vehicle3d_file

    return path.is_file() and path.suffix.lower() in (".yaml", ".yml") and \
        is_vehicle3d_file(path)


def _vehicle(mv: Any) -> tuple[Any, Any]:
    """Return the coupled vehicle model of a version and its side-view scene."""
    from modal_twin.models.vehicle import assemble_vehicle
    from modal_twin.models.vehicle_spec import load_vehicle
    from modal_twin.viz.vehicle_scene import vehicle_scene

    vm = assemble_vehicle(load_vehicle(mv.structure), theta=mv.theta or None)
    return vm, vehicle_scene(vm)


def _structure(model: Path, n_basis: int) -> tuple[Any, Any, Any]:
    """Model version, wireframe and lowest ``n_basis`` modes (on every node) of a file."""
    from modal_twin.models.versions import read_version
    from modal_twin.viz.scene import building_geometry, building_modes

    mv = read_version(model)
    return mv, building_geometry(mv.structure), building_modes(mv.structure, n_basis)


def identified_scene(model: Path, modes_file: Path, n_basis: int = 12
                     ) -> tuple[list[object], str]:
    """meshcat commands and caption of identified modes beside their model pairs.

    Raises
    ------
    ModalTwinError
        A modes file whose shapes do not name their channels, or channels that are not
        sensors of the structure.
    """
    import numpy as np

    from modal_twin.errors import ConfigError
    from modal_twin.io.modes_file import read_modes
    from modal_twin.viz.mode_pairs import (
        channel_nodes,
        expand_shapes,
        pair_by_mac,
        real_shapes,
        sampled_shapes,
    )
    from modal_twin.viz.scene import (
        SceneModes,
        overlay_html,
        scene_commands,
    )

    _, geom, basis = _structure(model, n_basis)
    mf = read_modes(modes_file)
    channels = [str(d.get("channel", "")) for d in mf.dofs]
    if len(channels) != mf.shapes.shape[0] or not all(channels):
        msg = f"{modes_file}: the shapes do not name their channels (use the identify JSON)"
        raise ConfigError(msg)
    at_ch = sampled_shapes(basis.shapes, channel_nodes(channels, geom.node_xyz, geom.sensors,
                                                       mf.dofs))
    ident = real_shapes(mf.shapes)
    expanded = expand_shapes(ident, at_ch, basis.shapes)
    shapes, f, z, labels, colors = [], [], [], [], []
    for i, j, m in pair_by_mac(mf.shapes, at_ch):
        shapes += [expanded[i], basis.shapes[j]]
        f += [mf.f_hz[i], basis.f_hz[j]]
        z += [mf.zeta[i], basis.zeta[j]]
        labels += [f"identified {i + 1}: {mf.f_hz[i]:.3f} Hz, zeta {100 * mf.zeta[i]:.2f} % "
                   f"(blue) | model {j + 1}: {basis.f_hz[j]:.3f} Hz, MAC {m:.3f} (orange)"]
        colors += [0x1F77B4, 0xE4572E]
    modes = SceneModes(np.asarray(f), np.asarray(z), np.asarray(shapes), "identified",
                       (), tuple(colors))
    caption_modes = SceneModes(np.asarray(mf.f_hz), np.asarray(mf.zeta), expanded,
                               "identified", tuple(labels))
    return scene_commands(geom, modes), overlay_html(geom, caption_modes)


_TWIN_COLOURS = (0xE4572E, 0x2CA02C, 0x9467BD, 0x8C564B)
_COLOUR_NAMES = ("orange", "green", "purple", "brown")


def bag_scene(model: Path, bag: Path, window_s: float = 0.0, n_basis: int = 12, *,
              others: tuple[Path, ...] = (), n_frames: int = 96
              ) -> tuple[list[object], str]:
    """meshcat commands and caption of a record's motion, measured beside the twin.

    ``others``: further model versions of the same structure, each drawn as its own twin
    (e.g. the nominal model and the version with the effect found); the sensors are
    coloured by the last one.

    Raises
    ------
    ModalTwinError
        A bag the model shares no acceleration sensor with, or that does not read.
    """
    import html

    import numpy as np

    from modal_twin.diagnosis.fitting import simulate_record
    from modal_twin.errors import ConfigError
    from modal_twin.io.records import record_from_bag
    from modal_twin.models.loading import load_model
    from modal_twin.models.versions import read_version
    from modal_twin.viz.live import residual_colour
    from modal_twin.viz.motion import displacement_from_acceleration, record_motion
    from modal_twin.viz.scene import SceneMotion, caption_html, scene_commands

    mv = read_version(model)
    plant = load_model(model).plant()
    rec = record_from_bag(bag, plant=plant)
    quantity = {c.name: c.quantity for c in plant.channels}
    acc = [c for c in rec.channel_names if quantity.get(c) == "acceleration"]
    geom, chs, at_ch, shapes, f1 = (_vehicle_basis if _is_vehicle(mv.structure)
                                    else _building_basis)(mv, acc, n_basis)
    if not chs:
        msg = f"{bag}: no acceleration channel at a sensor of {mv.structure.name}"
        raise ConfigError(msg)
    n_basis = shapes.shape[0]
    rec = rec.with_channels(chs)
    f_low = 0.5 * f1
    meas = displacement_from_acceleration(rec.data, rec.fs_hz, f_low)
    span = window_s if window_s > 0 else 3.0 / f1
    models = (model, *others)[: len(_TWIN_COLOURS)]
    runs = []
    for m in models:
        sim = simulate_record(load_model(m).plant() if m != model else plant, rec)
        runs.append(record_motion(
            chs, meas, displacement_from_acceleration(sim, rec.fs_hz, f_low), rec.fs_hz,
            at_ch, shapes, window_s=span, n_frames=n_frames, scored=(rec.data, sim)))
    mo = runs[-1]
    colours = {s: residual_colour(r) for s, r in mo.sensor_nrmse.items()}
    motion = SceneMotion(np.stack([mo.measured, *(r.twin for r in runs)]), 1.0 / mo.dt_s,
                         (0x1F77B4, *_TWIN_COLOURS), colours)
    t1 = mo.t0_s + mo.dt_s * mo.measured.shape[0]
    label = bag.parent.name if bag.name == "bag" else bag.name
    items = [f"<b>{html.escape(label)}</b>: measured (blue), then the twin of each "
             f"model (copies right to left, row by row), {mo.t0_s:.1f}-{t1:.1f} s in real time",
             f"displacements from {len(chs)} accelerations above {f_low:.2f} Hz, expanded "
             f"with {n_basis} model modes (fit {100 * mo.fit:.1f} %)"]
    for m, r, name in zip(models, runs, _COLOUR_NAMES, strict=False):
        worst = sorted(r.sensor_nrmse.items(), key=lambda kv: -kv[1])[:3]
        version = (mv if m == model else read_version(m)).label
        items.append(f"{name}: {html.escape(version)}, worst: " + ", ".join(
            f"{html.escape(s)} {100 * v:.1f} %" for s, v in worst))
    items.append(f"sensors coloured by the {_COLOUR_NAMES[len(runs) - 1]} twin's NRMSE of the "
                 "measured accelerations there: green &lt; 10 %, yellow, red &ge; 30 %")
    return scene_commands(geom, motion=motion), caption_html(items)


def _building_basis(mv: Any, acc: list[str], n_basis: int
                    ) -> tuple[Any, list[str], Any, Any, float]:
    """Return the wireframe, sensor channels, modes at them and on every node, and f_1."""
    from modal_twin.viz.mode_pairs import channel_nodes, sampled_shapes
    from modal_twin.viz.scene import building_geometry, building_modes

    geom, basis = building_geometry(mv.structure), building_modes(mv.structure, n_basis)
    chs = [c for c in acc if c.rpartition("_")[0] in geom.sensors
           and c.rpartition("_")[2] in ("x", "y", "z")]
    at_ch = sampled_shapes(basis.shapes, channel_nodes(chs, geom.node_xyz, geom.sensors))
    return geom, chs, at_ch, basis.shapes, float(basis.f_hz[0])


def _vehicle_basis(mv: Any, acc: list[str], n_basis: int
                   ) -> tuple[Any, list[str], Any, Any, float]:
    """Return the same for a vehicle: its floor sensors, as many coupled modes as sensors."""
    vm, vs = _vehicle(mv)
    rows = {c.name: i for i, c in enumerate(vm.channels)}
    chs = [c for c in acc if c in rows]
    k = max(1, min(n_basis, len(chs)))
    at_ch = vm.S[[rows[c] for c in chs]] @ vm.Phi[:, :k]
    return vs.geom, chs, at_ch, vs.modes(vm, k).shapes, float(vm.f_hz[0])


def geometry_scene(path: Path, modes_file: Path | None) -> tuple[list[object], str]:
    """meshcat commands and caption of a test geometry (and identified modes on it)."""
    import html

    from modal_twin.io.modes_file import read_modes
    from modal_twin.viz.measured_geometry import modes_on_nodes
    from modal_twin.viz.scene import caption_html, overlay_html, scene_commands

    mg = load_measured_geometry(path)
    if modes_file is None:
        g = mg.geom
        return scene_commands(g), caption_html([
            f"<b>{html.escape(path.name)}</b>: test geometry, {len(mg.ids)} nodes, "
            f"{g.edges.shape[0]} trace-line segments, {len(g.sensors)} nodes with channels "
            "(blue)"])
    mf = read_modes(modes_file)
    modes = modes_on_nodes(mg, mf.f_hz, mf.zeta, mf.shapes, mf.dofs)
    return scene_commands(mg.geom, modes), overlay_html(mg.geom, modes)


def load_measured_geometry(path: Path) -> Any:
    """Return the test geometry of a UFF file, or of a bag ``modal-twin import`` wrote with one.

    (A :class:`~modal_twin.viz.measured_geometry.MeasuredGeometry`.)

    Raises
    ------
    ConfigError
        No geometry in the file or folder.
    """
    import json

    from modal_twin.errors import ConfigError
    from modal_twin.io.channel_map import MAP_FILE, read_channel_map
    from modal_twin.viz.measured_geometry import MeasuredGeometry, geometry_from_uff
    from modal_twin.yaml_files import read_text

    chans: dict[str, tuple[str, str]] = {}
    if path.is_dir():
        parts = sorted(path.glob("geometry_*.json"))
        if not parts:
            msg = f"{path}: no test geometry (import a UFF 15 / 82 file with the record)"
            raise ConfigError(msg)
        g: dict[str, Any] = {"nodes": {}, "trace_lines": []}
        for p in parts:
            d = json.loads(read_text(p, "geometry file"))
            g["nodes"].update(d.get("nodes", {}))
            g["trace_lines"] += d.get("trace_lines", [])
        if (path / MAP_FILE).is_file():
            chans = {c.name: (c.node, c.direction.lower()) for c in
                     read_channel_map(path / MAP_FILE) if c.node}
    else:
        from modal_twin.io.uff import read_uff

        g = read_uff(path).geometry
    geom, ids = geometry_from_uff(g, path.name, [n for n, _ in chans.values()])
    return MeasuredGeometry(geom, ids, chans)


def _is_vehicle(path: Path) -> bool:
    from modal_twin.models.vehicle_spec import is_vehicle_file

    return is_vehicle_file(path)


def _is_geometry(path: Path) -> bool:
    return path.is_dir() or path.suffix.lower() in (".uff", ".unv")


def _check_drawable(model: Path) -> None:
    """Refuse a matrix model (or a version of one): it carries no geometry to draw."""
    from modal_twin.errors import ConfigError
    from modal_twin.models.frame_file import is_frame_file
    from modal_twin.models.matrix_model import MATRIX_SUFFIXES
    from modal_twin.models.versions import read_version

    if _is_geometry(model):
        return
    if is_frame_file(model):
        msg = (f"{model}: a frame file (kind: frame) is a matrix model built from its spec, "
               "with no drawing yet; view takes a structure or vehicle YAML, a model version "
               "of one, a UFF geometry or an imported bag (`modal-twin model info` lists its "
               "modes)")
        raise ConfigError(msg)
    structure = model if model.suffix.lower() in MATRIX_SUFFIXES else read_version(model).structure
    if structure.suffix.lower() in MATRIX_SUFFIXES:
        msg = (f"{model}: a matrix model ({structure.suffix}) has no geometry to draw; view "
               "takes a structure or vehicle YAML, a model version of one, a UFF geometry or an "
               "imported bag (`modal-twin model info` lists a matrix model's modes)")
        raise ConfigError(msg)


def _scene(args: argparse.Namespace) -> tuple[list[object], str]:
    """Return the scene the arguments ask for (module docstring)."""
    from modal_twin.errors import ConfigError

    if _is_vehicle3d(args.model):
        return vehicle3d_scene_commands(args)
    if args.carbody_mode is not None or args.carbody_params is not None:
        msg = f"--carbody-mode, --carbody-params: only for a 3D vehicle file, got {args.model}"
        raise ConfigError(msg)
    _check_drawable(args.model)
    if args.modes is not None and args.model.is_file() and _is_vehicle(args.model):
        msg = (f"{args.model}: --modes draws on a building or a test geometry; a vehicle "
               "shows its model modes (and a record's motion with --bag)")
        raise ConfigError(msg)
    if _is_geometry(args.model) and args.bag is None:
        return geometry_scene(args.model, args.modes)
    if args.bag is not None:
        return bag_scene(args.model, args.bag, args.window)
    if args.modes is not None:
        return identified_scene(args.model, args.modes)
    return model_scene(args.model, args.n_modes)


def run(args: argparse.Namespace) -> int:
    """Write the scene's HTML, or serve it until Ctrl-C."""
    from modal_twin.viz.meshcat_server import MeshcatServer, send_commands
    from modal_twin.viz.scene import static_html

    if not (args.model.is_file() or args.model.is_dir()):
        print(f"modal-twin view: model file {args.model} not found", file=sys.stderr)
        return ExitCode.USAGE
    for what, p in (("modes file", args.modes), ("bag", args.bag)):
        if p is not None and not p.exists():
            print(f"modal-twin view: {what} {p} not found", file=sys.stderr)
            return ExitCode.USAGE
    if args.modes is not None and args.bag is not None:
        print("modal-twin view: give --modes or --bag, not both", file=sys.stderr)
        return ExitCode.USAGE
    if args.html is not None:
        check_new(args.html, args.force)  # before the work
    cmds, caption = _scene(args)
    if args.html is not None:
        with atomic_file(args.html, force=args.force) as tmp:
            tmp.write_text(static_html(cmds, caption=caption, title=args.model.name))
        print(f"scene: {args.html}")
        return ExitCode.OK
    def _terminate(*_: object) -> None:  # SIGTERM ends the view like Ctrl-C (server stopped)
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, _terminate)
    try:
        with MeshcatServer(zmq_port=args.zmq_port, web_port=args.web_port) as server:
            send_commands(server.zmq_url, cmds)
            print(f"scene: {server.web_url} (Ctrl-C to stop the server, pid "
                  f"{server.proc.pid if server.proc else '?'})", flush=True)
            while server.proc is not None and server.proc.poll() is None:
                time.sleep(0.5)
    except KeyboardInterrupt:
        return ExitCode.INTERRUPTED
    return ExitCode.FAILED
