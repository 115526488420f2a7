"""Diagnosis node.

Buffers /measurement/frames, diagnoses on request or on a schedule, publishes /diagnosis/report;
``~/add_effect`` fits an effect, writes model version n+1 and publishes it on /model/parameters so
the twin loads it live.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from modal_twin_msgs.msg import (
    CandidateEffect,
    DiagnosisReport,
    FailingPlace,
    ModelParameters,
)
from modal_twin_msgs.msg import SignalBlock as SignalBlockMsg
from modal_twin_msgs.srv import AddEffect, RunDiagnosis
from rclpy.node import Node

from modal_twin.acquisition.continuity import StreamMonitor, Verdict
from modal_twin.block_window import BlockWindow
from modal_twin.diagnosis.live import live_diagnosis
from modal_twin.diagnosis.pipeline import Diagnosis
from modal_twin.diagnosis.record import Record, record_from_blocks
from modal_twin.diagnosis.workflow import (
    add_diagnosed,
    add_effect,
    choose_start,
    diagnose_model,
)
from modal_twin.errors import ModalTwinError
from modal_twin.io.convert import block_from_msg
from modal_twin.io.params import declare_config
from modal_twin.io.report_convert import diagnosis_to_msg, version_to_parameters_msg
from modal_twin.io.ros import guarded, guarded_service, qos_for, report, run_node
from modal_twin.models.loading import load_model
from modal_twin.paths import resolve_config
from modal_twin.validation import check_field

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
    """Wiring: frames -> buffer -> diagnosis / add effect -> report, parameters."""

    def __init__(self) -> None:
        super().__init__("diagnosis")
        self.cfg = declare_config(self, DiagnosisConfig)
        self.frames = BlockWindow(self.cfg.buffer_s, "measurement frames")
        self.residuals = BlockWindow(self.cfg.buffer_s, "twin residuals")
        self.monitor = StreamMonitor()
        self.last: Diagnosis | None = None
        self.report_pub = self.create_publisher(DiagnosisReport, "/diagnosis/report",
                                                qos_for("/diagnosis/report"))
        self.param_pub = self.create_publisher(ModelParameters, "/model/parameters",
                                               qos_for("/model/parameters"))
        self.create_subscription(SignalBlockMsg, "/measurement/frames",
                                 guarded(self, "frame", self._on_frame),
                                 qos_for("/measurement/frames"))
        self.create_subscription(SignalBlockMsg, "/twin/residual",
                                 guarded(self, "residual", self._on_residual),
                                 qos_for("/twin/residual"))
        self.channels = {c.name: c for c in
                         load_model(resolve_config(self.cfg.model_file)).plant().channels}
        self.create_service(RunDiagnosis, "~/run", guarded_service(self, "~/run", self._on_run))
        self.create_service(AddEffect, "~/add_effect",
                            guarded_service(self, "~/add_effect", self._on_add))
        if self.cfg.period_s > 0:
            self.create_timer(self.cfg.period_s, guarded(self, "live diagnosis", self._scheduled))

    def _on_frame(self, msg: SignalBlockMsg) -> None:
        v = self.monitor.check(block_from_msg(msg))
        if v.verdict is not Verdict.OK:
            report(self.get_logger(), v)
        if v.block is not None:
            self.frames.add(v.block)  # a gap or restart starts a new record

    def _on_residual(self, msg: SignalBlockMsg) -> None:
        self.residuals.add(block_from_msg(msg))

    def _records(self, window_s: float) -> tuple[Record, Record]:
        last_s = check_field(window_s, "window_s", "window_s")
        rec = record_from_blocks([self.frames.joined(last_s)], source="/measurement/frames")
        cut = round(self.cfg.train_fraction * rec.n_samples)
        return rec.segment(0, cut), rec.segment(cut, rec.n_samples, warmup=True)

    def _diagnose(self, window_s: float) -> Diagnosis:
        train, test = self._records(window_s)
        d = diagnose_model(resolve_config(self.cfg.model_file), train, test,
                           n_fit=self.cfg.n_fit)
        self.last = d
        self.report_pub.publish(diagnosis_to_msg(d, self.cfg.model_file, DiagnosisReport,
                                                 FailingPlace, CandidateEffect))
        self.get_logger().info(d.summary)
        return d

    def _scheduled(self) -> None:
        d = live_diagnosis(list(self.frames.blocks), list(self.residuals.blocks), self.channels)
        self.report_pub.publish(diagnosis_to_msg(d, self.cfg.model_file, DiagnosisReport,
                                                 FailingPlace, CandidateEffect))

    def _on_run(self, req: RunDiagnosis.Request, res: RunDiagnosis.Response):
        d = self._diagnose(req.window_s)
        res.success, res.message = True, d.summary
        res.report = diagnosis_to_msg(d, self.cfg.model_file, DiagnosisReport,
                                      FailingPlace, CandidateEffect)
        return res

    def _on_add(self, req: AddEffect.Request, res: AddEffect.Response):
        train, test = self._records(0.0)
        model = resolve_config(self.cfg.model_file)
        if req.effect and req.component:  # the named effect, started as the CLI starts it
            start = choose_start(load_model(model), req.component, req.effect, train)
            mv, _ = add_effect(model, req.component, req.effect, start, train, test,
                               self.cfg.versions_dir)
        else:  # every effect the diagnosis found (accepted, unflagged)
            d = self.last or self._diagnose(0.0)
            written = add_diagnosed(model, d, test, self.cfg.versions_dir)
            if written is None:
                msg = f"nothing to add: {d.summary}"
                raise ModalTwinError(msg)
            mv = written
        res.parameters = version_to_parameters_msg(mv, ModelParameters)
        self.param_pub.publish(res.parameters)
        res.success, res.model_version = True, mv.label
        res.message = f"{mv.note}; written to {mv.path}"
        self.get_logger().info(res.message)
        return res


def main() -> int:
    """Entry point of ``diagnosis_node``."""
    return run_node(DiagnosisNode)
