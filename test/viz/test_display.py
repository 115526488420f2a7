"""Display stream: window means with stamps (closed forms), and the node's JointState."""

from __future__ import annotations

import numpy as np
import pytest

from modal_twin.errors import OptionError
from modal_twin.signal_block import SignalBlock
from modal_twin.viz.display import BlockMeans

FS = 1000.0


def _blocks(x: np.ndarray, size: int, first: int = 0, t0_ns: int = 10**18) -> list[SignalBlock]:
    return [SignalBlock(("a", "b"), FS, first + k, x[:, k:k + size],
                        stamp_ns=t0_ns + round((first + k) * 1e6))
            for k in range(0, x.shape[1], size)]


def test_window_means_of_a_sine_are_the_closed_form_across_blocks() -> None:
    # mean of sin(2 pi f t) over [t0, t0 + T] = sin at the centre x sinc(f T)
    f, rate = 3.0, 50.0
    t = np.arange(2000) / FS
    x = np.vstack([np.sin(2 * np.pi * f * t), np.full(t.size, 2.5)])
    means = BlockMeans(rate)
    outs = [means.push(b) for b in _blocks(x, 37)]  # blocks do not align with windows
    stamps = np.concatenate([o.stamps_ns for o in outs])
    values = np.hstack([o.values for o in outs])
    assert values.shape == (2, 100)  # 2 s at 50 Hz
    centre = (stamps - 10**18) / 1e9
    n = round(FS / rate)
    np.testing.assert_allclose(centre, (np.arange(100) * n + (n - 1) / 2) / FS, atol=1e-9)
    # the discrete mean of n samples: sin(centre) * sin(pi f n / fs) / (n sin(pi f / fs))
    gain = np.sin(np.pi * f * n / FS) / (n * np.sin(np.pi * f / FS))
    np.testing.assert_allclose(values[0], gain * np.sin(2 * np.pi * f * centre), atol=1e-12)
    np.testing.assert_allclose(values[1], 2.5)


def test_a_gap_starts_a_new_window() -> None:
    x = np.ones((2, 30))
    means = BlockMeans(100.0)  # windows of 10 samples
    assert means.push(_blocks(x, 15)[0]).values.shape[1] == 1  # 5 samples left pending
    later = SignalBlock(("a", "b"), FS, 100, 3.0 * np.ones((2, 10)),
                        stamp_ns=10**18 + 100 * 10**6)
    out = means.push(later)  # not where the stream was: the pending 5 are dropped
    np.testing.assert_allclose(out.values, 3.0)
    assert out.stamps_ns[0] == 10**18 + 100 * 10**6 + 4_500_000


def test_bad_rate_is_refused() -> None:
    with pytest.raises(OptionError, match="rate_hz"):
        BlockMeans(0.0)


@pytest.mark.ros
def test_display_node_publishes_joint_states(domain_id: int) -> None:
    import rclpy
    from modal_twin_msgs.msg import SignalBlock as SignalBlockMsg
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import JointState

    from modal_twin.io.convert import block_to_msg
    from modal_twin.io.ros import qos_for
    from modal_twin.viz.node import DisplayNode

    rclpy.init(domain_id=domain_id, args=["display", "--ros-args", "-p", "rate_hz:=100.0"])
    node = DisplayNode()
    probe = rclpy.create_node("probe")
    got: list[JointState] = []
    probe.create_subscription(JointState, "/display/measurement", got.append,
                              qos_for("/display/measurement"))
    pub = probe.create_publisher(SignalBlockMsg, "/measurement/frames",
                                 qos_for("/measurement/frames"))
    ex = SingleThreadedExecutor()
    ex.add_node(node)
    ex.add_node(probe)
    try:
        for _ in range(100):
            ex.spin_once(timeout_sec=0.05)
            if pub.get_subscription_count() and node.pubs["/display/measurement"] \
                    .get_subscription_count():
                break
        x = np.vstack([np.arange(200.0), -np.arange(200.0)])
        for b in _blocks(x, 50):
            pub.publish(block_to_msg(b, SignalBlockMsg))
        for _ in range(100):
            ex.spin_once(timeout_sec=0.05)
            if len(got) >= 20:
                break
        assert len(got) == 20  # 0.2 s at 100 Hz
        assert list(got[0].name) == ["a", "b"]
        assert list(got[0].position) == [4.5, -4.5]  # mean of samples 0..9
        assert got[1].header.stamp.sec == 10**9 and got[1].header.stamp.nanosec == 14_500_000
    finally:
        node.destroy_node()
        probe.destroy_node()
        rclpy.try_shutdown()
