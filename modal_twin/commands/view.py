"""``modal-twin view MODEL [--n-modes N] [--html OUT]``: the 3D scene of a model.

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


def run(args: argparse.Namespace) -> int:
    """Write the scene's HTML, or serve it until Ctrl-C."""
    from modal_twin.viz.meshcat_server import MeshcatServer, send_commands
    from modal_twin.viz.scene import static_html

    if not args.model.is_file():
        print(f"modal-twin view: model file {args.model} not found", file=sys.stderr)
        return ExitCode.USAGE
    cmds, caption = model_scene(args.model, args.n_modes)
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
