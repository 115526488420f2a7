"""The node graph's topic contract: names, message types and QoS kind (no rclpy here)."""

from __future__ import annotations

from enum import Enum
from typing import NamedTuple

__all__ = ["NODE_ENDPOINTS", "TOPICS", "QosKind", "TopicSpec"]

PKG = "modal_twin_msgs"


class QosKind(Enum):
    """How a topic is delivered."""

    STREAM = "stream"  # reliable, keep-last deep: signal blocks
    LATCHED = "latched"  # reliable, transient-local, keep-last 1: maps, models
    EVENT = "event"  # reliable, volatile, keep-last 50: reports


class TopicSpec(NamedTuple):
    """Message type (e.g. ``modal_twin_msgs/msg/SignalBlock``) and delivery of a topic."""

    msgtype: str
    qos: QosKind


def _t(name: str, qos: QosKind) -> TopicSpec:
    return TopicSpec(f"{PKG}/msg/{name}", qos)


TOPICS: dict[str, TopicSpec] = {
    "/excitation/signal": _t("SignalBlock", QosKind.STREAM),
    "/excitation/command": _t("ExcitationCommand", QosKind.EVENT),
    "/rig/raw": _t("SignalBlock", QosKind.STREAM),
    "/measurement/frames": _t("SignalBlock", QosKind.STREAM),
    "/measurement/channels": _t("ChannelMap", QosKind.LATCHED),
    "/identification/modes": _t("ModalModel", QosKind.LATCHED),
    "/identification/stabilization": _t("StabilizationDiagram", QosKind.LATCHED),
    "/model/parameters": _t("ModelParameters", QosKind.LATCHED),
    "/updating/report": _t("UpdateReport", QosKind.EVENT),
    "/twin/prediction": _t("SignalBlock", QosKind.STREAM),
    "/twin/residual": _t("SignalBlock", QosKind.STREAM),
    "/twin/metrics": _t("ComparisonMetrics", QosKind.EVENT),
    "/diagnosis/report": _t("DiagnosisReport", QosKind.LATCHED),
    # every node's state, counters and progress (modal_twin.io.status), the ROS convention
    "/diagnostics": TopicSpec("diagnostic_msgs/msg/DiagnosticArray", QosKind.EVENT),
}


NODE_ENDPOINTS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "excitation_node": (("/excitation/command",), ("/excitation/signal",)),
    "rig_node": (("/excitation/signal",), ("/rig/raw",)),
    "acquisition_node": (("/rig/raw",), ("/measurement/frames", "/measurement/channels")),
    "identification_node": (("/measurement/frames",),
                            ("/identification/modes", "/identification/stabilization")),
    "updating_node": (("/identification/modes",), ("/model/parameters", "/updating/report")),
    "twin_node": (("/measurement/frames", "/model/parameters"),
                  ("/twin/prediction", "/twin/residual", "/twin/metrics")),
    "diagnosis_node": (("/measurement/frames", "/twin/residual"),
                       ("/diagnosis/report", "/model/parameters")),
}
"""(subscriptions, publishers) each node executable creates once it is fully constructed:
the launcher waits for them before it calls the graph ready."""
