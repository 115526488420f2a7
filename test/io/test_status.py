"""Node state on /diagnostics: ready, busy during a request, refusals counted."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

pytestmark = pytest.mark.ros


def test_status_follows_requests_and_counts_refusals(domain_id: int) -> None:
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from rclpy.executors import SingleThreadedExecutor

    from modal_twin.io.ros import guarded, guarded_service, qos_for
    from modal_twin.io.status import STATUS_TOPIC, status_of

    rclpy.init(domain_id=domain_id)
    node = rclpy.create_node("worker")
    probe = rclpy.create_node("probe")
    got: list[DiagnosticArray] = []
    probe.create_subscription(DiagnosticArray, STATUS_TOPIC, got.append,
                              qos_for(STATUS_TOPIC))
    ex = SingleThreadedExecutor()
    ex.add_node(node)
    ex.add_node(probe)
    try:
        status = status_of(node)
        for _ in range(60):  # discovery
            ex.spin_once(timeout_sec=0.05)
            if status._pub.get_subscription_count():
                break
        seen_inside: list[str] = []

        def work(req: object, res: SimpleNamespace) -> SimpleNamespace:
            seen_inside.append(status.state)
            res.success, res.message = True, "done"
            return res

        def bad(req: object, res: SimpleNamespace) -> SimpleNamespace:
            msg = "window_s: expected >= 0, got -1"
            raise ValueError(msg)

        assert guarded_service(node, "~/run", work)(None, SimpleNamespace()).success
        assert seen_inside == ["busy"] and status.state == "ready"
        res = guarded_service(node, "~/run", bad)(None, SimpleNamespace(success=True))
        assert res.success is False and "window_s" in res.message
        guarded(node, "frame", lambda msg: 1 / 0)(None)  # a refused message
        assert status.counters["refused"] == 2
        from modal_twin.acquisition.continuity import Verdict
        from modal_twin.io.ros import report

        for _ in range(3):  # every dropped block counts, though the log is throttled
            report(node.get_logger(), SimpleNamespace(verdict=Verdict.GAP, block=None,
                                                      message="gap"), node=node)
        assert status.counters["dropped"] == 3
        for _ in range(40):
            ex.spin_once(timeout_sec=0.05)
        states = [a.status[0].message for a in got]
        assert "busy: ~/run" in states
        last = {kv.key: kv.value for kv in got[-1].status[0].values}
        assert last["state"] == "ready" and int(last["refused"]) >= 1
        assert got[-1].status[0].level == DiagnosticStatus.OK
        assert got[-1].status[0].name == "/worker"
    finally:
        node.destroy_node()
        probe.destroy_node()
        rclpy.try_shutdown()


def test_status_reports_matched_readers_per_published_topic(domain_id: int) -> None:
    """The launcher's readiness: ``matched /topic`` counts the subscriptions that matched."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from std_msgs.msg import Float64

    from modal_twin.io.status import MATCHED, status_of

    rclpy.init(domain_id=domain_id)
    node = rclpy.create_node("writer")
    readers = [rclpy.create_node(f"reader_{k}") for k in range(2)]
    ex = SingleThreadedExecutor()
    for n in (node, *readers):
        ex.add_node(n)
    try:
        node.create_publisher(Float64, "/hop", 10)
        status = status_of(node)

        def matched() -> dict[str, str]:
            return {kv.key: kv.value for kv in status.message().status[0].values
                    if kv.key.startswith(MATCHED)}

        assert matched() == {"matched /hop": "0"}  # no reader yet; own topics left out
        for r in readers:
            r.create_subscription(Float64, "/hop", lambda m: None, 10)
        for _ in range(100):  # discovery
            ex.spin_once(timeout_sec=0.05)
            if matched()["matched /hop"] == "2":
                break
        assert matched() == {"matched /hop": "2"}
    finally:
        for n in (node, *readers):
            n.destroy_node()
        rclpy.try_shutdown()
