"""Node state on ``/diagnostics`` (diagnostic_msgs/DiagnosticArray, the ROS convention).

Every node gets one :class:`NodeStatus` (:func:`status_of`): its state (``starting`` while
it configures, e.g. ``starting: compiling kernels``; ``ready`` once built; ``busy: <what>``,
``error``), counters of what it refused or dropped, the
fraction done of long work, and for each topic it publishes how many subscriptions have
matched it (``matched <topic>``: the launcher starts the excitation only when every hop of
the graph has matched its readers). It publishes on every change of state and once a second, so
``ros2 topic echo /diagnostics``, rqt_robot_monitor or Foxglove show a node that hangs,
refuses input or works on a long request. The wrappers of :mod:`modal_twin.io.ros` set the
state and count refusals for every node without code in the nodes.
"""

from __future__ import annotations

from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.node import Node

__all__ = ["MATCHED", "STATUS_TOPIC", "NodeStatus", "status_of"]

STATUS_TOPIC = "/diagnostics"
MATCHED = "matched "
"""Key prefix of a published topic's matched-subscription count."""
_OWN = ("/rosout", "/parameter_events", STATUS_TOPIC)
_LEVEL = {"starting": DiagnosticStatus.OK, "ready": DiagnosticStatus.OK,
          "busy": DiagnosticStatus.OK, "warning": DiagnosticStatus.WARN,
          "error": DiagnosticStatus.ERROR}


class NodeStatus:
    """State, counters and progress of one node, published on :data:`STATUS_TOPIC`."""

    def __init__(self, node: Node, period_s: float = 1.0) -> None:
        self.node = node
        self.state = "starting"
        self.detail = ""
        self.progress: float | None = None
        self.counters: dict[str, int] = {"refused": 0, "dropped": 0}
        from modal_twin.io.ros import qos_for

        self._pub = node.create_publisher(DiagnosticArray, STATUS_TOPIC, qos_for(STATUS_TOPIC))
        node.create_timer(period_s, self.publish)

    def set(self, state: str, detail: str = "", progress: float | None = None) -> None:
        """Change the state (publishes at once)."""
        self.state, self.detail = state, detail
        self.progress = None if progress is None else min(max(float(progress), 0.0), 1.0)
        self.publish()

    def count(self, what: str, n: int = 1) -> None:
        """Add ``n`` to a counter (``refused``, ``dropped`` ...)."""
        self.counters[what] = self.counters.get(what, 0) + int(n)

    def message(self) -> DiagnosticArray:
        """Return the DiagnosticArray of the current state."""
        st = DiagnosticStatus()
        st.level = _LEVEL.get(self.state, DiagnosticStatus.WARN)
        st.name = self.node.get_fully_qualified_name()
        st.message = f"{self.state}: {self.detail}" if self.detail else self.state
        st.hardware_id = "modal_twin"
        values = [("state", self.state), *((k, str(v)) for k, v in self.counters.items())]
        if self.progress is not None:
            values.append(("progress", f"{self.progress:.3f}"))
        values += [(MATCHED + p.topic_name, str(p.get_subscription_count()))
                   for p in self.node.publishers if p.topic_name not in _OWN]
        st.values = [KeyValue(key=k, value=v) for k, v in values]
        arr = DiagnosticArray()
        arr.header.stamp = self.node.get_clock().now().to_msg()
        arr.status = [st]
        return arr

    def publish(self) -> None:
        """Publish the current state."""
        self._pub.publish(self.message())


def status_of(node: Any, initial: str = "ready") -> NodeStatus:
    """Return the node's :class:`NodeStatus`, created (and set to ``initial``) on first use.

    A node that configures at length (a model reduction, compiled kernels) says
    ``starting`` first; :func:`modal_twin.io.ros.run_node` sets it ``ready`` once the node
    is built, and the launcher starts the run only when every node has said so.
    """
    st = getattr(node, "_modal_twin_status", None)
    if st is None:
        st = NodeStatus(node)
        node._modal_twin_status = st
        st.set(initial)
    return st
