"""The node graph's topic contract: names, message types and QoS kind (no rclpy here)."""

from __future__ import annotations

from enum import Enum
from typing import Any, NamedTuple

__all__ = ["BURST_LIMIT_BLOCKS", "DEPTH", "NODE_ENDPOINTS", "TOPICS", "QosKind", "TopicSpec",
           "bag_qos"]

PKG = "modal_twin_msgs"


class QosKind(Enum):
    """How a topic is delivered."""

    STREAM = "stream"  # reliable, keep-last deep: signal blocks
    LATCHED = "latched"  # reliable, transient-local, keep-last 1: maps, models
    EVENT = "event"  # reliable, volatile, keep-last 50: reports


BURST_LIMIT_BLOCKS = 20_000
"""Blocks a signal topic holds for a slow reader (20 s of 1 kHz data in 1 ms blocks, 400 s
in the usual 50-sample blocks)."""

DEPTH = {QosKind.STREAM: BURST_LIMIT_BLOCKS, QosKind.LATCHED: 1, QosKind.EVENT: 50}
"""History depth (keep-last) of each kind; all reliable, LATCHED also transient local."""


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
    # plottable display samples (modal_twin.viz.node, off by default)
    "/display/measurement": TopicSpec("sensor_msgs/msg/JointState", QosKind.EVENT),
    "/display/twin": TopicSpec("sensor_msgs/msg/JointState", QosKind.EVENT),
}


NODE_ENDPOINTS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "excitation_node": (("/excitation/command",), ("/excitation/signal",)),
    "rig_node": (("/excitation/signal",), ("/rig/raw",)),
    "acquisition_node": (("/rig/raw",), ("/measurement/frames", "/measurement/channels")),
    "identification_node": (("/measurement/frames", "/measurement/channels"),
                            ("/identification/modes", "/identification/stabilization")),
    "updating_node": (("/identification/modes",), ("/model/parameters", "/updating/report")),
    "twin_node": (("/measurement/frames", "/measurement/channels", "/model/parameters"),
                  ("/twin/prediction", "/twin/residual", "/twin/metrics")),
    "diagnosis_node": (("/measurement/frames", "/twin/residual"),
                       ("/diagnosis/report", "/model/parameters")),
    "display_node": (("/measurement/frames", "/twin/prediction"),
                     ("/display/measurement", "/display/twin")),
}
"""(subscriptions, publishers) each node executable creates once it is fully constructed:
the launcher waits for them before it calls the graph ready."""


def bag_qos(topic: str) -> list[Any]:
    """Return the QoS a topic is offered with, as rosbag2 stores it (``offered_qos_profiles``).

    Written with each topic of a bag so that ``ros2 bag play`` (and our replay) offer the
    same QoS again: a latched topic stays latched (transient local) for late joiners.
    """
    from rosbags.interfaces import (
        Qos,
        QosDurability,
        QosHistory,
        QosLiveliness,
        QosReliability,
        QosTime,
    )

    kind = TOPICS[topic].qos if topic in TOPICS else QosKind.STREAM
    never = QosTime(sec=2147483647, nsec=4294967295)  # rosbag2's "infinite"
    return [Qos(history=QosHistory.KEEP_LAST, depth=DEPTH[kind],
                reliability=QosReliability.RELIABLE,
                durability=(QosDurability.TRANSIENT_LOCAL if kind is QosKind.LATCHED
                            else QosDurability.VOLATILE),
                deadline=never, lifespan=never, liveliness=QosLiveliness.AUTOMATIC,
                liveliness_lease_duration=never, avoid_ros_namespace_conventions=False)]
