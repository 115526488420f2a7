"""Updating node: /identification/modes -> two-stage update -> /model/parameters.

It publishes /model/parameters (latched) and /updating/report, and writes a new model
version file the twin loads.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from modal_twin_msgs.msg import ModalModel as ModalModelMsg
from modal_twin_msgs.msg import ModelParameters, ModePair, UpdateReport
from modal_twin_msgs.srv import RunUpdating
from rclpy.node import Node

from modal_twin.identification.modal_model import ModalModel
from modal_twin.io.convert import to_float_array
from modal_twin.io.modal_convert import modal_model_from_msg
from modal_twin.io.params import declare_config
from modal_twin.io.report_convert import version_to_parameters_msg
from modal_twin.io.ros import guarded, guarded_service, one_line, qos_for, run_node
from modal_twin.paths import resolve_config
from modal_twin.updating.run import ModelUpdate, pairs_table, update_model

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
        report = UpdateReport()
        if self.modes is None:
            return False, "no identified modes received yet", report
        try:
            upd = update_model(resolve_config(self.cfg.model_file), *self.modes,
                               self.cfg.versions_dir, f_split_hz=self.cfg.f_split_hz)
        except Exception as err:  # any failure: the previous model stays, the node runs on
            return False, f"update failed, the previous model stays: {one_line(err)}", report
        report = self._report(upd)
        params = version_to_parameters_msg(upd.version, ModelParameters)
        last = upd.result.stages[-1]
        if last.uncertainty is not None:
            std = dict(zip(last.uncertainty.names, last.uncertainty.std, strict=True))
            params.std = to_float_array([std.get(n, np.nan) for n in params.names])
        self.param_pub.publish(params)
        self.report_pub.publish(report)
        return True, report.message, report

    def _report(self, upd: ModelUpdate) -> UpdateReport:
        r = UpdateReport()
        v = upd.version
        r.model_version_before = "" if v.parent is None else f"v{v.parent}"
        r.model_version_after = v.label
        r.stages = list(upd.result.stage_names)
        for i, j, f, fb, fa, mb, ma in pairs_table(upd):
            p = ModePair()
            p.identified_index, p.model_index = i, j
            p.identified_frequency_hz = f
            p.model_frequency_hz_before, p.model_frequency_hz_after = fb, fa
            p.mac_before, p.mac_after = mb, ma
            r.pairs.append(p)
        r.cost_before = float(upd.result.stages[0].cost_before)
        r.cost_after = float(upd.result.stages[-1].cost_after)
        r.converged = all(s.converged for s in upd.result.stages)
        r.message = f"{v.label} written to {v.path}: {v.note}"
        return r

    def _on_run(self, req: RunUpdating.Request,
                res: RunUpdating.Response) -> RunUpdating.Response:
        ok, text, report = self._update()
        res.success, res.message, res.report = ok, text, report
        return res


def main() -> int:
    """Entry point of ``updating_node``."""
    return run_node(UpdatingNode)
