"""Excitation node: publishes the drive signal on /excitation/signal in blocks.

Services ``~/start`` (StartExcitation) and ``~/abort`` (AbortExcitation); a message on
/excitation/command starts a drive too (kind ``stop`` aborts).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np
from modal_twin_msgs.msg import ExcitationCommand
from modal_twin_msgs.msg import SignalBlock as SignalBlockMsg
from modal_twin_msgs.srv import AbortExcitation, StartExcitation
from rclpy.node import Node

from modal_twin.excitation.drive import ExcitationConfig, make_drive
from modal_twin.io.convert import block_to_msg
from modal_twin.io.params import declare_config
from modal_twin.io.ros import qos_for, run_node
from modal_twin.signal_block import SignalBlock

__all__ = ["ExcitationNode", "main"]


class ExcitationNode(Node):
    """Wiring: parameters -> drive signal -> paced blocks."""

    def __init__(self) -> None:
        super().__init__("excitation")
        self.cfg = declare_config(self, ExcitationConfig)
        self.pub = self.create_publisher(SignalBlockMsg, "/excitation/signal",
                                         qos_for("/excitation/signal"))
        self.create_subscription(ExcitationCommand, "/excitation/command", self._on_command,
                                 qos_for("/excitation/command"))
        self.create_service(StartExcitation, "~/start", self._on_start)
        self.create_service(AbortExcitation, "~/abort", self._on_abort)
        self.drive: np.ndarray | None = None
        self.next_sample = 0
        self.stream_index = 0
        self.t0_wall = 0.0
        self.t0_ns = 0
        self.waiting_since = time.monotonic()
        period = self.cfg.block_size / self.cfg.fs_hz
        self.timer = self.create_timer(min(period, 0.05), self._tick)
        if self.cfg.autostart:
            self._start(self.cfg)

    def _start(self, cfg: ExcitationConfig) -> None:
        self.cfg = cfg
        self.drive = make_drive(cfg)
        self.next_sample = 0
        self.t0_wall = 0.0  # set when the first block goes out
        self.waiting_since = time.monotonic()
        self.get_logger().info(
            f"drive {cfg.kind}: {self.drive.shape[0]} channels x {self.drive.shape[1]} "
            f"samples at {cfg.fs_hz} Hz"
        )

    def _tick(self) -> None:
        if self.drive is None:
            return
        cfg = self.cfg
        if self.t0_wall == 0.0:
            ready = self.pub.get_subscription_count() >= cfg.wait_subscribers
            if not ready and time.monotonic() - self.waiting_since < 15.0:
                return
            self.t0_wall = time.monotonic()
            self.t0_ns = time.time_ns()
        n_total = self.drive.shape[1]
        elapsed = time.monotonic() - self.t0_wall
        due = n_total if cfg.rate <= 0 else min(n_total, int(elapsed * cfg.fs_hz * cfg.rate)
                                                + cfg.block_size)
        while self.next_sample + cfg.block_size <= due or (
            due == n_total and self.next_sample < n_total
        ):
            i0 = self.next_sample
            i1 = min(i0 + cfg.block_size, n_total)
            block = SignalBlock(
                tuple(cfg.channels), cfg.fs_hz, self.stream_index, self.drive[:, i0:i1],
                stamp_ns=self.t0_ns + round(i0 / cfg.fs_hz * 1e9), source="excitation",
            )
            self.pub.publish(block_to_msg(block, SignalBlockMsg))
            self.next_sample = i1
            self.stream_index += i1 - i0
        if self.next_sample >= n_total:
            self.get_logger().info(f"drive finished: {n_total} samples published")
            self.drive = None

    def _on_command(self, msg: ExcitationCommand) -> None:
        error = self._command(msg)
        if error:
            self.get_logger().error(f"excitation command refused: {error}")

    def _command(self, msg: ExcitationCommand) -> str:
        """Apply a command; returns '' or the reason it was refused."""
        if msg.kind == "stop":
            self.drive = None
            return ""
        fields = {"kind": msg.kind}
        if msg.channels:
            fields["channels"] = tuple(msg.channels)
        for name, value in (("duration_s", msg.duration_s), ("fs_hz", msg.sample_rate_hz),
                            ("f_min_hz", msg.f_min_hz), ("f_max_hz", msg.f_max_hz)):
            if value > 0:
                fields[name] = value
        if msg.amplitude > 0:
            fields["rms"] = (msg.amplitude,)
        if msg.record_path:
            fields["record_path"] = msg.record_path
            fields["record_scale"] = msg.record_scale or 1.0
        if msg.seed:
            fields["seed"] = int(msg.seed)
        try:
            self._start(dataclasses.replace(self.cfg, **fields))
        except (ValueError, OSError) as err:
            return str(err)
        return ""

    def _on_start(self, req: StartExcitation.Request,
                  res: StartExcitation.Response) -> StartExcitation.Response:
        error = self._command(req.command)
        res.accepted = not error
        res.message = error or f"started {req.command.kind}"
        return res

    def _on_abort(self, req: AbortExcitation.Request,
                  res: AbortExcitation.Response) -> AbortExcitation.Response:
        was = self.drive is not None
        self.drive = None
        res.accepted, res.message = was, "aborted" if was else "nothing was running"
        return res


def main() -> int:
    """Entry point of ``excitation_node``."""
    return run_node(ExcitationNode)


if __name__ == "__main__":
    import sys

    sys.exit(main())
