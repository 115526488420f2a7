"""Excitation node: publishes the drive signal on /excitation/signal in blocks.

Services ``~/start`` (StartExcitation) and ``~/abort`` (AbortExcitation); a message on
/excitation/command starts a drive too (kind ``stop`` aborts). A refused command leaves
the running drive and the settings as they were.
"""

from __future__ import annotations

import time

from modal_twin_msgs.msg import ExcitationCommand
from modal_twin_msgs.msg import SignalBlock as SignalBlockMsg
from modal_twin_msgs.srv import AbortExcitation, StartExcitation
from rclpy.node import Node

from modal_twin.excitation.drive import ExcitationConfig, make_drive
from modal_twin.excitation.player import DrivePlayer
from modal_twin.io.command_convert import config_from_command
from modal_twin.io.convert import block_to_msg
from modal_twin.io.params import declare_config
from modal_twin.io.ros import guarded, guarded_service, qos_for, run_node
from modal_twin.paths import request_roots

__all__ = ["ExcitationNode", "main"]


class ExcitationNode(Node):
    """Wiring: command -> configuration -> drive -> paced blocks."""

    def __init__(self) -> None:
        super().__init__("excitation")
        self.cfg = declare_config(self, ExcitationConfig)
        self.record_roots = request_roots()
        self.pub = self.create_publisher(SignalBlockMsg, "/excitation/signal",
                                         qos_for("/excitation/signal"))
        self.create_subscription(ExcitationCommand, "/excitation/command",
                                 guarded(self, "/excitation/command", self._command),
                                 qos_for("/excitation/command"))
        self.create_service(StartExcitation, "~/start",
                            guarded_service(self, "~/start", self._on_start, "accepted"))
        self.create_service(AbortExcitation, "~/abort", self._on_abort)
        self.player: DrivePlayer | None = None
        self.stream_index = 0
        self.create_timer(min(self.cfg.block_size / self.cfg.fs_hz, 0.05),
                          guarded(self, "drive tick", self._tick))
        if self.cfg.autostart:
            self._start(self.cfg)

    def _start(self, cfg: ExcitationConfig) -> None:
        drive = make_drive(cfg)  # may raise: nothing is changed before it succeeds
        self.cfg = cfg
        self.player = DrivePlayer(drive, cfg, self.stream_index, created_s=time.monotonic())
        self.get_logger().info(f"drive {cfg.kind}: {drive.shape[0]} channels x "
                               f"{drive.shape[1]} samples at {cfg.fs_hz} Hz")

    def _tick(self) -> None:
        p = self.player
        if p is None:
            return
        warning = p.start_when_read(time.monotonic(), time.time_ns(),
                                    self.pub.get_subscription_count())
        if warning:
            self.get_logger().warning(warning)
        for block in p.due(time.monotonic()):
            self.pub.publish(block_to_msg(block, SignalBlockMsg))
            self.stream_index = block.next_index
        if p.finished:
            self.get_logger().info(f"drive finished: {p.n_samples} samples published")
            self.player = None

    def _command(self, msg: ExcitationCommand) -> str:
        if msg.kind == "stop":
            self.player = None
            return "stopped"
        self._start(config_from_command(msg, self.cfg, self.record_roots))
        return f"started {self.cfg.kind}"

    def _on_start(self, req: StartExcitation.Request, res: StartExcitation.Response):
        res.message = self._command(req.command)
        res.accepted = True
        return res

    def _on_abort(self, req: AbortExcitation.Request, res: AbortExcitation.Response):
        was = self.player is not None
        self.player = None
        res.accepted, res.message = was, "aborted" if was else "nothing was running"
        return res


def main() -> int:
    """Entry point of ``excitation_node``."""
    return run_node(ExcitationNode)


if __name__ == "__main__":
    import sys

    sys.exit(main())
