"""Launcher: start a scenario's nodes as processes and supervise them.

Wait until they are up and matched, supervise them, stop them cleanly.

- Every node runs as its own process with ``--ros-args -r __node:=<name>
  --params-file <run>/params/<name>.yaml`` and logs to ``<run>/logs/<name>.log``.
- A run gets its own ``ROS_DOMAIN_ID`` (unless one is set), reserved until it stops
  (:func:`modal_twin.domain.reserve_domain`), so parallel runs never meet.
- Ready = every node visible in the graph, every node has said ``ready`` on
  ``/diagnostics`` (a node says ``starting: ...`` while it builds its model and compiles its
  kernels) and every topic that one launched node publishes and another subscribes has
  both ends discovered. Only then are the excitation nodes started (``~/start``) and the
  run's duration counted, so the first sample reaches the bag; a node still starting at
  ``ready_timeout_s`` is named in one line (exit code NOT_READY).
- Ctrl-C / SIGTERM are forwarded as SIGINT to the nodes (recorder last); the run then exits
  130 after Ctrl-C, 0 after SIGTERM. A node that dies stops the run, which exits 1 and names it.
- The nodes die with the launcher even when it is killed (SIGKILL): each is started with
  ``PR_SET_PDEATHSIG`` = SIGTERM (Linux).
- Discovery stays on this host (unicast to 127.0.0.1) unless the
  environment or the scenario (``launch.network: true``) asks for the network, and its UDP
  sockets bind 127.0.0.1 only (:func:`modal_twin.io.ros.dds_env`); files the launcher and
  the nodes create are private to the user (files 0600, folders 0700:
  :data:`modal_twin.paths.UMASK`). Fast DDS gives its shared-memory
  segments mode 0644 whatever the umask; ``launch.shared_memory: false`` keeps the data off
  shared memory (UDP on the loopback only).
"""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any

import rclpy
from rclpy.context import Context

from modal_twin.domain import DomainReservation, reserve_domain
from modal_twin.errors import ConfigError
from modal_twin.exit_codes import ExitCode
from modal_twin.io.ros import dds_env
from modal_twin.io.topics import NODE_ENDPOINTS
from modal_twin.paths import RUNS, private_files
from modal_twin.runtime import runtime_env
from modal_twin.scenario import Scenario, load_scenario, with_parameters
from modal_twin.validation import check_name

__all__ = ["LaunchResult", "Launcher", "launch"]

log = logging.getLogger(__name__)

_PR_SET_PDEATHSIG = 1
SETTLE_S = 1.0
"""Least wait between the probe seeing every endpoint and the excitation start. Beyond it
the launcher waits until every node reports (on /diagnostics, ``matched <topic>``) that
each topic it publishes has matched all its launched readers: the later hops (rig ->
acquisition -> recorder and twin) are matched before the first block, however loaded the
machine; the excitation itself waits for the readers of /excitation/signal."""


def _die_with_parent() -> None:
    """``preexec_fn`` of every node: SIGTERM when the launcher dies, files private (0600)."""
    import ctypes

    private_files()
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGTERM, 0, 0, 0)
    except (OSError, AttributeError):  # not Linux: the nodes' own shutdown still applies
        pass


@dataclass(slots=True)
class LaunchResult:
    """What a run did."""

    exit_code: int
    run_dir: Path
    domain_id: int
    bag: Path | None
    node_exit_codes: dict[str, int | None] = field(default_factory=dict)
    message: str = ""


def _executable(name: str) -> list[str]:
    """Command for a node executable (console script beside this interpreter)."""
    script = Path(sys.executable).parent / name
    if script.is_file():
        return [str(script)]
    from importlib.metadata import entry_points

    eps = {ep.name: ep.value for ep in entry_points(group="console_scripts")
           if ep.value.startswith("modal_twin.")}
    if name in eps:
        module, func = eps[name].split(":")
        code = f"import sys; from {module} import {func}; sys.exit({func}())"
        return [sys.executable, "-c", code]
    msg = f"executable {name!r} not found; known: {sorted(eps)}"
    raise ConfigError(msg)


class _StatusWatch:
    """What the nodes say on ``/diagnostics``: last state, who was ready, matched readers."""

    def __init__(self) -> None:
        self.said: dict[str, str] = {}  # each node's last message
        self.ready: set[str] = set()  # said ready once (a later busy state is work)
        self.matched: dict[str, dict[str, int]] = {}  # node -> topic -> matched readers

    def on_status(self, msg: Any) -> None:
        """Take one DiagnosticArray."""
        from modal_twin.io.status import MATCHED

        for st in msg.status:
            name = st.name.lstrip("/")
            self.said[name] = st.message
            if any(kv.key == "state" and kv.value == "ready" for kv in st.values):
                self.ready.add(name)
            self.matched[name] = {kv.key[len(MATCHED):]: int(kv.value)
                                  for kv in st.values if kv.key.startswith(MATCHED)}


