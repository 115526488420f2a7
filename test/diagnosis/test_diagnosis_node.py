"""Diagnosis node on a replayed bag: report, add-effect service, /model/parameters."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]


def _bag(path: Path) -> None:
    from conftest import write_frames_bag

    from modal_twin.models.loading import load_model
    from modal_twin.models.rig_file import load_rig

    rig = load_rig(ROOT / "config" / "rigs" / "s1_stick_slip.yaml")
    write_frames_bag(path, load_model(rig.structure).plant(rig.effects), seconds=16.0,
                     scale=(1.2, 1.2, 0.3, 0, 0, 0), seed=3, block=200, noise_rms=rig.noise_rms)


def _spin_until(ex: Any, done: Callable[[], bool]) -> None:
    """Spin ``ex`` until ``done()``."""
    while not done():
        ex.spin_once(timeout_sec=0.05)


def test_diagnosis_node_finds_and_adds_the_effect(domain_id: int, tmp_path: Path) -> None:
    import rclpy
    from modal_twin_msgs.msg import ModelParameters
    from modal_twin_msgs.srv import AddEffect, RunDiagnosis
    from rclpy.executors import SingleThreadedExecutor

    from modal_twin.diagnosis.node import DiagnosisNode
    from modal_twin.io.ros import qos_for

    _bag(tmp_path / "bag")
    rclpy.init(domain_id=domain_id, args=[
        "diag", "--ros-args", "-p", f"model_file:={ROOT}/config/structures/building.yaml",
        "-p", f"versions_dir:={tmp_path}/models", "-p", "n_fit:=2"])
    node = DiagnosisNode()
    client = rclpy.create_node("client")
    params: list[ModelParameters] = []
    client.create_subscription(ModelParameters, "/model/parameters", params.append,
                               qos_for("/model/parameters"))
    ex = SingleThreadedExecutor()
    ex.add_node(node)
    ex.add_node(client)
    try:
        # every wait below is for an event (the graph, a reply, the samples): however loaded
        # the machine, only pytest-timeout's hang guard bounds them
        empty = client.create_client(RunDiagnosis, "/diagnosis/run")
        _spin_until(ex, empty.service_is_ready)
        fut = empty.call_async(RunDiagnosis.Request())
        ex.spin_until_future_complete(fut)
        assert not fut.result().success and "no measurement frames" in fut.result().message
        rep = subprocess.Popen([sys.executable, "-m", "modal_twin.cli", "replay",
                                str(tmp_path / "bag"), "--rate", "8"], stdout=subprocess.DEVNULL)
        _spin_until(ex, lambda: node.service.frames.n_samples >= 16000)
        assert rep.wait() == 0
        assert node.service.frames.n_samples == 16000
        fut = empty.call_async(RunDiagnosis.Request())
        ex.spin_until_future_complete(fut)
        res = fut.result()
        assert res.success, res.message
        assert res.report.significant
        assert (res.report.candidates[0].component, res.report.candidates[0].effect) == (
            "ESB1", "stick_slip")
        add = client.create_client(AddEffect, "/diagnosis/add_effect")
        fut = add.call_async(AddEffect.Request())
        ex.spin_until_future_complete(fut)
        out = fut.result()
        assert out.success, out.message
        assert out.model_version == "v1"
        assert (tmp_path / "models" / "v0000.yaml").is_file()
        assert (tmp_path / "models" / "v0001.yaml").is_file()
        _spin_until(ex, lambda: bool(params))
        assert params[-1].model_file.endswith("v0001.yaml")
    finally:
        ex.shutdown()
        node.destroy_node()
        client.destroy_node()
        rclpy.try_shutdown()
