"""Updating node: /identification/modes -> two-stage update -> /model/parameters.

It publishes /model/parameters (latched) and /updating/report, and writes a new model
version file the twin loads.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from modal_twin_msgs.msg import ModalModel as ModalModelMsg
from modal_twin_msgs.msg import ModelParameters, ModePair, UpdateReport
from modal_twin_msgs.srv import RunUpdating
from rclpy.node import Node

from modal_twin.identification.modal_model import ModalModel
from modal_twin.io.modal_convert import modal_model_from_msg
from modal_twin.io.params import declare_config
from modal_twin.io.report_convert import update_to_msgs
from modal_twin.io.ros import guarded, guarded_service, one_line, qos_for, run_node
from modal_twin.paths import resolve_config
from modal_twin.updating.run import update_model

__all__ = ["UpdatingConfig", "UpdatingNode", "main"]


@dataclass(frozen=True, slots=True)
class UpdatingConfig:
    """Parameters of the updating node."""

    model_file: str = field(default="config/structures/building.yaml",
                            metadata={"doc": "model to update (structure or version file)"})
    versions_dir: str = field(default="runs/models", metadata={"doc": "model version folder"})
    f_split_hz: float = field(default=0.0,
                              metadata={"doc": "isolation modes below, superstructure above "
                                        "(0: the gap of the model's own modes)"})
    auto: bool = field(default=True, metadata={"doc": "update on every new set of modes"})


class UpdatingNode(Node):
    """Wiring: modes -> update -> parameters, report."""

    def __init__(self) -> None:
        super().__init__("updating")
        self.cfg = declare_config(self, UpdatingConfig)
        self.modes: tuple[ModalModel, tuple[str, ...]] | None = None
        self.param_pub = self.create_publisher(ModelParameters, "/model/parameters",
                                               qos_for("/model/parameters"))
        self.report_pub = self.create_publisher(UpdateReport, "/updating/report",
                                                qos_for("/updating/report"))
        self.create_subscription(ModalModelMsg, "/identification/modes",
                                 guarded(self, "/identification/modes", self._on_modes),
                                 qos_for("/identification/modes"))
        self.create_service(RunUpdating, "~/run", guarded_service(self, "~/run", self._on_run))

    def _on_modes(self, msg: ModalModelMsg) -> None:
        self.modes = modal_model_from_msg(msg)
        if self.cfg.auto:
            ok, text, _ = self._update()
            if ok:
                self.get_logger().info(text)
            else:
                self.get_logger().error(text)

    def _update(self) -> tuple[bool, str, UpdateReport]:
        if self.modes is None:
            return False, "no identified modes received yet", UpdateReport()
        try:
            upd = update_model(resolve_config(self.cfg.model_file), *self.modes,
                               self.cfg.versions_dir, f_split_hz=self.cfg.f_split_hz)
        except Exception as err:  # any failure: the previous model stays, the node runs on
            msg = f"update failed, the previous model stays: {one_line(err)}"
            return False, msg, UpdateReport()
        report, params = update_to_msgs(upd, UpdateReport, ModePair, ModelParameters)
        self.param_pub.publish(params)
        self.report_pub.publish(report)
        return True, report.message, report

    def _on_run(self, req: RunUpdating.Request,
                res: RunUpdating.Response) -> RunUpdating.Response:
        ok, text, report = self._update()
        res.success, res.message, res.report = ok, text, report
        return res


def main() -> int:
    """Entry point of ``updating_node``."""
    return run_node(UpdatingNode)
