"""Replay: republish a bag's messages with their original timing (or scaled by a rate).

A replay is a measurement: with pacing (``--paced-by /twin/residual``) the replay is
paced by its consumer, never more than ``lead`` blocks of ``/measurement/frames`` ahead of
the blocks the consumer has answered on that topic (each answer carries the sample indices
of the block it answers), so however slow the consumer (a loaded machine), no block
overflows a queue and every block is processed in order. A latched message (a channel map,
a model version) is acknowledged by its readers before the next message goes out, so it is
applied before the frames that follow it.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections import deque
from pathlib import Path
from typing import Any

import rclpy
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy

from modal_twin.errors import BagError
from modal_twin.exit_codes import ExitCode
from modal_twin.io.bag import SIGNAL_BLOCK, bag_info, read_raw
from modal_twin.io.ros import message_class, qos_for, split_ros_args, wait_for_subscribers
from modal_twin.io.typestore import typestore

__all__ = ["PACED_TOPIC", "ConsumerPacing", "MetricsWatch", "main", "replay"]

PACED_TOPIC = "/measurement/frames"
"""The topic whose blocks a consumer's answers pace."""


class ConsumerPacing:
    """Flow control of a replay by its consumer's answers (a block out per block in).

    Parameters
    ----------
    node : Node
        The replaying node (it subscribes ``topic``).
    topic : str
        SignalBlock topic on which the consumer answers each block it processed, with that
        block's sample indices (the twin's ``/twin/residual``).
    lead : int
        Blocks the replay may be ahead of the consumer's answers.
    stall_s : float
        Seconds without an answer after which the consumer is taken as not following: the
        replay goes on unpaced (said, and counted in :attr:`unanswered`).
    """

    def __init__(self, node: Node, topic: str, lead: int, stall_s: float) -> None:
        if lead < 1 or not stall_s > 0:
            msg = f"pacing: expected lead >= 1 and stall_s > 0, got {lead} and {stall_s}"
            raise BagError(msg)
        self.node, self.topic, self.lead, self.stall_s = node, topic, lead, stall_s
        self.pending: deque[int] = deque()  # next sample index of each unanswered block
        self.answered = 0
        self.stalled = False
        self._last = time.monotonic()
        self.sub = node.create_subscription(message_class(SIGNAL_BLOCK), topic, self._on_answer,
                                            qos_for(topic))

    def _on_answer(self, msg: Any) -> None:
        end = int(msg.first_sample_index) + int(msg.n_samples)
        if end not in self.pending:  # not a block of this replay (or answered already)
            return
        while self.pending:  # a block the consumer dropped is answered by the next one
            self.answered += 1
            if self.pending.popleft() == end:
                break
        self._last = time.monotonic()

    def sent(self, raw: bytes, msgtype: str) -> None:
        """Note a published block (raw CDR) as awaiting its answer."""
        blk = typestore().deserialize_cdr(raw, msgtype)
        self.pending.append(int(blk.first_sample_index) + int(blk.n_samples))

    @property
    def unanswered(self) -> int:
        """Blocks published and not (yet) answered."""
        return len(self.pending)

    def wait(self, most: int) -> None:
        """Spin until at most ``most`` blocks await an answer (or the consumer stalls)."""
        start = time.monotonic()
        while not self.stalled and len(self.pending) > most:
            if time.monotonic() - max(start, self._last) > self.stall_s:
                self.stalled = True
                self.node.get_logger().warning(
                    f"no answer on {self.topic} for {self.stall_s:.0f} s with "
                    f"{len(self.pending)} blocks unanswered: publishing on unpaced")
                return
            rclpy.spin_once(self.node, timeout_sec=0.01)

    def summary(self) -> str:
        """One line: how many blocks the consumer answered."""
        return (f"{self.answered} of {self.answered + self.unanswered} blocks answered on "
                f"{self.topic}" + (" (the consumer stalled)" if self.stalled else ""))


def _wait_readers(node: Node, pubs: dict[str, Any], subscribers: int, wait_s: float,
                  pacing: ConsumerPacing | None) -> None:
    """Wait for each topic's readers, and for the consumer's answering publisher."""
    for name, pub in pubs.items():
        if wait_s > 0 and not wait_for_subscribers(node, pub, subscribers, wait_s):
            node.get_logger().warning(f"{pub.get_subscription_count()} of {subscribers} "
                                      f"subscribers on {name}; publishing anyway")
    if pacing is not None:
        end = time.monotonic() + wait_s
        while pacing.sub.get_publisher_count() < 1 and time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.05)


