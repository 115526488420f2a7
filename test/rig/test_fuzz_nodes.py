"""Every node survives random and extreme values on every topic and service it serves.

All seven nodes are launched; a tester sends hostile messages (one field at a time at
inf, nan, 1e308, 4294967295, empty, huge or mismatched arrays, path escapes, then random
messages) to every subscribed topic and hostile requests to every service. Afterwards
every node is still running and still answers, and a refused excitation start left the
settings as they were (the next valid start is accepted).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(Path(__file__).resolve().parent))

RIG = f"{ROOT}/config/rigs/building_rig.yaml"
MODEL = f"{ROOT}/config/structures/building.yaml"


def scenario_text(versions: Path) -> str:
    """All seven nodes, the excitation waiting for a start request."""
    return f"""
launch:
  name: fuzz
  ready_timeout_s: 120
  nodes:
    - {{name: excitation, executable: excitation_node}}
    - {{name: rig, executable: rig_node}}
    - {{name: acquisition, executable: acquisition_node}}
    - {{name: identification, executable: identification_node}}
    - {{name: updating, executable: updating_node}}
    - {{name: twin, executable: twin_node}}
    - {{name: diagnosis, executable: diagnosis_node}}
excitation:
  ros__parameters: {{autostart: false, duration_s: 2.0}}
rig:
  ros__parameters: {{rig_file: {RIG}}}
acquisition:
  ros__parameters: {{rig_file: {RIG}}}
identification:
  ros__parameters: {{window_s: 30.0}}
updating:
  ros__parameters: {{model_file: {MODEL}, versions_dir: {versions}, auto: false}}
twin:
  ros__parameters: {{model_file: {MODEL}, metrics_period_s: 0.5}}
diagnosis:
  ros__parameters: {{model_file: {MODEL}, versions_dir: {versions}, buffer_s: 30.0}}
