"""Live transport between processes: rclpy round trip, record, replay, crash salvage."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.ros

HERE = Path(__file__).resolve().parent
PY = sys.executable
TOPIC = "/rig/raw"


def _modal_twin(*args: str) -> list[str]:
    return [PY, "-m", "modal_twin.cli", *args]


class Listener:
    """A subscriber in its own Context on the test's domain."""

    def __init__(self, domain_id: int, topic: str = TOPIC) -> None:
        import rclpy
        from modal_twin_msgs.msg import SignalBlock as Msg
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor

        from modal_twin.io.ros import qos_for

        self.ctx = Context()
        rclpy.init(context=self.ctx, domain_id=domain_id)
        self.node = rclpy.create_node("listener", context=self.ctx)
        self.got: list[tuple[int, object]] = []
        self.node.create_subscription(
            Msg, topic, lambda m: self.got.append((time.monotonic_ns(), m)), qos_for(topic))
        self.ex = SingleThreadedExecutor(context=self.ctx)
        self.ex.add_node(self.node)

    def spin_until(self, n: int, timeout_s: float) -> None:
        end = time.monotonic() + timeout_s
        while len(self.got) < n and time.monotonic() < end:
            self.ex.spin_once(timeout_sec=0.01)

    def close(self) -> None:
        import rclpy

        self.ex.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.ctx)


def _expected(k: int, bs: int, n_ch: int, fs: float):  # type: ignore[no-untyped-def]
    sys.path.insert(0, str(HERE))
    from pub_blocks import expected_block

    return expected_block(k, bs, n_ch, fs)


def test_signal_blocks_round_trip_between_processes(domain_id: int) -> None:
    from modal_twin.io.convert import block_from_msg

    lis = Listener(domain_id)
    try:
        pub = subprocess.Popen([PY, str(HERE / "pub_blocks.py"), TOPIC, "20", "10", "3", "50"],
                               stdout=subprocess.PIPE, text=True)
        lis.spin_until(20, 30.0)
        pub.wait(30)
    finally:
        lis.close()
    assert len(lis.got) == 20
    for k, (_, msg) in enumerate(lis.got):
        got, want = block_from_msg(msg), _expected(k, 10, 3, 500.0)
        assert got.channel_names == want.channel_names
        assert got.first_index == want.first_index
        assert got.stamp_ns == want.stamp_ns
        assert got.fs_hz == want.fs_hz
        np.testing.assert_array_equal(got.data, want.data)


def _record(bag: Path, *topics: str) -> subprocess.Popen[bytes]:
    return subprocess.Popen(_modal_twin("record", "-o", str(bag), *topics),
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def test_record_then_read_back_exactly(domain_id: int, tmp_path: Path) -> None:
    from modal_twin.io.bag import read_blocks

    rec = _record(tmp_path / "bag", TOPIC)
    pub = subprocess.run([PY, str(HERE / "pub_blocks.py"), TOPIC, "200", "20", "8", "100"],
                         capture_output=True, text=True, timeout=60)
    assert "ready" in pub.stdout
    rec.send_signal(signal.SIGINT)
    assert rec.wait(20) == 0
    blocks = read_blocks(tmp_path / "bag", TOPIC)
    assert len(blocks) == 200
    for k, b in enumerate(blocks):
        want = _expected(k, 20, 8, 2000.0)
        assert (b.first_index, b.stamp_ns, b.channel_names) == (
            want.first_index, want.stamp_ns, want.channel_names)
        np.testing.assert_array_equal(b.data, want.data)


def test_replay_in_order_with_original_timing(domain_id: int, tmp_path: Path) -> None:
    from modal_twin.io.bag import BagWriter, read_raw
    from modal_twin.io.convert import block_from_msg, block_to_rosbags
    from modal_twin.io.typestore import typestore

    st = typestore()
    sb = "modal_twin_msgs/msg/SignalBlock"
    rng = np.random.default_rng(0)
    t_bag = np.cumsum(rng.uniform(0.005, 0.040, size=120))  # irregular spacing, s
    with BagWriter(tmp_path / "bag", {TOPIC: sb}) as w:
        for k, t in enumerate(t_bag):
            blk = _expected(k, 10, 2, 1000.0)
            w.write(TOPIC, int(1e18 + t * 1e9), st.serialize_cdr(block_to_rosbags(blk, st), sb))
    lis = Listener(domain_id)
    try:
        rep = subprocess.Popen(_modal_twin("replay", str(tmp_path / "bag"), "--rate", "1"),
                               stdout=subprocess.PIPE, text=True)
        lis.spin_until(120, 40.0)
        rep.wait(30)
    finally:
        lis.close()
    assert [block_from_msg(m).first_index for _, m in lis.got] == [k * 10 for k in range(120)]
    t_recv = np.array([t for t, _ in lis.got]) / 1e9
    t_rec = np.array([t for _, _, t, _ in read_raw(tmp_path / "bag")]) / 1e9
    err_ms = 1e3 * ((t_recv - t_recv[0]) - (t_rec - t_rec[0]))
    # goal: < 5 ms; judged on the 99th percentile, as the receive side shares 2 cores
    p99 = float(np.percentile(np.abs(err_ms), 99))
    print(f"replay timing error: p50 {np.median(np.abs(err_ms)):.2f} ms, p99 {p99:.2f} ms, "
          f"max {np.max(np.abs(err_ms)):.2f} ms")
    assert p99 < 5.0, f"timing error p99 {p99:.2f} ms (max {np.max(np.abs(err_ms)):.2f} ms)"


@pytest.mark.slow
def test_sigkill_recorder_loses_at_most_one_second(domain_id: int, tmp_path: Path) -> None:
    from modal_twin.io.bag import read_blocks, salvage

    rec = _record(tmp_path / "bag", TOPIC)
    # 1 kHz stream in blocks of 10 samples: 100 blocks/s for up to 20 s
    pub = subprocess.Popen([PY, str(HERE / "pub_blocks.py"), TOPIC, "2000", "10", "4", "100"],
                           stdout=subprocess.PIPE, text=True)
    assert pub.stdout is not None
    assert pub.stdout.readline().strip() == "ready"
    time.sleep(10.0)
    os.kill(rec.pid, signal.SIGKILL)
    killed_at = time.time_ns()
    rec.wait(5)
    last_sent = -1
    for line in pub.stdout:
        k, t_ns = map(int, line.split()[1:3])
        if t_ns > killed_at:
            break
        last_sent = k
    pub.kill()
    pub.wait(5)
    info = salvage(tmp_path / "bag")
    blocks = read_blocks(info.path, TOPIC)
    assert [b.first_index for b in blocks] == [k * 10 for k in range(len(blocks))]
    lost_s = (last_sent + 1 - len(blocks)) / 100.0
    print(f"SIGKILL after 10 s at 1 kHz: {len(blocks)} of {last_sent + 1} blocks kept, "
          f"{lost_s:.2f} s lost")
    assert last_sent > 900
    assert lost_s <= 1.0, f"lost {lost_s:.2f} s of data"
