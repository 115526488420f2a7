"""The loop over ROS on a replayed bag: identification -> updating -> twin, error falls."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytestmark = [pytest.mark.ros, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[2]
BUILDING = ROOT / "config" / "structures" / "building.yaml"
TRUTH = {"E_Fc36": 3.278e10 * 0.85, "E_Fc27": 2.915e10 * 1.12, "E_Fc21": 2.585e10 * 0.88}
SCENARIO = f"""
launch:
  name: chain
  ready_timeout_s: 40
  nodes:
    - {{name: identification, executable: identification_node}}
    - {{name: updating, executable: updating_node}}
    - {{name: twin, executable: twin_node}}
identification:
  ros__parameters: {{window_s: 200.0, fs_target_hz: 50.0, max_order: 60,
                    order_step: 4, f_max_hz: 20.0}}
updating:
  ros__parameters: {{model_file: {BUILDING}, versions_dir: VERSIONS, auto: true}}
twin:
  ros__parameters: {{model_file: {BUILDING}, fs_hz: 1000.0, window_s: 200.0,
                    metrics_period_s: 0.5, versions_dir: VERSIONS}}
"""


def _bag(path: Path) -> None:
    from conftest import write_frames_bag

    from modal_twin.models.loading import load_model

    write_frames_bag(path, load_model(BUILDING, theta=TRUTH).plant(), seconds=100.0,
                     scale=(0.4, 0.4, 0.2, 0, 0, 0), seed=5, block=250,
                     noise_rms={"acceleration": 0.002, "displacement": 1e-5, "force": 100.0})


def test_replayed_bag_identify_update_twin(domain_id: int, tmp_path: Path) -> None:
    import rclpy
    from modal_twin_msgs.msg import ComparisonMetrics, ModelParameters
    from modal_twin_msgs.srv import RunIdentification
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor

    from modal_twin.io.ros import qos_for
    from modal_twin.launch import Launcher
    from modal_twin.scenario import load_scenario

    _bag(tmp_path / "bag")
    scen = tmp_path / "s.yaml"
    scen.write_text(SCENARIO.replace("VERSIONS", str(tmp_path / "models")))
    launcher = Launcher(load_scenario(scen), run_dir=tmp_path / "run", say=lambda s: None)
    launcher.start()
    ctx = Context()
    rclpy.init(context=ctx, domain_id=domain_id)
    node = rclpy.create_node("probe", context=ctx)
    metrics: list[ComparisonMetrics] = []
    params: list[ModelParameters] = []
    node.create_subscription(ComparisonMetrics, "/twin/metrics", metrics.append,
                             qos_for("/twin/metrics"))
    node.create_subscription(ModelParameters, "/model/parameters", params.append,
                             qos_for("/model/parameters"))
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)

    def spin(seconds: float, until=lambda: False) -> None:  # type: ignore[no-untyped-def]
        end = time.monotonic() + seconds
        while time.monotonic() < end and not until():
            ex.spin_once(timeout_sec=0.05)

    def replay() -> float:
        rep = subprocess.Popen([sys.executable, "-m", "modal_twin.cli", "replay",
                                str(tmp_path / "bag"), "--rate", "10",
                                "--subscribers", "2",  # identification and twin
                                # ends when the twin has answered every block, at any load
                                "--paced-by", "/twin/residual"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        while rep.poll() is None:
            spin(0.2)
        n0 = len(metrics)
        spin(30.0, lambda: len(metrics) > n0 + 2 and metrics[-1].samples >= 100_000)
        m = metrics[-1]
        assert m.samples >= 100_000, f"the twin compared {m.samples} of 100000 samples"
        acc = [i for i, c in enumerate(m.channel_names) if c[-2:] in ("_x", "_y", "_z")]
        return float(np.mean(np.asarray(m.residual_rms)[acc]))

    try:
        assert launcher.wait_ready(40.0) == ""
        before = replay()
        cli = node.create_client(RunIdentification, "/identification/run")
        assert cli.wait_for_service(timeout_sec=10)
        fut = cli.call_async(RunIdentification.Request())
        spin(120.0, fut.done)
        assert fut.result() is not None
        assert fut.result().success, fut.result().message
        spin(60.0, lambda: bool(params))
        assert params, "the updating node published no parameters"
        twin_log = tmp_path / "run" / "logs" / "twin.log"
        spin(30.0, lambda: "now runs model version" in twin_log.read_text())
        assert "now runs model version" in twin_log.read_text(), "the twin did not reload"
        after = replay()
        assert launcher.dead() == []
    finally:
        launcher.stop()
        ex.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)
    got = dict(zip(params[-1].names, params[-1].values, strict=True))
    for k, v in TRUTH.items():
        assert got[k] == pytest.approx(v, rel=0.03), k
    print(f"twin residual of the accelerations: {before:.2f} % -> {after:.2f} %")
    assert after < 0.3 * before
