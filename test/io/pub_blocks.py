"""Helper process for tests: publish N SignalBlocks with known content, then linger.

usage: python pub_blocks.py TOPIC N_BLOCKS BLOCK_SIZE N_CHANNELS RATE_HZ [WAIT_SUBS]
Block k holds data = k * 1000 + arange(n_ch * block_size) (exactly representable), and
prints "published <k> <t_ns>" lines for the test to read.
"""

from __future__ import annotations

import sys
import time

import numpy as np
import rclpy
from modal_twin_msgs.msg import SignalBlock as SignalBlockMsg

from modal_twin.io.convert import block_to_msg
from modal_twin.io.ros import qos_for, wait_for_subscribers
from modal_twin.signal_block import SignalBlock


def expected_block(k: int, block_size: int, n_ch: int, fs: float) -> SignalBlock:
    data = (k * 1000.0 + np.arange(n_ch * block_size, dtype=float)).reshape(n_ch, block_size)
    return SignalBlock(tuple(f"ch{c:02d}" for c in range(n_ch)), fs, k * block_size, data,
                       stamp_ns=1_700_000_000_000_000_000 + k * 10_000_000, source="test")


def main() -> int:
    topic, n, bs, n_ch, rate = sys.argv[1], *map(int, sys.argv[2:5]), float(sys.argv[5])
    wait_subs = int(sys.argv[6]) if len(sys.argv) > 6 else 1
    rclpy.init()
    node = rclpy.create_node("pub_blocks")
    pub = node.create_publisher(SignalBlockMsg, topic, qos_for(topic))
    if not wait_for_subscribers(node, pub, wait_subs, 20.0):
        print("no subscriber", flush=True)
        return 3
    print("ready", flush=True)
    t0 = time.monotonic()
    for k in range(n):
        due = t0 + k / rate
        while time.monotonic() < due:
            time.sleep(min(0.001, max(0.0, due - time.monotonic())))
        pub.publish(block_to_msg(expected_block(k, bs, n_ch, bs * rate), SignalBlockMsg))
        print(f"published {k} {time.time_ns()}", flush=True)
    end = time.monotonic() + 2.0
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
