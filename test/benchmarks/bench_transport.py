"""Transport benchmark: 64 channels at 2 kHz in blocks between two processes, recorded.

A publisher process streams 64-channel blocks (100 samples, 20 blocks/s) for
``--duration`` seconds; this process subscribes and measures latency (receive time minus
the block's stamp, which the publisher sets at publish time) while a recorder process
writes the same topic to an MCAP bag. Afterwards the bag is read back to count what the
recorder kept, and its write path is timed on the recorded messages in this process
(recorder throughput as a multiple of real time).

usage: python test/benchmarks/bench_transport.py [--duration 60]
Last line: JSON with blocks_lost, latency_p50_ms, latency_p99_ms, recorder_x_realtime.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

TOPIC = "/rig/raw"
N_CH, FS, BS = 64, 2000.0, 100


def publisher(duration: float) -> int:
    import rclpy
    from modal_twin_msgs.msg import SignalBlock as Msg

    from modal_twin.io.convert import block_to_msg
    from modal_twin.io.ros import qos_for, wait_for_subscribers
    from modal_twin.signal_block import SignalBlock

    rclpy.init()
    node = rclpy.create_node("bench_pub")
    pub = node.create_publisher(Msg, TOPIC, qos_for(TOPIC))
    if not wait_for_subscribers(node, pub, 2, 30.0):
        print("publisher: readers not matched", file=sys.stderr)
        return 3
    rng = np.random.default_rng(0)
    data = rng.normal(size=(N_CH, BS))
    names = tuple(f"a{c:02d}" for c in range(N_CH))
    n = int(duration * FS / BS)
    t0 = time.monotonic()
    for k in range(n):
        due = t0 + k * BS / FS
        while (d := due - time.monotonic()) > 0:
            time.sleep(min(d, 0.002))
        blk = SignalBlock(names, FS, k * BS, data, stamp_ns=time.time_ns(), source="bench")
        pub.publish(block_to_msg(blk, Msg))
    print(n, flush=True)
    end = time.monotonic() + 3.0
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--publisher", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.publisher:
        return publisher(a.duration)
    os.environ.setdefault("ROS_DOMAIN_ID", str(random.randint(101, 150) % 101 + 1))
    import rclpy
    from modal_twin_msgs.msg import SignalBlock as Msg

    from modal_twin.io.bag import BagWriter, bag_info, read_raw
    from modal_twin.io.convert import stamp_to_ns
    from modal_twin.io.ros import qos_for

    tmp = Path(tempfile.mkdtemp(prefix="bench_transport_"))
    bag = tmp / "bag"
    rec = subprocess.Popen([sys.executable, "-m", "modal_twin.cli", "record", "-o", str(bag),
                            TOPIC], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    rclpy.init()
    node = rclpy.create_node("bench_sub")
    lat_ms: list[float] = []
    idx: list[int] = []

    def cb(m: Msg) -> None:
        lat_ms.append((time.time_ns() - stamp_to_ns(m.header.stamp)) / 1e6)
        idx.append(m.first_sample_index)

    node.create_subscription(Msg, TOPIC, cb, qos_for(TOPIC))
    pub = subprocess.Popen([sys.executable, __file__, "--publisher", "--duration",
                            str(a.duration)], stdout=subprocess.PIPE, text=True)
    while pub.poll() is None:
        rclpy.spin_once(node, timeout_sec=0.05)
    out = pub.stdout.read() if pub.stdout else ""
    end = time.monotonic() + 1.0
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    node.destroy_node()
    rclpy.try_shutdown()
    rec.send_signal(signal.SIGINT)
    rec.wait(30)
    sent = int(out.strip() or 0)
    info = bag_info(bag)
    recorded = info.message_count
    raw = [(t, r) for _, _, t, r in read_raw(bag)]
    t0 = time.perf_counter()
    with BagWriter(tmp / "rewrite", {TOPIC: "modal_twin_msgs/msg/SignalBlock"}) as w:
        for t_ns, r in raw:
            w.write(TOPIC, t_ns, r)
    write_s = time.perf_counter() - t0
    lat = np.array(lat_ms) if lat_ms else np.array([np.nan])
    in_order = bool(np.all(np.diff(idx) > 0)) if idx else False
    figures = {
        "duration_s": a.duration,
        "blocks_sent": sent,
        "blocks_lost": sent - len(idx),
        "blocks_lost_recorder": sent - recorded,
        "in_order": in_order,
        "latency_p50_ms": round(float(np.percentile(lat, 50)), 3),
        "latency_p99_ms": round(float(np.percentile(lat, 99)), 3),
        "recorder_x_realtime": round(a.duration / write_s, 1) if write_s > 0 else None,
        "samples_per_s": N_CH * FS,
    }
    print(f"sent {sent} blocks of {N_CH} ch x {BS} samples at {FS:.0f} Hz for {a.duration} s")
    print(f"subscriber got {len(idx)} (lost {figures['blocks_lost']}, in order {in_order}); "
          f"recorder kept {recorded}")
    print(f"latency p50 {figures['latency_p50_ms']} ms, p99 {figures['latency_p99_ms']} ms")
    print(f"recorder write path {figures['recorder_x_realtime']}x real time")
    print(json.dumps(figures))
    return 0


if __name__ == "__main__":
    sys.exit(main())
