"""Acquisition node: /rig/raw -> calibrated, checked /measurement/frames (+ channel map)."""

from __future__ import annotations

from dataclasses import dataclass, field

from modal_twin_msgs.msg import ChannelInfo, ChannelMap
from modal_twin_msgs.msg import SignalBlock as SignalBlockMsg
from rclpy.node import Node

from modal_twin.acquisition.continuity import StreamMonitor, Verdict
from modal_twin.acquisition.frames import frame_from_raw
from modal_twin.io.convert import block_from_msg, block_to_msg, channel_map_to_msg
from modal_twin.io.params import declare_config
from modal_twin.io.ros import guarded, qos_for, report, run_node
from modal_twin.models.rig_file import load_rig
from modal_twin.models.sensors import rig_channels
from modal_twin.paths import resolve_config

__all__ = ["AcquisitionConfig", "AcquisitionNode", "main"]


@dataclass(frozen=True, slots=True)
class AcquisitionConfig:
    """Parameters of the acquisition node."""

    rig_file: str = field(default="config/rigs/building_rig.yaml",
                          metadata={"doc": "rig file giving the channel map and sensitivities"})


class AcquisitionNode(Node):
    """Wiring: raw blocks -> continuity check -> SI units -> frames."""

    def __init__(self) -> None:
        super().__init__("acquisition")
        self.cfg = declare_config(self, AcquisitionConfig)
        channels = rig_channels(load_rig(resolve_config(self.cfg.rig_file)))
        self.channels = {c.name: c for c in channels}
        self.monitor = StreamMonitor(expected_channels=tuple(self.channels))
        self.pub = self.create_publisher(SignalBlockMsg, "/measurement/frames",
                                         qos_for("/measurement/frames"))
        self.map_pub = self.create_publisher(ChannelMap, "/measurement/channels",
                                             qos_for("/measurement/channels"))
        self.map_pub.publish(channel_map_to_msg(channels, "acquisition", ChannelMap,
                                                ChannelInfo))
        self.create_subscription(SignalBlockMsg, "/rig/raw",
                                 guarded(self, "raw block", self._on_raw), qos_for("/rig/raw"))
        self.get_logger().info(f"channel map: {len(channels)} channels")

    def _on_raw(self, msg: SignalBlockMsg) -> None:
        v = self.monitor.check(block_from_msg(msg))
        if v.verdict is not Verdict.OK:
            report(self.get_logger(), v, node=self)
        if v.block is None:
            return
        frame, unknown = frame_from_raw(v.block, self.channels)
        if unknown:
            self.get_logger().error(
                f"/rig/raw: channels {unknown[:5]} are not in the channel map: dropped",
                throttle_duration_sec=5.0)
        if frame is not None:
            self.pub.publish(block_to_msg(frame, SignalBlockMsg))


def main() -> int:
    """Entry point of ``acquisition_node``."""
    return run_node(AcquisitionNode)
