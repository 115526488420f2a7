"""Identification node on a replayed bag of simulated frames (item 5 of issue 4)."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.signal as sig

from modal_twin.identification.metrics import mac
from modal_twin.io.bag import BagWriter
from modal_twin.io.convert import block_to_rosbags
from modal_twin.io.typestore import typestore
from modal_twin.signal_block import SignalBlock

pytestmark = pytest.mark.ros
SB = "modal_twin_msgs/msg/SignalBlock"
ROOT = Path(__file__).resolve().parents[2]


def _chain(n: int = 4, zeta: float = 0.02) -> tuple:
    """Fixed-free spring-mass chain, modal damping: (A, B, C, D) for base forces, truth."""
    k = np.linspace(1.0, 0.6, n) * 1e3
    K = np.diag(k + np.r_[k[1:], 0.0]) - np.diag(k[1:], 1) - np.diag(k[1:], -1)
    w2, Phi = sla.eigh(K)
    w = np.sqrt(w2)
    C = Phi @ np.diag(2 * zeta * w) @ Phi.T
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-K, -C]])
    Bf = np.eye(n)[:, [0, n - 1]]
    B = np.vstack([np.zeros_like(Bf), Bf])
    return (A, B, A[n:], Bf), w / (2 * np.pi), Phi


def _frames(fs: float, n: int, bs: int) -> tuple[list[SignalBlock], np.ndarray, np.ndarray]:
    (A, B, C, D), f, Phi = _chain()
    rng = np.random.default_rng(7)
    u = rng.standard_normal((2, n))
    sysd = sig.cont2discrete((A, B, C, D), 1 / fs)
    _, y, _ = sig.dlsim(sig.dlti(*sysd[:4], dt=1 / fs), u.T)
    y = y.T + 0.1 * rng.standard_normal(y.T.shape) * y.std()  # 20 dB
    data = np.vstack([u, y])
    names = ("table_x", "table_y", "a1", "a2", "a3", "a4")
    blocks = [SignalBlock(names, fs, i, data[:, i : i + bs], stamp_ns=10**18 + round(i / fs * 1e9),
                          source="sim") for i in range(0, n, bs)]
    return blocks, f, Phi


class Harness:
    """The node plus a client and a modes subscriber in one Context on the test's domain."""

    def __init__(self, domain_id: int) -> None:
        import rclpy
        from modal_twin_msgs.msg import ModalModel as ModalModelMsg
        from modal_twin_msgs.msg import StabilizationDiagram as DiagramMsg
        from modal_twin_msgs.srv import RunIdentification
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor

        from modal_twin.identification.node import IdentificationNode
        from modal_twin.io.ros import qos_for

        self.ctx = Context()
        rclpy.init(context=self.ctx, domain_id=domain_id)
        self.node = IdentificationNode(context=self.ctx)
        self.client_node = rclpy.create_node("ident_client", context=self.ctx)
        self.modes: list = []
        self.diagrams: list = []
        self.client_node.create_subscription(ModalModelMsg, "/identification/modes",
                                             self.modes.append, qos_for("/identification/modes"))
        self.client_node.create_subscription(DiagramMsg, "/identification/stabilization",
                                             self.diagrams.append,
                                             qos_for("/identification/stabilization"))
        self.cli = self.client_node.create_client(RunIdentification, "/identification/run")
        self.Req = RunIdentification.Request
        self.ex = SingleThreadedExecutor(context=self.ctx)
        self.ex.add_node(self.node)
        self.ex.add_node(self.client_node)

    def spin_until(self, cond, timeout_s: float) -> bool:  # type: ignore[no-untyped-def]
        end = time.monotonic() + timeout_s
        while not cond() and time.monotonic() < end:
            self.ex.spin_once(timeout_sec=0.02)
        return bool(cond())

    def call(self, **fields: object):  # type: ignore[no-untyped-def]
        req = self.Req()
        for k, v in fields.items():
            setattr(req, k, v)
        assert self.spin_until(lambda: self.cli.service_is_ready(), 10.0)
        fut = self.cli.call_async(req)
        assert self.spin_until(fut.done, 60.0)
        return fut.result()

    def close(self) -> None:
        import rclpy

        self.ex.shutdown()
        self.client_node.destroy_node()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.ctx)