"""


class HostileClient:
    """Publishers and clients for every topic and service of the graph, one Context."""

    def __init__(self, domain_id: int) -> None:
        import rclpy
        from modal_twin_msgs import msg, srv
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor

        from modal_twin.io.ros import qos_for

        self.msg, self.srv = msg, srv
        self.ctx = Context()
        rclpy.init(context=self.ctx, domain_id=domain_id)
        self.node = rclpy.create_node("fuzzer", context=self.ctx)
        self.ex = SingleThreadedExecutor(context=self.ctx)
        self.ex.add_node(self.node)
        topics = {"/excitation/command": msg.ExcitationCommand,
                  "/excitation/signal": msg.SignalBlock, "/rig/raw": msg.SignalBlock,
                  "/measurement/frames": msg.SignalBlock, "/twin/residual": msg.SignalBlock,
                  "/model/parameters": msg.ModelParameters,
                  "/identification/modes": msg.ModalModel}
        self.pubs = {t: self.node.create_publisher(c, t, qos_for(t)) for t, c in topics.items()}
        services = {"/excitation/start": srv.StartExcitation,
                    "/excitation/abort": srv.AbortExcitation,
                    "/identification/run": srv.RunIdentification,
                    "/updating/run": srv.RunUpdating, "/diagnosis/run": srv.RunDiagnosis,
                    "/diagnosis/add_effect": srv.AddEffect}
        self.clients = {s: (self.node.create_client(c, s), c) for s, c in services.items()}

    def spin(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.ex.spin_once(timeout_sec=0.02)

    def call(self, service: str, req: object, timeout_s: float = 120.0) -> object | None:
        client, _ = self.clients[service]
        end = time.monotonic() + timeout_s
        while not client.service_is_ready() and time.monotonic() < end:
            self.ex.spin_once(timeout_sec=0.05)
        fut = client.call_async(req)
        while not fut.done() and time.monotonic() < end:
            self.ex.spin_once(timeout_sec=0.02)
        return fut.result() if fut.done() else None

    def close(self) -> None:
        import rclpy

        self.ex.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.ctx)


def _block(msg_mod: object, k: int, names: tuple[str, ...]) -> object:
    from modal_twin.io.convert import block_to_msg
    from modal_twin.signal_block import SignalBlock

    data = np.random.default_rng(k).normal(size=(len(names), 50))
    return block_to_msg(SignalBlock(names, 1000.0, 50 * k, data), msg_mod.SignalBlock)  # type: ignore[attr-defined]


def send_hostile(t: HostileClient, rng: np.random.Generator) -> int:
    """Every hostile message and request; returns how many were sent."""
    from hostile import hostile

    m, s = t.msg, t.srv
    drive = ("ax", "ay", "az", "arx", "ary", "arz")
    makers = {
        "/excitation/command": lambda: m.ExcitationCommand(kind="random"),
        "/excitation/signal": lambda: _block(m, 3, drive),
        "/rig/raw": lambda: _block(m, 3, ("table_x", "F0_C1_x")),
        "/measurement/frames": lambda: _block(m, 3, ("table_x", "F0_C1_x")),
        "/twin/residual": lambda: _block(m, 3, ("F0_C1_x",)),
        "/model/parameters": lambda: m.ModelParameters(names=["E_Fc36"], values=[3e10]),
        "/identification/modes": lambda: m.ModalModel(
            method="n4sid", channel_names=["a"],
            modes=[m.Mode(frequency_hz=1.0, damping_ratio=0.02, shape_real=[1.0],
                          shape_imag=[0.0])]),
    }
    n = 0
    for topic, make in makers.items():
        for msg in hostile(make, rng):
            t.pubs[topic].publish(msg)
            n += 1
            t.ex.spin_once(timeout_sec=0.005)
    mode_msg = makers["/identification/modes"]()
    for v in (float("nan"), float("inf"), 1e308, -1.0):
        mode_msg.modes[0].frequency_hz = v
        t.pubs["/identification/modes"].publish(mode_msg)
        n += 1
    requests = [
        ("/excitation/start", s.StartExcitation.Request(command=c))
        for c in hostile(lambda: m.ExcitationCommand(kind="random"), rng)
        if not (c.kind == "random" and 0 < c.duration_s <= 5 and not c.record_path)
    ]
    requests += [("/identification/run", r) for r in hostile(s.RunIdentification.Request, rng)]
    requests += [("/diagnosis/run", r) for r in hostile(s.RunDiagnosis.Request, rng)]
    requests += [("/diagnosis/add_effect", r) for r in hostile(s.AddEffect.Request, rng)]
    requests += [("/updating/run", r) for r in hostile(s.RunUpdating.Request, rng)]
    requests += [("/excitation/abort", s.AbortExcitation.Request())]
    for service, req in requests:
        t.call(service, req)
        n += 1
    return n


def test_all_nodes_survive_hostile_input(domain_id: int, tmp_path: Path) -> None:
    from modal_twin.launch import Launcher
    from modal_twin.scenario import load_scenario

    p = tmp_path / "fuzz.yaml"
    p.write_text(scenario_text(tmp_path / "versions"))
    launcher = Launcher(load_scenario(p), run_dir=tmp_path / "run", say=lambda s: None,
                        record=False)
    launcher.start()
    t = HostileClient(domain_id)
    try:
        assert launcher.wait_ready(120.0) == "", "graph did not come up"
        n = send_hostile(t, np.random.default_rng(12))
        t.spin(3.0)
        assert n > 200
        assert launcher.dead() == []  # nobody died
        # every service still answers; the refused starts changed nothing
        ok = t.call("/excitation/start", t.srv.StartExcitation.Request(
            command=t.msg.ExcitationCommand(kind="random", duration_s=1.0)))
        assert ok is not None and ok.accepted, getattr(ok, "message", "no answer")
        for service, req in (("/identification/run", t.srv.RunIdentification.Request()),
                             ("/diagnosis/run", t.srv.RunDiagnosis.Request()),
                             ("/updating/run", t.srv.RunUpdating.Request())):
            assert t.call(service, req) is not None, f"{service} did not answer"
        names = {x for x, _ in t.node.get_node_names_and_namespaces()}
        assert {"excitation", "rig", "acquisition", "identification", "updating", "twin",
                "diagnosis"} <= names
        assert launcher.dead() == []
    finally:
        t.close()
        launcher.stop()
    logs = {nm: launcher.log_tail(nm, 400) for nm in ("identification", "excitation", "twin")}
    assert "max_order: expected an integer in [0, 400]" in logs["identification"]
    assert "command.duration_s: expected a finite number" in logs["excitation"]
    assert "Traceback" not in "".join(logs.values())
