"""Twin node: the nominal model run on measured inputs beside the measurements.

Publishes /twin/prediction and /twin/residual (prediction - measurement) per frame and
/twin/metrics (Eq. (8) of [004] per channel over a sliding window) every ``metrics_period_s``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import rclpy.logging
from modal_twin_msgs.msg import ComparisonMetrics, ModelParameters
from modal_twin_msgs.msg import SignalBlock as SignalBlockMsg
from rclpy.node import Node

from modal_twin.acquisition.continuity import StreamMonitor, Verdict
from modal_twin.io.convert import block_from_msg, block_to_msg, metrics_to_msg, theta_from_msg
from modal_twin.io.params import declare_config
from modal_twin.io.ros import guarded, qos_for, report, run_node
from modal_twin.models.loading import load_model
from modal_twin.paths import config_roots, resolve_config
from modal_twin.twin.runner import TwinRunner
from modal_twin.validation import check_request_path

__all__ = ["TwinConfig", "TwinNode", "main"]


@dataclass(frozen=True, slots=True)
class TwinConfig:
    """Parameters of the twin node."""

    model_file: str = field(default="config/structures/building.yaml",
                            metadata={"doc": "structure file or model version file"})
    fs_hz: float = field(default=1000.0, metadata={"doc": "frame rate the twin runs at"})
    window_s: float = field(default=10.0, metadata={"doc": "metrics window"})
    metrics_period_s: float = field(default=1.0, metadata={"doc": "metrics publish period"})
    versions_dir: str = field(default="runs/models",
                              metadata={"doc": "folder of the model versions /model/parameters "
                                               "may name (besides the working folder)"})


class TwinNode(Node):
    """Wiring: frames -> nominal plant -> prediction, residual, metrics."""

    def __init__(self) -> None:
        super().__init__("twin")
        self.cfg = declare_config(self, TwinConfig)
        self.plant = load_model(resolve_config(self.cfg.model_file)).plant()
        self.version = self.plant.name
        self.model_roots = [Path.cwd(), Path(self.cfg.versions_dir),
                            resolve_config(self.cfg.model_file).resolve().parent, *config_roots()]
        self.runner = TwinRunner(self.plant, self.cfg.fs_hz, window_s=self.cfg.window_s)
        self.monitor = StreamMonitor()
        self.pred_pub = self.create_publisher(SignalBlockMsg, "/twin/prediction",
                                              qos_for("/twin/prediction"))
        self.res_pub = self.create_publisher(SignalBlockMsg, "/twin/residual",
                                             qos_for("/twin/residual"))
        self.met_pub = self.create_publisher(ComparisonMetrics, "/twin/metrics",
                                             qos_for("/twin/metrics"))
        self.create_subscription(SignalBlockMsg, "/measurement/frames",
                                 guarded(self, "frame", self._on_frame),
                                 qos_for("/measurement/frames"))
        self.create_subscription(ModelParameters, "/model/parameters",
                                 guarded(self, "/model/parameters", self._on_parameters),
                                 qos_for("/model/parameters"))
        self.create_timer(self.cfg.metrics_period_s,
                          guarded(self, "metrics", self._publish_metrics))
        self.get_logger().info(f"twin of {self.plant.name}: {len(self.plant.channels)} "
                               f"channels, {self.plant.system.n} coordinates")

    def _on_frame(self, msg: SignalBlockMsg) -> None:
        v = self.monitor.check(block_from_msg(msg))
        if v.verdict is not Verdict.OK:
            report(self.get_logger(), v)
        if v.block is None:
            return
        if v.verdict is Verdict.RESTART:  # a new run: the structure starts from rest
            self.runner = TwinRunner(self.plant, self.cfg.fs_hz, window_s=self.cfg.window_s)
        step = self.runner.step(v.block)
        self.pred_pub.publish(block_to_msg(step.prediction, SignalBlockMsg))
        self.res_pub.publish(block_to_msg(step.residual, SignalBlockMsg))

    def _on_parameters(self, msg: ModelParameters) -> None:
        """Load the model version of a parameter message; a refused one changes nothing."""
        path = self.cfg.model_file
        if msg.model_file:
            path = str(check_request_path(msg.model_file, "ModelParameters.model_file",
                                          self.model_roots))
        plant = load_model(resolve_config(path), theta=theta_from_msg(msg)).plant()
        self.plant, self.version = plant, msg.model_version or plant.name
        self.runner = TwinRunner(plant, self.cfg.fs_hz, window_s=self.cfg.window_s)
        self.get_logger().info(f"twin now runs model version {self.version}")

    def _publish_metrics(self) -> None:
        m = self.runner.metrics()
        if m is None or self.runner.compare is None:
            return
        self.met_pub.publish(metrics_to_msg(self.runner.compare, m, self.cfg.window_s,
                                            self.version, ComparisonMetrics))

    def close(self) -> None:
        """Log the final error table."""
        table = self.runner.error_table(top=12)
        rclpy.logging.get_logger(self.get_name()).info(f"final per-channel error:\n{table}")


def main() -> int:
    """Entry point of ``twin_node``."""
    return run_node(TwinNode)