def test_node_identifies_modes_from_a_replayed_bag(tmp_path: Path, domain_id: int) -> None:
    fs, n, bs = 40.0, 8000, 200
    blocks, f_true, Phi = _frames(fs, n, bs)
    bag = tmp_path / "frames"
    st = typestore()
    with BagWriter(bag, {"/measurement/frames": SB}) as w:  # type: ignore[arg-type]
        for b in blocks:
            raw = st.serialize_cdr(block_to_rosbags(b, st), SB)
            w.write("/measurement/frames", b.stamp_ns, raw)
    h = Harness(domain_id)
    try:
        # nothing buffered yet: a clear refusal, not a crash
        res = h.call(method="n4sid", max_order=0, window_s=0.0)
        assert not res.success
        assert "no frames received yet" in res.message
        proc = subprocess.Popen(
            [sys.executable, "-m", "modal_twin.cli", "replay", str(bag), "--rate", "40",
             "--wait", "15"],
            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        try:
            got_all = h.spin_until(lambda: h.node.window.n_received >= n, 60.0)
        finally:
            out = proc.communicate(timeout=30)[0]
        assert got_all, f"received {h.node.window.n_received} of {n} samples; replay said: {out}"
        assert h.node.window.n_samples == 4800  # window_s = 120 s at 40 Hz
        res = h.call(method="n4sid", max_order=24, window_s=0.0)
        assert res.success, res.message
        m = res.model
        f = np.array([md.frequency_hz for md in m.modes])
        assert list(m.channel_names) == ["a1", "a2", "a3", "a4"]
        assert m.method == "n4sid"
        np.testing.assert_allclose(f, f_true, rtol=0.01)
        shapes = np.array([np.array(md.shape_real) + 1j * np.array(md.shape_imag)
                           for md in m.modes]).T
        assert np.diag(mac(shapes, Phi)).min() > 0.98
        assert all(md.std_frequency_hz > 0 and 0.9 < md.mpc <= 1.0 + 1e-9 for md in m.modes)
        assert h.spin_until(lambda: h.modes and h.diagrams, 10.0)
        np.testing.assert_allclose([md.frequency_hz for md in h.modes[-1].modes], f)
        dg = h.diagrams[-1]
        assert len(dg.order) == len(dg.frequency_hz) == len(dg.stability) > 0
        assert max(dg.stability) == 3
        # output-only SSI-cov on the same buffer agrees with N4SID
        res2 = h.call(method="ssi-cov", max_order=24, window_s=0.0)
        assert res2.success, res2.message
        f2 = np.array([md.frequency_hz for md in res2.model.modes])
        assert all(np.min(np.abs(f2 - x)) / x < 0.01 for x in f_true)
        # bad requests: answered with the reason, the node keeps running
        bad = h.call(method="bogus", max_order=0, window_s=0.0)
        assert not bad.success
        assert "method: expected one of" in bad.message
        short = h.call(method="n4sid", max_order=24, window_s=1.0)
        assert not short.success
        assert "expected at least" in short.message
        ok = h.call(method="", max_order=0, window_s=0.0)  # defaults still work afterwards
        assert ok.success
    finally:
        h.close()


def test_parameters_are_read_only_at_run_time(domain_id: int) -> None:
    from rclpy.parameter import Parameter

    h = Harness(domain_id)
    try:
        res = h.node.set_parameters([Parameter("max_order", value=10)])
        assert not res[0].successful and "read-only" in res[0].reason
        assert h.node.get_parameter("max_order").value == 0  # from the record
        bad = h.call(method="", max_order=4294967295, window_s=0.0)
        assert not bad.success
        assert "max_order: expected an integer in [0, 400]" in bad.message
        bad = h.call(method="", max_order=0, window_s=float("inf"))
        assert not bad.success and "window_s" in bad.message
    finally:
        h.close()