class Launcher:
    """Start, watch and stop the processes of one scenario run."""

    def __init__(
        self,
        scenario: Scenario,
        *,
        run_dir: Path | None = None,
        domain_id: int | None = None,
        record: bool = True,
        say: Callable[[str], None] = print,
    ) -> None:
        self.sc = scenario
        stamp = datetime.now().strftime("%Y%m%d-%H%M%S")
        name = check_name(scenario.name, "launch.name")  # it names the run folder
        self.run_dir = run_dir or Path(RUNS) / f"{stamp}_{name}"
        env_domain = os.environ.get("ROS_DOMAIN_ID")
        self._domain: DomainReservation | None = None  # held until stop(), when drawn here
        if domain_id is None and env_domain:
            domain_id = int(env_domain)
        elif domain_id is None:
            self._domain = reserve_domain()
            domain_id = self._domain.domain_id
        self.domain_id = domain_id
        self.say = say
        self.record = record and bool(scenario.record_topics)
        self.bag = self.run_dir / "bag" if self.record else None
        self.procs: dict[str, subprocess.Popen[bytes]] = {}
        self.deferred: list[str] = []  # excitation nodes started once every reader matched
        self._stop_requested = False

    # -- processes ---------------------------------------------------------------------
    def _env(self) -> dict[str, str]:
        env = dict(os.environ)
        env["ROS_DOMAIN_ID"] = str(self.domain_id)
        env["PYTHONUNBUFFERED"] = "1"
        env["MODAL_TWIN_RUN_DIR"] = str(self.run_dir.resolve())  # where a node writes results
        env["RCUTILS_LOGGING_BUFFERED_STREAM"] = "0"
        env.setdefault("RCUTILS_COLORIZED_OUTPUT", "0")
        shm = self.sc.extra.get("shared_memory", True) is not False
        dds_env(env, network=True if self.sc.extra.get("network", False) else None,
                shared_memory=shm, folder=self.run_dir / "params")
        if not shm:  # Fast DDS makes its segments 0644 whatever the umask: avoid them
            env["FASTDDS_BUILTIN_TRANSPORTS"] = "UDPv4"
        return runtime_env(env)  # one BLAS thread, allocator (modal_twin.runtime)

    def _spawn(self, name: str, cmd: list[str]) -> None:
        logf = (self.run_dir / "logs" / f"{name}.log").open("wb")
        self.procs[name] = subprocess.Popen(
            cmd, stdout=logf, stderr=subprocess.STDOUT, env=self._env(),
            start_new_session=True, cwd=os.getcwd(), preexec_fn=_die_with_parent,
        )
        logf.close()

    def start(self) -> None:
        """Write the per-node parameter files and start every process."""
        (self.run_dir / "logs").mkdir(parents=True, exist_ok=True)
        (self.run_dir / "params").mkdir(parents=True, exist_ok=True)
        if self.record and self.bag is not None:
            self._spawn("recorder", [*_executable("recorder_node"), "-o", str(self.bag),
                                     *self.sc.record_topics])
        sc = self.sc
        for node in sc.nodes:  # the excitation starts when the launcher says ready
            if node.executable == "excitation_node" and node.parameters.get("autostart", True):
                readers = self._readers("/excitation/signal")
                wait = max(int(node.parameters.get("wait_subscribers", 1)), readers)
                sc = with_parameters(sc, node.name, autostart=False, wait_subscribers=wait)
                self.deferred.append(node.name)
        for node in sc.nodes:
            pfile = self.run_dir / "params" / f"{node.name}.yaml"
            pfile.write_text(sc.params_file_text(node.name))
            cmd = [*_executable(node.executable), *node.args, "--ros-args",
                   "-r", f"__node:={node.name}", "--params-file", str(pfile)]
            self._spawn(node.name, cmd)

    def dead(self) -> list[tuple[str, int]]:
        """Return the processes that ended when they should not have: (name, exit code)."""
        out = []
        one_shot = {n.name for n in self.sc.nodes if n.one_shot}
        for name, p in self.procs.items():
            code = p.poll()
            if code is not None and not (name in one_shot and code == 0):
                out.append((name, code))
        return out

    def log_tail(self, name: str, lines: int = 12) -> str:
        """Last lines of a node's log."""
        path = self.run_dir / "logs" / f"{name}.log"
        if not path.is_file():
            return ""
        return "\n".join(path.read_text(errors="replace").splitlines()[-lines:])

    def stop(self, timeout_s: float = 10.0) -> None:
        """SIGINT every node (recorder last), then SIGTERM, then SIGKILL."""
        order = [n for n in self.procs if n != "recorder"]
        if "recorder" in self.procs:
            order.append("recorder")
        groups = [order[:-1], order[-1:]] if "recorder" in self.procs else [order]
        for group in groups:
            for name in group:
                if self.procs[name].poll() is None:
                    self.procs[name].send_signal(signal.SIGINT)
            for sig, wait in ((None, timeout_s), (signal.SIGTERM, 3.0), (signal.SIGKILL, 3.0)):
                end = time.monotonic() + wait
                alive = [n for n in group if self.procs[n].poll() is None]
                if sig is not None:
                    for n in alive:
                        self.say(f"launch: {n} did not stop, sending {sig.name}")
                        self.procs[n].send_signal(sig)
                while alive and time.monotonic() < end:
                    time.sleep(0.05)
                    alive = [n for n in alive if self.procs[n].poll() is None]
                if not alive:
                    break
        if self._domain is not None:  # the graph is gone: its domain is free again
            self._domain.release()

    # -- readiness ---------------------------------------------------------------------
    def _readers(self, topic: str) -> int:
        """Return launched processes (recorder included) that subscribe ``topic``."""
        n = int(self.record and topic in {t.partition(":")[0] for t in self.sc.record_topics})
        return n + sum(topic in NODE_ENDPOINTS.get(node.executable, ((), ()))[0]
                       for node in self.sc.nodes)

    def _endpoints(self, name: str) -> tuple[set[str], set[str]]:
        """(subscriptions, publishers) process ``name`` has once fully constructed."""
        if name == "recorder":
            return {t.partition(":")[0] for t in self.sc.record_topics}, set()
        spec = next((n for n in self.sc.nodes if n.name == name), None)
        subs, pubs = NODE_ENDPOINTS.get(spec.executable if spec else "", ((), ()))
        return set(subs), set(pubs)

    def wait_ready(self, timeout_s: float) -> str:
        """'' when every node is up, ready and its topics matched, else what is missing.

        Ready is explicit: each node says ``ready`` on ``/diagnostics`` once it is built
        (its model loaded or reduced, its kernels compiled: ``starting: compiling kernels``
        until then), and the excitation is started only after every node has. What is
        missing at ``timeout_s`` names the late nodes and what they said last.
        """
        from diagnostic_msgs.msg import DiagnosticArray
        from rclpy.executors import SingleThreadedExecutor

        from modal_twin.io.ros import qos_for
        from modal_twin.io.status import STATUS_TOPIC

        ctx = Context()
        rclpy.init(context=ctx, domain_id=self.domain_id)
        probe = rclpy.create_node("launch_probe", context=ctx, start_parameter_services=False)
        ex = SingleThreadedExecutor(context=ctx)
        ex.add_node(probe)
        watch = _StatusWatch()
        sub = probe.create_subscription(DiagnosticArray, STATUS_TOPIC, watch.on_status,
                                        qos_for(STATUS_TOPIC))

        def pause(s: float) -> None:
            until = time.monotonic() + s
            while time.monotonic() < until:
                ex.spin_once(timeout_sec=max(until - time.monotonic(), 0.0))

        want = set(self.procs)
        end = time.monotonic() + timeout_s
        missing = "nodes " + ", ".join(sorted(want))
        try:
            while time.monotonic() < end:
                if self.dead() or self._stop_requested:
                    return ""
                names = {n for n, _ in probe.get_node_names_and_namespaces()}
                lacking = sorted(want - names)
                if lacking:
                    missing = "nodes " + ", ".join(lacking)
                    pause(0.2)
                    continue
                pubs: set[str] = set()
                subs: set[str] = set()
                lacking = []
                for n in want:
                    p = {t for t, _ in probe.get_publisher_names_and_types_by_node(n, "/")}
                    s = {t for t, _ in probe.get_subscriber_names_and_types_by_node(n, "/")}
                    want_s, want_p = self._endpoints(n)
                    lacking += [f"{n}:{t}" for t in sorted((want_s - s) | (want_p - p))]
                    pubs, subs = pubs | p, subs | s
                if lacking:  # a node still being built (its model loading)
                    missing = "endpoints " + ", ".join(lacking)
                    pause(0.2)
                    continue
                late = self._late(watch)
                if late:
                    missing = "ready from " + "; ".join(late)
                    pause(0.2)
                    continue
                unmatched = sorted(
                    t for t in (pubs & subs) - {"/rosout", "/parameter_events"}
                    if probe.count_publishers(t) == 0 or probe.count_subscribers(t) == 0
                )
                if not unmatched:
                    return self._start_deferred(probe, ex, watch.matched, end)
                missing = "topics " + ", ".join(unmatched)
                pause(0.2)
            return missing
        finally:
            probe.destroy_subscription(sub)
            ex.remove_node(probe)
            ex.shutdown()
            probe.destroy_node()
            rclpy.try_shutdown(context=ctx)

    def _late(self, watch: _StatusWatch) -> list[str]:
        """Return the nodes not yet ready, each with what it said last.

        A one-shot node that ended cleanly counts as ready.
        """
        done = {n for n, p in self.procs.items() if p.poll() == 0}
        return [f"{n} ({watch.said.get(n, 'no status yet')})" for n in sorted(self.procs)
                if n not in watch.ready and n not in done]

    def _wait_matched(self, ex: Any, matched: dict[str, dict[str, int]], end: float) -> str:
        """'' once every node's published topics matched their launched readers (SETTLE_S).

        Else, at ``end``, which hop still lacks readers (``node:/topic m of n``); the
        counts are those the nodes report on ``/diagnostics`` (``matched``).
        """
        need = {(n, t): self._readers(t) for n in self.procs for t in self._endpoints(n)[1]}
        need = {k: r for k, r in need.items() if r > 0}
        settle = time.monotonic() + SETTLE_S
        lacking = [f"{n}:{t}" for n, t in need]
        while time.monotonic() < end:
            ex.spin_once(timeout_sec=0.05)
            lacking = [f"{n}:{t} {matched.get(n, {}).get(t, 0)} of {r}"
                       for (n, t), r in need.items() if matched.get(n, {}).get(t, 0) < r]
            if not lacking and time.monotonic() >= settle:
                return ""
        return "matched readers on " + ", ".join(lacking)

    def _start_deferred(self, probe: Any, ex: Any, matched: dict[str, dict[str, int]],
                        end: float) -> str:
        """Call ``~/start`` of each deferred excitation node.

        Its first block goes out only after every node is ready and every recorder and
        reader of the graph has matched.
        """
        from modal_twin_msgs.msg import ExcitationCommand
        from modal_twin_msgs.srv import StartExcitation

        if self.deferred:
            unmatched = self._wait_matched(ex, matched, end)
            if unmatched:
                return unmatched
        for name in self.deferred:
            client = probe.create_client(StartExcitation, f"/{name}/start")
            fut = None
            while time.monotonic() < end and not (fut and fut.done()):
                if fut is None and client.service_is_ready():
                    fut = client.call_async(StartExcitation.Request(
                        command=ExcitationCommand(kind="", reason="launcher: ready")))
                ex.spin_once(timeout_sec=0.05)
            if fut is None or not fut.done():
                return f"a start answer from /{name}/start"
            if not fut.result().accepted:
                return f"an accepted start of {name}: {fut.result().message}"
        return ""

    # -- the whole run -----------------------------------------------------------------
    def request_stop(self) -> None:
        """Stop the run cleanly, as the end of its duration does (callable from a thread)."""
        self._stop_requested = True

    def run(self) -> LaunchResult:
        """Start, wait ready, supervise until the duration ends or a signal / death."""
        interrupted: list[int] = []

        def on_signal(signum: int, _frame: object) -> None:
            self._stop_requested = True
            interrupted.append(signum)

        if self.sc.extra.get("network", False):  # the launcher's own probe too
            dds_env(os.environ, network=True)
        old = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
        code, message = ExitCode.OK, ""
        try:
            self.say(f"launch: {self.sc.name} in {self.run_dir} (ROS_DOMAIN_ID={self.domain_id})")
            self.start()
            missing = self.wait_ready(self.sc.ready_timeout_s)
            if missing:
                code, message = ExitCode.NOT_READY, (
                    f"not ready after {self.sc.ready_timeout_s:.0f} s: missing {missing}")
            elif not self.dead():
                self.say(f"launch: {len(self.procs)} processes up and matched")
            t_end = time.monotonic() + self.sc.duration_s if self.sc.duration_s else None
            while not code and not self._stop_requested:
                died = self.dead()
                if died:
                    name, rc = died[0]
                    code = ExitCode.FAILED
                    message = (f"node {name!r} died with exit code {rc}; last lines of its "
                               f"log:\n{self.log_tail(name)}")
                    break
                if t_end is not None and time.monotonic() >= t_end:
                    break
                time.sleep(0.1)
        finally:
            self.stop()
            for s, h in old.items():
                signal.signal(s, h)
        if code == ExitCode.OK and signal.SIGINT in interrupted:  # Ctrl-C: 130 (README)
            code = ExitCode.INTERRUPTED
        if message:
            self.say(f"launch: {message}")
        self.say(f"launch: stopped; logs in {self.run_dir / 'logs'}")
        return LaunchResult(code, self.run_dir, self.domain_id, self.bag,
                            {n: p.returncode for n, p in self.procs.items()}, message)


def launch(path: str | Path, **kwargs: object) -> LaunchResult:
    """Load a scenario file and run it (see :class:`Launcher` for keywords)."""
    return Launcher(load_scenario(path), **kwargs).run()  # type: ignore[arg-type]


