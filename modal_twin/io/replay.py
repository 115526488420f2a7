"""Replay: republish a bag's messages with their original timing (or scaled by a rate)."""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import rclpy
from rclpy.node import Node

from modal_twin.errors import BagError
from modal_twin.exit_codes import ExitCode
from modal_twin.io.bag import bag_info, read_raw
from modal_twin.io.ros import message_class, qos_for, split_ros_args, wait_for_subscribers

__all__ = ["main", "replay"]


def replay(
    node: Node,
    path: Path,
    *,
    rate: float = 1.0,
    topics: list[str] | None = None,
    wait_subscribers_s: float = 10.0,
    subscribers: int = 1,
) -> int:
    """Publish every message of ``path`` (raw CDR) at ``rate`` x the recorded timing.

    Waits up to ``wait_subscribers_s`` for each topic to have ``subscribers`` matched
    readers first (DDS discovery takes seconds and matches readers one by one; a reader
    matched late loses the head of the stream). Returns the number of messages published.
    """
    if not (rate > 0 and math.isfinite(rate)):  # nan / inf would never (or at once) publish
        msg = f"--rate: expected a finite number > 0, got {rate}"
        raise BagError(msg)
    info = bag_info(path)
    wanted = [t for t in info.topics if topics is None or t.name in topics]
    pubs = {t.name: node.create_publisher(message_class(t.msgtype), t.name, qos_for(t.name))
            for t in wanted}
    for name, pub in pubs.items():
        if wait_subscribers_s > 0 and not wait_for_subscribers(node, pub, subscribers,
                                                                wait_subscribers_s):
            node.get_logger().warning(f"{pub.get_subscription_count()} of {subscribers} "
                                      f"subscribers on {name}; publishing anyway")
    n = 0
    t0_bag: int | None = None
    t0_wall = 0.0
    for topic, _mt, t_ns, raw in read_raw(path, list(pubs)):
        if t0_bag is None:
            t0_bag, t0_wall = t_ns, time.monotonic()
        due = t0_wall + (t_ns - t0_bag) / 1e9 / rate
        delay = due - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        pubs[topic].publish(raw)
        n += 1
    return n


def main(argv: list[str] | None = None) -> int:
    """Entry point: ``replay_node BAG [--rate R] [--topics ...]``."""
    p = argparse.ArgumentParser(prog="modal-twin replay", description=__doc__)
    p.add_argument("bag", type=Path)
    p.add_argument("--rate", type=float, default=1.0, help="speed factor (2 = twice as fast)")
    p.add_argument("--topics", nargs="*", default=None)
    p.add_argument("--wait", type=float, default=10.0, help="s to wait for subscribers")
    p.add_argument("--subscribers", type=int, default=1,
                   help="readers each topic must have before publishing starts")
    own, ros_args = split_ros_args(sys.argv[1:] if argv is None else argv)
    a = p.parse_args(own)
    try:
        info = bag_info(a.bag)
    except BagError as err:
        print(f"modal-twin replay: {err}", file=sys.stderr)
        return ExitCode.USAGE
    rclpy.init(args=["replay", *ros_args])
    node = rclpy.create_node("replay")
    try:
        n = replay(node, a.bag, rate=a.rate, topics=a.topics, wait_subscribers_s=a.wait,
                   subscribers=a.subscribers)
        # give reliable readers time to take the tail before the publishers go away
        end = time.monotonic() + 1.0
        while time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.05)
        print(f"replayed {n} messages of {info.message_count} from {a.bag} at rate {a.rate}")
    except KeyboardInterrupt:
        return ExitCode.INTERRUPTED
    except BagError as err:
        print(f"modal-twin replay: {err}", file=sys.stderr)
        return ExitCode.USAGE
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return ExitCode.OK


if __name__ == "__main__":
    sys.exit(main())
