"""Diagnosis node on a replayed bag: report, add-effect service, /model/parameters."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]


def _bag(path: Path) -> None:
    from modal_twin.excitation import signals
    from modal_twin.io.bag import BagWriter
    from modal_twin.io.convert import block_to_rosbags
    from modal_twin.io.typestore import typestore
    from modal_twin.rig.config import load_rig
    from modal_twin.rig.truth import TruthRig
    from modal_twin.signal_block import SignalBlock
    from modal_twin.twin.plants import INPUTS_6DOF, load_plant

    rig = load_rig(ROOT / "config" / "rigs" / "s1_stick_slip.yaml")
    truth = TruthRig(load_plant(rig.structure, effects=rig.effects), 1e-3,
                     noise_rms=rig.noise_rms, seed=3)
    rng = np.random.default_rng(3)
    ag = signals.band_limited_random(6, 16.0, 1000.0, f_min_hz=0.2, f_max_hz=20.0, rms=1.0,
                                     rng=rng) * np.array([1.2, 1.2, 0.3, 0, 0, 0])[:, None]
    st = typestore()
    sb = "modal_twin_msgs/msg/SignalBlock"
    with BagWriter(path, {"/measurement/frames": sb}) as w:
        for k in range(0, ag.shape[1], 200):
            raw = truth.process(SignalBlock(INPUTS_6DOF, 1000.0, k, ag[:, k:k + 200],
                                            stamp_ns=10**18 + k * 10**6))
            w.write("/measurement/frames", raw.stamp_ns,
                    st.serialize_cdr(block_to_rosbags(raw, st), sb))


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
        empty = client.create_client(RunDiagnosis, "/diagnosis/run")
        assert empty.wait_for_service(timeout_sec=10)
        fut = empty.call_async(RunDiagnosis.Request())
        ex.spin_until_future_complete(fut, timeout_sec=10)
        assert not fut.result().success and "no measurement frames" in fut.result().message
        rep = subprocess.Popen([sys.executable, "-m", "modal_twin.cli", "replay",
                                str(tmp_path / "bag"), "--rate", "8"], stdout=subprocess.PIPE)
        end = time.monotonic() + 60
        while rep.poll() is None and time.monotonic() < end:
            ex.spin_once(timeout_sec=0.05)
        for _ in range(40):
            ex.spin_once(timeout_sec=0.05)
        assert sum(b.n_samples for b in node.blocks) == 16000
        fut = empty.call_async(RunDiagnosis.Request())
        ex.spin_until_future_complete(fut, timeout_sec=240)
        res = fut.result()
        assert res.success, res.message
        assert res.report.significant
        assert (res.report.candidates[0].component, res.report.candidates[0].effect) == (
            "ESB1", "stick_slip")
        add = client.create_client(AddEffect, "/diagnosis/add_effect")
        fut = add.call_async(AddEffect.Request())
        ex.spin_until_future_complete(fut, timeout_sec=240)
        out = fut.result()
        assert out.success, out.message
        assert out.model_version == "v1"
        assert (tmp_path / "models" / "v0000.yaml").is_file()
        assert (tmp_path / "models" / "v0001.yaml").is_file()
        end = time.monotonic() + 5
        while not params and time.monotonic() < end:
            ex.spin_once(timeout_sec=0.05)
        assert params and params[-1].model_file.endswith("v0001.yaml")
    finally:
        ex.shutdown()
        node.destroy_node()
        client.destroy_node()
        rclpy.try_shutdown()
