"""Updating node: identified modes in, updated parameters and a model version out."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
import scipy.signal as sig

pytestmark = pytest.mark.ros

FS = 50.0


def _identified(truth: dict[str, float]):  # type: ignore[no-untyped-def]
    from modal_twin.identification import n4sid, select_modes, stabilization_diagram
    from modal_twin.models.building import DEFAULT_BUILDING_YAML
    from modal_twin.models.loading import load_model
    from modal_twin.twin.simulator import simulate

    plant = load_model(DEFAULT_BUILDING_YAML, theta=truth, n_modes=16).plant()
    rng = np.random.default_rng(1)
    b, a = sig.butter(4, 20.0, fs=FS)
    ag = np.zeros((6, int(200 * FS)))
    ag[:3] = sig.lfilter(b, a, rng.standard_normal((3, ag.shape[1])), axis=1)
    y = plant.measure(simulate(plant.system, ag, 1 / FS))[:42]
    y = y + 0.02 * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)
    sw = n4sid(ag[:3], y, FS, orders=np.arange(20, 62, 4), f_min_hz=4.0)
    return select_modes(stabilization_diagram(sw), f_range_hz=(0.3, 21.0)), \
        plant.channel_names[:42]


def test_updating_node_publishes_parameters_and_version(domain_id: int, tmp_path: Path
                                                        ) -> None:
    import rclpy
    from modal_twin_msgs.msg import ModalModel, Mode, ModelParameters, UpdateReport
    from modal_twin_msgs.srv import RunUpdating
    from rclpy.executors import SingleThreadedExecutor

    from modal_twin.io.modal_convert import modal_model_to_msg
    from modal_twin.io.ros import qos_for
    from modal_twin.models.versions import read_version
    from modal_twin.updating.node import UpdatingNode

    truth = {"E_Fc36": 3.278e10 * 0.93, "E_Fc27": 2.915e10 * 1.07, "E_Fc21": 2.585e10 * 0.90}
    mm, names = _identified(truth)
    rclpy.init(domain_id=domain_id, args=["u", "--ros-args", "-p",
                                          f"versions_dir:={tmp_path}/models"])
    node = UpdatingNode()
    peer = rclpy.create_node("peer")
    params: list[ModelParameters] = []
    reports: list[UpdateReport] = []
    peer.create_subscription(ModelParameters, "/model/parameters", params.append,
                             qos_for("/model/parameters"))
    peer.create_subscription(UpdateReport, "/updating/report", reports.append,
                             qos_for("/updating/report"))
    pub = peer.create_publisher(ModalModel, "/identification/modes",
                                qos_for("/identification/modes"))
    ex = SingleThreadedExecutor()
    ex.add_node(node)
    ex.add_node(peer)
    try:
        cli = peer.create_client(RunUpdating, "/updating/run")
        assert cli.wait_for_service(timeout_sec=10)
        fut = cli.call_async(RunUpdating.Request())
        ex.spin_until_future_complete(fut, timeout_sec=10)
        assert not fut.result().success
        assert "no identified modes" in fut.result().message
        pub.publish(modal_model_to_msg(mm, names, ModalModel, Mode, stamp_ns=0,
                                       source="test", model_version=""))
        end = time.monotonic() + 60
        while not (params and reports) and time.monotonic() < end:
            ex.spin_once(timeout_sec=0.1)
    finally:
        ex.shutdown()
        node.destroy_node()
        peer.destroy_node()
        rclpy.try_shutdown()
    assert params and reports, "no parameters / report published"
    p = params[-1]
    got = dict(zip(p.names, p.values, strict=True))
    for k, v in truth.items():
        assert got[k] == pytest.approx(v, rel=0.02), k
    mv = read_version(p.model_file)
    assert mv.version == 1 and mv.parent == 0
    assert (tmp_path / "models" / "v0000.yaml").is_file()
    r = reports[-1]
    assert r.model_version_after == "v1" and len(r.pairs) >= 10
    after = [abs(q.model_frequency_hz_after / q.identified_frequency_hz - 1) for q in r.pairs
             if q.model_index >= 0]
    assert max(after) < 0.01
