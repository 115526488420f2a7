"""Diagnosis node.

Buffers /measurement/frames, diagnoses on request or on a schedule, publishes /diagnosis/report;
``~/add_effect`` fits an effect, writes model version n+1 and publishes it on /model/parameters so
the twin loads it live. The work is :class:`~modal_twin.diagnosis.service.DiagnosisService`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from modal_twin_msgs.msg import CandidateEffect, DiagnosisReport, FailingPlace, ModelParameters
from modal_twin_msgs.msg import SignalBlock as SignalBlockMsg
from modal_twin_msgs.srv import AddEffect, RunDiagnosis
from rclpy.node import Node

from modal_twin.acquisition.continuity import Verdict
from modal_twin.diagnosis.pipeline import Diagnosis
from modal_twin.diagnosis.service import DiagnosisService
from modal_twin.io.convert import block_from_msg
from modal_twin.io.params import declare_config
from modal_twin.io.report_convert import diagnosis_to_msg, version_to_parameters_msg
from modal_twin.io.ros import compile_kernels, guarded, guarded_service, qos_for, report, run_node
from modal_twin.io.status import status_of
from modal_twin.paths import resolve_config

__all__ = ["DiagnosisConfig", "DiagnosisNode", "main"]


@dataclass(frozen=True, slots=True)
class DiagnosisConfig:
    """Parameters of the diagnosis node."""

    model_file: str = field(default="config/structures/building.yaml",
                            metadata={"doc": "nominal model (structure or version file)"})
    versions_dir: str = field(default="runs/models", metadata={"doc": "model version folder"})
    buffer_s: float = field(default=120.0, metadata={"doc": "frames kept, s"})
    train_fraction: float = field(default=0.6, metadata={"doc": "share used for fitting"})
    period_s: float = field(default=0.0,
                            metadata={"doc": "live where-it-fails every N s from /twin/residual "
                                             "(0: off); the full diagnosis runs on ~/run"})
    n_fit: int = field(default=3, metadata={"doc": "candidates fitted by simulation"})


class DiagnosisNode(Node):
    """Wiring: frames -> :class:`DiagnosisService` -> report, parameters."""

    def __init__(self) -> None:
        super().__init__("diagnosis")
        self.cfg = declare_config(self, DiagnosisConfig)
        self.service = DiagnosisService(
            resolve_config(self.cfg.model_file), self.cfg.versions_dir,
            buffer_s=self.cfg.buffer_s, train_fraction=self.cfg.train_fraction,
            n_fit=self.cfg.n_fit)
        self.report_pub = self.create_publisher(DiagnosisReport, "/diagnosis/report",
                                                qos_for("/diagnosis/report"))
        self.param_pub = self.create_publisher(ModelParameters, "/model/parameters",
                                               qos_for("/model/parameters"))
        for topic, call in (("/measurement/frames", self._on_frame),
                            ("/twin/residual", self._on_residual)):
            self.create_subscription(SignalBlockMsg, topic, guarded(self, topic, call),
                                     qos_for(topic))
        self.create_service(RunDiagnosis, "~/run", guarded_service(self, "~/run", self._on_run))
        self.create_service(AddEffect, "~/add_effect",
                            guarded_service(self, "~/add_effect", self._on_add))
        if self.cfg.period_s > 0:
            self.create_timer(self.cfg.period_s, guarded(self, "live diagnosis", self._live))
        compile_kernels(self, self.service.warm_up)  # before ready: ~/run does not wait

    def _on_frame(self, msg: SignalBlockMsg) -> None:
        v = self.service.add_frame(block_from_msg(msg))
        if v.verdict is not Verdict.OK:
            report(self.get_logger(), v, node=self)

    def _on_residual(self, msg: SignalBlockMsg) -> None:
        self.service.add_residual(block_from_msg(msg))

    def _report(self, d: Diagnosis) -> DiagnosisReport:
        return diagnosis_to_msg(d, self.cfg.model_file, DiagnosisReport, FailingPlace,
                                CandidateEffect)

    def _live(self) -> None:
        self.report_pub.publish(self._report(self.service.live()))

    def _on_run(self, req: RunDiagnosis.Request, res: RunDiagnosis.Response):
        status = status_of(self)
        d = self.service.diagnose(req.window_s,
                                  progress=lambda step: status.set("busy", f"~/run: {step}"))
        res.report = self._report(d)
        self.report_pub.publish(res.report)
        self.get_logger().info(d.summary)
        res.success, res.message = True, d.summary
        return res

    def _on_add(self, req: AddEffect.Request, res: AddEffect.Response):
        mv = self.service.add(req.effect, req.component)
        res.parameters = version_to_parameters_msg(mv, ModelParameters)
        self.param_pub.publish(res.parameters)
        res.success, res.model_version = True, mv.label
        res.message = f"{mv.note}; written to {mv.path}"
        self.get_logger().info(res.message)
        return res


def main() -> int:
    """Entry point of ``diagnosis_node``."""
    return run_node(DiagnosisNode)
