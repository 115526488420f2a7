"""The meshcat server as a subprocess we own: 127.0.0.1 only, stopped by PID.

meshcat's own ``meshcat.servers.zmqserver`` binds its ZeroMQ socket to 127.0.0.1 but its
web server to every interface (``tornado`` ``listen(port)`` without an address), tries
the next port silently when one is in use, and outlives a killed parent. Here:

* the child (``python -m modal_twin.viz.meshcat_server --zmq-port P --web-port Q``) runs
  meshcat's bridge with the web server bound to 127.0.0.1 and exactly the ports asked; a
  port in use ends it with one line ``meshcat server: port Q on 127.0.0.1 is in use``;
* the parent (:class:`MeshcatServer`) writes the child's PID to a PID file, asks the kernel
  to end the child with the parent (``PR_SET_PDEATHSIG``), stops it by that PID on exit,
  and on start stops a server left by an earlier run (the PID file names it);
* meshcat's ngrok tunnel (``--ngrok_http_tunnel``, via pyngrok) is never offered: nothing
  here imports pyngrok, and the scene can be exported without any server
  (:func:`modal_twin.viz.scene.static_html`).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import select
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

from modal_twin.errors import LaunchError
from modal_twin.viz.scene import VertexAnimation

__all__ = ["MeshcatServer", "default_pid_file", "send_commands"]

HOST = "127.0.0.1"
_MARK = "modal_twin.viz.meshcat_server"


def default_pid_file() -> Path:
    """``<tmp>/modal_twin_meshcat_<uid>.pid``."""
    return Path(tempfile.gettempdir()) / f"modal_twin_meshcat_{os.getuid()}.pid"


def _die_with_parent() -> None:  # pragma: no cover - runs in the child before exec
    try:
        import ctypes

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except OSError:
        pass


def _is_our_server(pid: int) -> bool:
    try:
        return _MARK in Path(f"/proc/{pid}/cmdline").read_bytes().decode(errors="replace")
    except OSError:
        return False


def _stop_pid(pid: int, timeout_s: float = 5.0) -> None:
    with contextlib.suppress(ProcessLookupError):
        os.kill(pid, signal.SIGTERM)
        t0 = time.monotonic()
        while time.monotonic() - t0 < timeout_s and _is_our_server(pid):
            time.sleep(0.05)
        if _is_our_server(pid):
            os.kill(pid, signal.SIGKILL)


class MeshcatServer:
    """Start / stop meshcat's server on 127.0.0.1 (context manager).

    Parameters
    ----------
    zmq_port, web_port : int
        Ports on 127.0.0.1 (meshcat's defaults 6000 and 7000).
    pid_file : path, optional
        Where the child's PID is kept (default :func:`default_pid_file`).
    timeout_s : float
        Time allowed for the server to come up.

    Raises
    ------
    LaunchError
        A port in use (one line naming it) or a server that did not come up.
    """

    def __init__(self, *, zmq_port: int = 6000, web_port: int = 7000,
                 pid_file: str | Path | None = None, timeout_s: float = 60.0) -> None:
        self.zmq_port, self.web_port = zmq_port, web_port
        self.pid_file = Path(pid_file) if pid_file is not None else default_pid_file()
        self.timeout_s = timeout_s
        self.proc: subprocess.Popen[bytes] | None = None
        self.zmq_url = f"tcp://{HOST}:{zmq_port}"
        self.web_url = f"http://{HOST}:{web_port}/static/"

    def start(self) -> MeshcatServer:
        """Stop a server left by an earlier run, start ours, wait until it listens."""
        self._stop_stale()
        cmd = [sys.executable, "-m", _MARK, "--zmq-port", str(self.zmq_port),
               "--web-port", str(self.web_port)]
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                     preexec_fn=_die_with_parent)
        self.pid_file.write_text(f"{self.proc.pid}\n")
        try:
            self._wait_ready()
        except BaseException:  # not up, port in use, Ctrl-C: the child goes too
            self.stop()
            raise
        return self

    def _wait_ready(self) -> None:
        assert self.proc is not None
        assert self.proc.stdout is not None
        fd, buf = self.proc.stdout.fileno(), b""
        t0 = time.monotonic()
        while time.monotonic() - t0 < self.timeout_s:
            ready, _, _ = select.select([fd], [], [], 0.2)
            if not ready:
                continue
            chunk = os.read(fd, 65536)  # raw reads: no line left behind in a buffer
            buf += chunk
            lines = buf.decode(errors="replace").splitlines()
            if any(ln.startswith("web_url=") for ln in lines):
                return
            err = [ln for ln in lines if ln.startswith("meshcat server:")]
            if err or not chunk:
                raise LaunchError(err[0] if err else "meshcat server: exited on start")
        msg = f"meshcat server: not up within {self.timeout_s:g} s"
        raise LaunchError(msg)

    def _stop_stale(self) -> None:
        try:
            pid = int(self.pid_file.read_text().split()[0])
        except (OSError, ValueError, IndexError):
            return
        if _is_our_server(pid):
            _stop_pid(pid)
        self.pid_file.unlink(missing_ok=True)

    def stop(self) -> None:
        """Stop the server by its PID and remove the PID file."""
        if self.proc is not None and self.proc.poll() is None:
            _stop_pid(self.proc.pid)
            self.proc.wait(timeout=5.0)
        if self.proc is not None and self.proc.stdout is not None:
            self.proc.stdout.close()
        self.proc = None
        self.pid_file.unlink(missing_ok=True)

    def __enter__(self) -> MeshcatServer:
        return self.start()

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.stop()


def send_commands(zmq_url: str, commands: Sequence[Any], *, timeout_s: float = 10.0) -> None:
    """Send meshcat commands (:func:`~modal_twin.viz.scene.scene_commands`) to a server."""
    import umsgpack
    import zmq

    ctx: zmq.Context[zmq.Socket[bytes]] = zmq.Context.instance()
    sock: zmq.Socket[bytes] = ctx.socket(zmq.REQ)
    sock.setsockopt(zmq.RCVTIMEO, int(1000 * timeout_s))
    sock.setsockopt(zmq.LINGER, 0)
    sock.connect(zmq_url)
    try:
        for cmd in commands:
            if isinstance(cmd, VertexAnimation):  # a static page's own script: at rest here
                continue
            data = cmd.lower()
            sock.send_multipart([data["type"].encode(), data["path"].encode(),
                                 umsgpack.packb(data)])
            sock.recv()
    except zmq.error.Again as err:
        msg = f"meshcat server at {zmq_url}: no answer within {timeout_s:g} s"
        raise LaunchError(msg) from err
    finally:
        sock.close()


def get_scene_html(zmq_url: str, *, timeout_s: float = 10.0) -> str:
    """Return the static HTML of the scene the server holds (meshcat's ``get_scene``)."""
    import zmq

    sock: zmq.Socket[bytes] = zmq.Context.instance().socket(zmq.REQ)
    sock.setsockopt(zmq.RCVTIMEO, int(1000 * timeout_s))
    sock.setsockopt(zmq.LINGER, 0)
    sock.connect(zmq_url)
    try:
        sock.send(b"get_scene")
        return bytes(sock.recv()).decode()
    finally:
        sock.close()


def _serve(argv: Sequence[str] | None = None) -> int:  # pragma: no cover - the child
    p = argparse.ArgumentParser(prog="python -m " + _MARK)
    p.add_argument("--zmq-port", type=int, default=6000)
    p.add_argument("--web-port", type=int, default=7000)
    a = p.parse_args(argv)
    from meshcat.servers.zmqserver import ZMQWebSocketBridge

    class _LocalBridge(ZMQWebSocketBridge):
        def make_app(self) -> Any:
            app = super().make_app()
            listen = app.listen
            app.listen = lambda port, **kw: listen(port, address=HOST, **kw)
            return app

    try:
        bridge = _LocalBridge(zmq_url=f"tcp://{HOST}:{a.zmq_port}", host=HOST,
                              port=a.web_port)
    except OSError as err:  # zmq's ZMQError is an OSError too
        port = a.web_port if "zmq" not in type(err).__module__ else a.zmq_port
        print(f"meshcat server: port {port} on {HOST} is in use ({err})", flush=True)
        return 3
    print(f"zmq_url={bridge.zmq_url}", flush=True)
    print(f"web_url={bridge.web_url}", flush=True)
    signal.signal(signal.SIGTERM, lambda *_: bridge.ioloop.add_callback_from_signal(
        bridge.ioloop.stop))
    bridge.run()
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(_serve())
