"""``modal-twin view MODEL [--modes FILE] [--n-modes N] [--html OUT]``: the 3D scene of a model.

With ``--modes`` (the JSON ``modal-twin identify`` writes) every identified mode is drawn
on the structure (expanded from its channels with the model's modes, SEREP) in blue,
beside the model mode it pairs with by MAC in orange; the caption gives f, zeta and MAC.

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

from modal_twin.exit_codes import ExitCode

__all__ = ["register", "run"]


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``view`` parser."""
    p = sub.add_parser("view", help="3D scene of a model: structure, sensors, devices, modes")
    p.add_argument("model", type=Path, help="structure file or model version file")
    p.add_argument("--n-modes", type=int, default=6, help="model modes to animate")
    p.add_argument("--modes", type=Path, default=None,
                   help="identified modes (identify JSON): drawn beside their model pairs")
    p.add_argument("--html", type=Path, default=None,
                   help="write a static HTML page instead of starting a server")
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
    geom = building_geometry(mv.structure)
    modes = building_modes(mv.structure, n_modes) if n_modes > 0 else None
    return (scene_commands(geom, modes, blamed=blamed),
            overlay_html(geom, modes, blamed))


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
    from modal_twin.models.versions import read_version
    from modal_twin.viz.mode_pairs import (
        channel_nodes,
        expand_shapes,
        pair_by_mac,
        real_shapes,
        sampled_shapes,
    )
    from modal_twin.viz.scene import (
        SceneModes,
        building_geometry,
        building_modes,
        overlay_html,
        scene_commands,
    )

    mv = read_version(model)
    geom = building_geometry(mv.structure)
    basis = building_modes(mv.structure, n_basis)
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


def run(args: argparse.Namespace) -> int:
    """Write the scene's HTML, or serve it until Ctrl-C."""
    from modal_twin.viz.meshcat_server import MeshcatServer, send_commands
    from modal_twin.viz.scene import static_html

    if not args.model.is_file():
        print(f"modal-twin view: model file {args.model} not found", file=sys.stderr)
        return ExitCode.USAGE
    if args.modes is not None and not args.modes.is_file():
        print(f"modal-twin view: modes file {args.modes} not found", file=sys.stderr)
        return ExitCode.USAGE
    cmds, caption = (model_scene(args.model, args.n_modes) if args.modes is None
                     else identified_scene(args.model, args.modes))
    if args.html is not None:
        args.html.parent.mkdir(parents=True, exist_ok=True)
        args.html.write_text(static_html(cmds, caption=caption, title=args.model.name))
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