def replay(
    node: Node,
    path: Path,
    *,
    rate: float = 1.0,
    topics: list[str] | None = None,
    wait_subscribers_s: float = 10.0,
    subscribers: int = 1,
    pacing: ConsumerPacing | None = None,
) -> int:
    """Publish every message of ``path`` (raw CDR) at ``rate`` x the recorded timing.

    Waits up to ``wait_subscribers_s`` for each topic to have ``subscribers`` matched
    readers first (DDS discovery takes seconds and matches readers one by one; a reader
    matched late loses the head of the stream), and for the consumer's answers when
    ``pacing`` is given. Each latched message is acknowledged by its readers before the
    next one is published; with ``pacing``, a block of :data:`PACED_TOPIC` waits until at
    most ``pacing.lead`` blocks await their answer, and the replay ends when every block
    is answered (or the consumer stalls). Returns the number of messages published.
    """
    if not (rate > 0 and math.isfinite(rate)):  # nan / inf would never (or at once) publish
        msg = f"--rate: expected a finite number > 0, got {rate}"
        raise BagError(msg)
    info = bag_info(path)
    wanted = [t for t in info.topics if topics is None or t.name in topics]
    pubs = {t.name: node.create_publisher(message_class(t.msgtype), t.name, qos_for(t.name))
            for t in wanted}
    _wait_readers(node, pubs, subscribers, wait_subscribers_s, pacing)
    latched = {name for name, pub in pubs.items()
               if pub.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL}
    ack_wait = Duration(seconds=max(wait_subscribers_s, 1.0))
    n = 0
    t0_bag: int | None = None
    t0_wall = 0.0
    for topic, mt, t_ns, raw in read_raw(path, list(pubs)):
        if t0_bag is None:
            t0_bag, t0_wall = t_ns, time.monotonic()
        due = t0_wall + (t_ns - t0_bag) / 1e9 / rate
        delay = due - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        paced = pacing if topic == PACED_TOPIC and mt == SIGNAL_BLOCK else None
        if paced is not None:
            paced.wait(paced.lead - 1)
        pubs[topic].publish(raw)
        n += 1
        if paced is not None:
            paced.sent(raw, mt)
        if topic in latched and not pubs[topic].wait_for_all_acked(ack_wait):
            node.get_logger().warning(f"{topic}: not acknowledged by every reader")
    if pacing is not None:
        pacing.wait(0)
    return n


class MetricsWatch:
    """Follow ``/twin/metrics`` of a run from this process (own context and thread).

    Parameters
    ----------
    domain_id : int
        ROS domain of the run.

    :attr:`last` is the latest message and :attr:`received` counts them; the caller
    decides from them when the comparison is complete. :meth:`close` ends the thread.
    """

    def __init__(self, domain_id: int) -> None:
        import threading

        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.signals import SignalHandlerOptions

        self.last: Any = None
        self.received = 0
        self._lock = threading.Lock()
        self._ctx = Context()
        rclpy.init(context=self._ctx, domain_id=domain_id,
                   signal_handler_options=SignalHandlerOptions.NO)
        self._node = rclpy.create_node("metrics_watch", context=self._ctx,
                                       start_parameter_services=False)
        self._node.create_subscription(message_class("modal_twin_msgs/msg/ComparisonMetrics"),
                                       "/twin/metrics", self._on_metrics,
                                       qos_for("/twin/metrics"))
        self._ex = SingleThreadedExecutor(context=self._ctx)
        self._ex.add_node(self._node)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, name="metrics_watch", daemon=True)
        self._thread.start()

    def _on_metrics(self, msg: Any) -> None:
        with self._lock:
            self.last, self.received = msg, self.received + 1

    def _spin(self) -> None:
        while not self._stop.is_set() and self._ctx.ok():
            self._ex.spin_once(timeout_sec=0.1)

    def latest(self) -> tuple[Any, int]:
        """Return the latest message (None before the first) and the count received."""
        with self._lock:
            return self.last, self.received

    def close(self) -> None:
        """Stop following (idempotent)."""
        if self._stop.is_set():
            return
        self._stop.set()
        self._thread.join(timeout=5.0)
        self._ex.shutdown()
        self._node.destroy_node()
        rclpy.try_shutdown(context=self._ctx)


def main(argv: list[str] | None = None) -> int:
    """Entry point: ``replay_node BAG [--rate R] [--topics ...]``."""
    p = argparse.ArgumentParser(prog="modal-twin replay", description=__doc__)
    p.add_argument("bag", type=Path)
    p.add_argument("--rate", type=float, default=1.0, help="speed factor (2 = twice as fast)")
    p.add_argument("--topics", nargs="*", default=None)
    p.add_argument("--wait", type=float, default=10.0, help="s to wait for subscribers")
    p.add_argument("--subscribers", type=int, default=1,
                   help="readers each topic must have before publishing starts")
    p.add_argument("--paced-by", default="", metavar="TOPIC",
                   help="pace the frames by the consumer's answers on TOPIC (e.g. "
                        "/twin/residual): every block processed, in order, at any load")
    p.add_argument("--lead", type=int, default=100,
                   help="--paced-by: blocks the replay may run ahead of the answers")
    p.add_argument("--stall", type=float, default=30.0,
                   help="--paced-by: s without an answer before publishing on unpaced")
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
        pacing = (ConsumerPacing(node, a.paced_by, a.lead, a.stall) if a.paced_by else None)
        n = replay(node, a.bag, rate=a.rate, topics=a.topics, wait_subscribers_s=a.wait,
                   subscribers=a.subscribers, pacing=pacing)
        # give reliable readers time to take the tail before the publishers go away
        end = time.monotonic() + 1.0
        while time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.05)
        print(f"replayed {n} messages of {info.message_count} from {a.bag} at rate {a.rate}"
              + (f"; {pacing.summary()}" if pacing is not None else ""))
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
