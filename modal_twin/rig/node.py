"""Rig node: runs the truth model of a rig file on /excitation/signal, publishes /rig/raw."""

from __future__ import annotations

from dataclasses import dataclass, field

from modal_twin_msgs.msg import SignalBlock as SignalBlockMsg
from rclpy.node import Node

from modal_twin.acquisition.continuity import StreamMonitor, Verdict
from modal_twin.io.convert import block_from_msg, block_to_msg
from modal_twin.io.params import declare_config
from modal_twin.io.ros import compile_kernels, configuring, guarded, qos_for, report, run_node
from modal_twin.models.loading import load_model
from modal_twin.models.rig_file import load_rig
from modal_twin.paths import resolve_config
from modal_twin.rig.truth import TruthRig

__all__ = ["RigConfig", "RigNode", "main"]


@dataclass(frozen=True, slots=True)
class RigConfig:
    """Parameters of the rig node."""

    rig_file: str = field(default="config/rigs/building_rig.yaml",
                          metadata={"doc": "rig file: structure, sensors, hidden effects"})
    fs_hz: float = field(default=1000.0, metadata={"doc": "drive / simulation rate"})


class RigNode(Node):
    """Wiring: drive blocks -> truth rig -> raw blocks."""

    def __init__(self) -> None:
        super().__init__("rig")
        self.cfg = declare_config(self, RigConfig)
        with configuring(self, "building the truth model"):
            rig = load_rig(resolve_config(self.cfg.rig_file))
            plant = load_model(rig.structure, theta=rig.theta or None).plant(rig.effects)
            self.truth = TruthRig(plant, 1.0 / self.cfg.fs_hz, noise_rms=rig.noise_rms,
                                  sensitivity=rig.sensitivity, seed=rig.seed,
                                  channels=rig.channels)
        self.monitor = StreamMonitor()
        self.pub = self.create_publisher(SignalBlockMsg, "/rig/raw", qos_for("/rig/raw"))
        self.create_subscription(SignalBlockMsg, "/excitation/signal",
                                 guarded(self, "drive block", self._on_drive),
                                 qos_for("/excitation/signal"))
        compile_kernels(self, self.truth.sim.warm_up)  # before ready: no block waits for it
        self.get_logger().info(
            f"rig {rig.path.name}: {plant.name}, {len(self.truth.names)} channels, "
            f"{len(rig.effects)} effect(s) beyond the structure file")

    def _on_drive(self, msg: SignalBlockMsg) -> None:
        try:
            v = self.monitor.check(block_from_msg(msg))
            if v.verdict is not Verdict.OK:
                report(self.get_logger(), v, node=self)
            if v.block is None:
                return
            if v.block.fs_hz != self.cfg.fs_hz:
                self.get_logger().error(
                    f"drive at {v.block.fs_hz} Hz, rig simulates at {self.cfg.fs_hz} Hz: dropped",
                    throttle_duration_sec=5.0)
                return
            self.pub.publish(block_to_msg(self.truth.process(v.block), SignalBlockMsg))
        except Exception as err:  # the truth restarts from rest after any failure
            self.get_logger().error(f"drive block refused: {err}", throttle_duration_sec=2.0)
            self.truth.sim.reset()


def main() -> int:
    """Entry point of ``rig_node``."""
    return run_node(RigNode)
