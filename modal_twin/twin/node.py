"""Twin node: the nominal model run on measured inputs beside the measurements.

Publishes /twin/prediction and /twin/residual (prediction - measurement) per frame and
/twin/metrics (Eq. (8) of [004] per channel over a sliding window, or with ``window_s`` 0 over
the whole stream) every ``metrics_period_s``; each metrics message names the sample indices
it spans (``header.frame_id`` = ``samples <first>..<last>``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import rclpy.logging
from modal_twin_msgs.msg import ChannelMap, ComparisonMetrics, ModelParameters
from modal_twin_msgs.msg import SignalBlock as SignalBlockMsg
from rclpy.node import Node

from modal_twin.acquisition.continuity import Verdict
from modal_twin.io import convert as cv
from modal_twin.io.channel_map import read_channel_map
from modal_twin.io.params import declare_config
from modal_twin.io.ros import compile_kernels, configuring, guarded, qos_for, report, run_node
from modal_twin.twin.session import TwinSession
from modal_twin.validation import check_request_path

__all__ = ["TwinConfig", "TwinNode", "main"]


@dataclass(frozen=True, slots=True)
class TwinConfig:
    """Parameters of the twin node."""

    model_file: str = field(default="config/structures/building.yaml",
                            metadata={"doc": "structure file or model version file"})
    fs_hz: float = field(default=1000.0, metadata={"doc": "frame rate the twin runs at"})
    window_s: float = field(default=10.0, metadata={
        "doc": "metrics window, s; 0 = the whole stream from its first sample"})
    metrics_period_s: float = field(default=1.0, metadata={"doc": "metrics publish period"})
    versions_dir: str = field(default="runs/models",
                              metadata={"doc": "folder of the model versions /model/parameters "
                                               "may name (besides the working folder)"})
    channel_map: str = field(default="", metadata={
        "doc": "channel map JSON (roles) of the stream; '' = take /measurement/channels, "
               "else table_<input> names"})


class TwinNode(Node):
    """Wiring: frames -> :class:`TwinSession` -> prediction, residual, metrics."""

    def __init__(self) -> None:
        super().__init__("twin")
        self.cfg = declare_config(self, TwinConfig)
        t0 = time.perf_counter()
        with configuring(self, "building the model"):  # a shell carbody's reduction: seconds
            self.twin = TwinSession(self.cfg.model_file, self.cfg.fs_hz, self.cfg.window_s,
                                    self.cfg.versions_dir)
        self.get_logger().info(f"model {self.twin.plant.name} built in "
                               f"{time.perf_counter() - t0:.1f} s")
        self.fixed_map = bool(self.cfg.channel_map)  # a given map wins over the stream's
        if self.fixed_map:
            self.twin.set_channels(read_channel_map(check_request_path(
                self.cfg.channel_map, "channel_map", self.twin.roots)))
        self.pred_pub, self.res_pub = (
            self.create_publisher(SignalBlockMsg, t, qos_for(t))
            for t in ("/twin/prediction", "/twin/residual"))
        self.met_pub = self.create_publisher(ComparisonMetrics, "/twin/metrics",
                                             qos_for("/twin/metrics"))
        # the executor takes ready messages in the order the subscriptions were made: a map
        # or a model version that arrived before a frame is applied before that frame
        self.create_subscription(ChannelMap, "/measurement/channels",
                                 guarded(self, "/measurement/channels", self._on_channels),
                                 qos_for("/measurement/channels"))
        self.create_subscription(ModelParameters, "/model/parameters",
                                 guarded(self, "/model/parameters", self._on_parameters),
                                 qos_for("/model/parameters"))
        self.create_subscription(SignalBlockMsg, "/measurement/frames",
                                 guarded(self, "frame", self._on_frame),
                                 qos_for("/measurement/frames"))
        self.create_timer(self.cfg.metrics_period_s,
                          guarded(self, "metrics", self._publish_metrics))
        compile_kernels(self, self.twin.runner.sim.warm_up)  # before ready
        plant = self.twin.plant
        self.get_logger().info(f"twin of {plant.name}: {len(plant.channels)} channels, "
                               f"{plant.system.n} coordinates")

    def _on_frame(self, msg: SignalBlockMsg) -> None:
        v, step = self.twin.frame(cv.block_from_msg(msg))
        if v.verdict is not Verdict.OK:
            report(self.get_logger(), v, node=self)
        if step is not None and step.first:
            self.get_logger().info(self.twin.runner.describe_route())
        if step is not None:
            self.pred_pub.publish(cv.block_to_msg(step.prediction, SignalBlockMsg))
            self.res_pub.publish(cv.block_to_msg(step.residual, SignalBlockMsg))

    def _on_channels(self, msg: ChannelMap) -> None:
        """Route the stream by the roles of its channel map (a refused map changes nothing)."""
        channels = cv.channel_map_from_msg(msg)  # validated even when a file map rules
        if not self.fixed_map and self.twin.set_channels(channels):
            self.get_logger().info(f"channel map of {msg.source or 'the stream'}: "
                                   f"{len(msg.channels)} channels, routed by their roles")

    def _on_parameters(self, msg: ModelParameters) -> None:
        """Load the model version of a parameter message; a refused one changes nothing."""
        label = self.twin.load_version(msg.model_file, cv.theta_from_msg(msg), msg.model_version)
        self.get_logger().info(f"twin now runs model version {label}")

    def _publish_metrics(self) -> None:
        runner = self.twin.runner
        m = runner.metrics()
        if m is not None and runner.compare is not None:
            msg = cv.metrics_to_msg(runner.compare, m, self.cfg.window_s, self.twin.version,
                                    ComparisonMetrics, span=runner.window_range())
            msg.header.stamp = self.get_clock().now().to_msg()
            self.met_pub.publish(msg)

    def close(self) -> None:
        """Log the final error table and what it covers."""
        table = self.twin.runner.error_table(top=12)
        rclpy.logging.get_logger(self.get_name()).info(
            f"final per-channel error, {self.twin.coverage()}:\n{table}")


def main() -> int:
    """Entry point of ``twin_node``."""
    return run_node(TwinNode)
