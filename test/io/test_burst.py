"""A burst of 10,000 blocks reaches a busy subscriber and the recorder whole."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.ros


def test_burst_of_10000_blocks_is_delivered_and_recorded(domain_id: int, tmp_path: Path) -> None:
    import rclpy
    from modal_twin_msgs.msg import SignalBlock as Msg
    from rclpy.context import Context
    from rclpy.duration import Duration
    from rclpy.executors import SingleThreadedExecutor

    from modal_twin.io.bag import read_blocks
    from modal_twin.io.convert import block_to_msg
    from modal_twin.io.ros import qos_for  # sets the Fast DDS profile before rclpy.init
    from modal_twin.signal_block import SignalBlock

    n, topic = 10_000, "/rig/raw"
    rec = subprocess.Popen([sys.executable, "-m", "modal_twin.cli", "record", "-o",
                            str(tmp_path / "bag"), topic], stdout=subprocess.DEVNULL)
    ctx = Context()
    rclpy.init(context=ctx, domain_id=domain_id)
    node = rclpy.create_node("burst", context=ctx)
    got: list[int] = []
    node.create_subscription(Msg, topic, lambda m: got.append(m.first_sample_index),
                             qos_for(topic))
    pub = node.create_publisher(Msg, topic, qos_for(topic))
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    try:
        end = time.monotonic() + 60.0
        while pub.get_subscription_count() < 2:
            assert time.monotonic() < end, "recorder never matched"
            ex.spin_once(timeout_sec=0.05)
        names = ("a", "b", "c", "d", "e", "f")
        for k in range(n):  # back to back while this reader does not take anything
            pub.publish(block_to_msg(SignalBlock(names, 1000.0, 50 * k,
                                                 np.full((6, 50), float(k))), Msg))
        end = time.monotonic() + 300.0
        while len(got) < n and time.monotonic() < end:
            ex.spin_once(timeout_sec=0.05)
        assert pub.wait_for_all_acked(Duration(seconds=120))
    finally:
        time.sleep(1.0)
        rec.send_signal(signal.SIGINT)
        rec.wait(120)
        ex.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)
    assert got == [50 * k for k in range(n)]
    assert [b.first_index for b in read_blocks(tmp_path / "bag", topic)] == got
