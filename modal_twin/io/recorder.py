"""Recorder node: writes chosen topics to a rosbag2 MCAP bag, raw CDR, bounded crash loss."""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from pathlib import Path

import rclpy.logging
from rclpy.node import Node

from modal_twin.errors import BagError
from modal_twin.io.bag import BagWriter
from modal_twin.io.ros import message_class, qos_for, run_node, split_ros_args
from modal_twin.io.topics import TOPICS
from modal_twin.io.typestore import known_types
from modal_twin.paths import private_files

__all__ = ["RecorderNode", "main", "resolve_topics"]


def resolve_topics(specs: list[str]) -> dict[str, str]:
    """``/topic`` or ``/topic:pkg/msg/Type`` -> {topic: type}.

    Raises
    ------
    BagError
        For a topic outside the node graph given without a type, or an unknown type; the
        message lists the known topics / types.
    """
    out: dict[str, str] = {}
    for spec in specs:
        topic, _, msgtype = spec.partition(":")
        if not msgtype:
            if topic not in TOPICS:
                msg = (
                    f"unknown topic {topic!r}: give its type as {topic}:pkg/msg/Type, or "
                    f"choose from {sorted(TOPICS)}"
                )
                raise BagError(msg)
            msgtype = TOPICS[topic].msgtype
        if msgtype not in known_types():
            msg = f"unknown message type {msgtype!r} for {topic}; known: {known_types()}"
            raise BagError(msg)
        out[topic] = msgtype
    if not out:
        msg = f"no topics to record; choose from {sorted(TOPICS)}"
        raise BagError(msg)
    return out


class RecorderNode(Node):
    """Subscribe raw (serialized) to each topic and append it to the bag."""

    def __init__(
        self,
        path: Path,
        topics: dict[str, str],
        *,
        flush_period_s: float = 0.5,
        rotate_s: float | None = None,
        rotate_bytes: int | None = None,
    ) -> None:
        super().__init__("recorder")
        self.writer = BagWriter(
            path, topics, flush_period_s=flush_period_s, rotate_s=rotate_s,
            rotate_bytes=rotate_bytes,
        )
        self._subs = [
            self.create_subscription(
                message_class(mt), topic, self._callback(topic), qos_for(topic), raw=True
            )
            for topic, mt in topics.items()
        ]
        self.path = path
        self.exit_code = 0
        self.closed = False
        self.create_timer(0.25, self._flush)  # a quiet stream's tail too
        self.get_logger().info(f"recording {sorted(topics)} to {path}")

    def _callback(self, topic: str) -> Callable[[bytes], None]:
        def cb(raw: bytes) -> None:
            if self.closed:
                return
            try:
                self.writer.write(topic, time.time_ns(), raw)
            except OSError as err:  # disk full, device gone: stop cleanly, say it once
                self._stop(err)

        return cb

    def _flush(self) -> None:
        if self.closed:
            return
        try:
            self.writer.flush_if_due()
        except OSError as err:
            self._stop(err)

    def _stop(self, err: OSError) -> None:
        """Close the bag after a write error, log one line, and end the node (exit 1)."""
        self.closed, self.exit_code = True, 1
        try:
            self.writer.close()
            state = "closed"
        except OSError:
            state = f"left without its index: run `modal-twin bag salvage {self.path}`"
        total = sum(self.writer.counts.values())
        self.get_logger().error(f"recording stopped: {err.strerror or err} writing {self.path}; "
                                f"bag {state} with {total} messages")
        self.context.try_shutdown()

    def close(self) -> None:
        """Finish the bag (summary and metadata.yaml)."""
        if self.closed:
            return
        self.closed = True
        self.writer.close()
        rclpy.logging.get_logger(self.get_name()).info(f"bag closed: {self.writer.counts}")


def main(argv: list[str] | None = None) -> int:
    """Entry point: ``recorder_node -o BAG /topic [/topic:pkg/msg/Type ...]``."""
    private_files()  # the bag is private to its user (README: file modes)
    p = argparse.ArgumentParser(prog="modal-twin record", description=__doc__)
    p.add_argument("topics", nargs="+", help="topics, optionally /topic:pkg/msg/Type")
    p.add_argument("-o", "--output", required=True, type=Path, help="bag folder to create")
    p.add_argument("--flush-period", type=float, default=0.5, help="s between flushes")
    p.add_argument("--rotate-s", type=float, default=None, help="start a new part every N s")
    p.add_argument("--rotate-mb", type=float, default=None, help="new part every N MB")
    own, ros_args = split_ros_args(sys.argv[1:] if argv is None else argv)
    a = p.parse_args(own)
    try:
        topics = resolve_topics(a.topics)
    except BagError as err:
        print(f"modal-twin record: {err}", file=sys.stderr)
        return 2
    rotate_bytes = int(a.rotate_mb * 1e6) if a.rotate_mb else None
    return run_node(
        lambda: RecorderNode(
            a.output, topics, flush_period_s=a.flush_period, rotate_s=a.rotate_s,
            rotate_bytes=rotate_bytes,
        ),
        ["recorder", *ros_args],
    )


if __name__ == "__main__":
    sys.exit(main())
