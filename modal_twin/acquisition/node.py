"""Acquisition node: /rig/raw -> calibrated, checked /measurement/frames (+ channel map).

With ``mode: impact`` it also keeps the frames of a hammer test and, when it stops, writes
the FRF matrix (``impact/frf.uff``, UFF 58, after the measured points' geometry where the
rig's structure file places its nodes: UFF 164 / 15 / 82) and every hit's verdict
(``impact/hits.yaml``) into the run folder (``MODAL_TWIN_RUN_DIR``, set by the launcher;
else the working directory), logging the hits averaged and each one rejected
(:mod:`modal_twin.acquisition.hammer_test`).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from modal_twin_msgs.msg import ChannelInfo, ChannelMap
from modal_twin_msgs.msg import SignalBlock as SignalBlockMsg
from rclpy.node import Node

from modal_twin.acquisition.continuity import StreamMonitor, Verdict
from modal_twin.acquisition.frames import frame_from_raw
from modal_twin.acquisition.hammer_test import HammerTest
from modal_twin.errors import OptionError
from modal_twin.io.convert import block_from_msg, block_to_msg, channel_map_to_msg
from modal_twin.io.impact_files import structure_geometry, write_hammer_result
from modal_twin.io.params import declare_config
from modal_twin.io.ros import configuring, guarded, qos_for, report, run_node
from modal_twin.models.rig_file import load_rig
from modal_twin.models.sensors import rig_channels
from modal_twin.paths import resolve_config

__all__ = ["AcquisitionConfig", "AcquisitionNode", "main"]


@dataclass(frozen=True, slots=True)
class AcquisitionConfig:
    """Parameters of the acquisition node."""

    rig_file: str = field(default="config/rigs/building_rig.yaml",
                          metadata={"doc": "rig file giving the channel map and sensitivities"})
    mode: str = field(default="stream", metadata={
        "doc": "stream (frames only) or impact (also the FRFs of a hammer test, at the end)"})
    impact_block_s: float = field(default=4.0, metadata={
        "doc": "one hit's block (s): frequency resolution 1 / block (mode=impact)"})
    impact_estimator: str = field(default="H1", metadata={"doc": "H1, H2 or Hv (mode=impact)"})
    impact_tau_s: float = field(default=0.0, metadata={
        "doc": "exponential window on the responses, 0 = none (mode=impact)"})
    impact_force_range_n: float = field(default=0.0, metadata={
        "doc": "force channel range: a hit at it is an overload, 0 = by flat top (mode=impact)"})

    def __post_init__(self) -> None:
        if self.mode not in ("stream", "impact"):
            msg = f"mode: expected stream or impact, got {self.mode!r}"
            raise OptionError(msg)
        if self.impact_estimator not in ("H1", "H2", "Hv"):
            msg = f"impact_estimator: expected H1, H2 or Hv, got {self.impact_estimator!r}"
            raise OptionError(msg)
        if not (math.isfinite(self.impact_block_s) and self.impact_block_s > 0):
            msg = f"impact_block_s: expected a block > 0 s, got {self.impact_block_s}"
            raise OptionError(msg)
        for name in ("impact_tau_s", "impact_force_range_n"):  # 0 = none
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                msg = f"{name}: expected >= 0 (0: none), got {v}"
                raise OptionError(msg)


class AcquisitionNode(Node):
    """Wiring: raw blocks -> continuity check -> SI units -> frames."""

    def __init__(self) -> None:
        super().__init__("acquisition")
        self.cfg = declare_config(self, AcquisitionConfig)
        with configuring(self, "building the channel map"):  # the rig's model: seconds
            rig = load_rig(resolve_config(self.cfg.rig_file))
            channels = rig_channels(rig)
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
        self.hammer: HammerTest | None = None
        self.geometry: dict[str, Any] | None = None
        self.exit_code = 0
        if self.cfg.mode == "impact":
            c = self.cfg
            self.hammer = HammerTest(
                channels, block_s=c.impact_block_s, estimator=c.impact_estimator,  # type: ignore[arg-type]
                tau_s=c.impact_tau_s or None, force_range=c.impact_force_range_n or None)
            # the measured points where the rig's structure file places them (UFF 15 / 82)
            self.geometry = structure_geometry(
                rig.structure, [*self.hammer.inputs, *self.hammer.outputs])
            self.get_logger().info(
                f"impact mode: {len(self.hammer.inputs)} hit points, "
                f"{len(self.hammer.outputs)} responses, {c.impact_block_s:g} s blocks")

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
            if self.hammer is not None:
                self.hammer.add(frame)

    def close(self) -> None:
        """At the end of an impact test: the FRF matrix and the hits' verdicts written."""
        if self.hammer is None:
            return
        log = self.get_logger()
        try:
            res = self.hammer.finish()
            folder = Path(os.environ.get("MODAL_TWIN_RUN_DIR", ".")) / "impact"
            frf, hits = write_hammer_result(folder, res, geometry=self.geometry)
        except Exception as err:  # said, never a traceback at shutdown
            log.error(f"impact: no FRFs written: {err}")
            self.exit_code = 1
            return
        for line in res.lines():  # one call site per severity (rclpy's loggers ask it)
            if line.lstrip().startswith("rejected"):
                log.warning(line)
            else:
                log.info(line)
        log.info(f"impact: FRF matrix {frf}, hits {hits}")


def main() -> int:
    """Entry point of ``acquisition_node``."""
    return run_node(AcquisitionNode)
