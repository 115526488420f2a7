"""Display node: /measurement/frames and /twin/prediction as plottable sensor_msgs/JointState.

One message per display sample: ``header.stamp`` the window's centre, ``name`` the
channels, ``position`` their window means (:class:`~modal_twin.viz.display.BlockMeans`).
PlotJuggler and Foxglove plot ``/display/measurement/position[F1_C1_x]`` without plugins.
Off by default; a scenario starts it (executable ``display_node``) and may record it.
With ``meshcat: true`` it also starts a meshcat server on 127.0.0.1 (stopped by PID) and
shows the structure with every sensor coloured by the twin's residual there
(:mod:`modal_twin.viz.live`), updated twice a second.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from modal_twin_msgs.msg import SignalBlock as SignalBlockMsg
from rclpy.node import Node
from sensor_msgs.msg import JointState

from modal_twin.io.convert import block_from_msg
from modal_twin.io.params import declare_config
from modal_twin.io.ros import guarded, qos_for, run_node
from modal_twin.viz.display import BlockMeans
from modal_twin.viz.live import LiveView

__all__ = ["DisplayConfig", "DisplayNode", "main"]

STREAMS = {"/measurement/frames": "/display/measurement",
           "/twin/prediction": "/display/twin"}


@dataclass(frozen=True, slots=True)
class DisplayConfig:
    """Parameters of the display node."""

    rate_hz: float = field(default=20.0, metadata={"doc": "display samples per second"})
    meshcat: bool = field(default=False, metadata={"doc": "live 3D view coloured by residual"})
    model_file: str = field(default="config/structures/building.yaml",
                            metadata={"doc": "structure drawn by the live view"})
    web_port: int = field(default=7000, metadata={"doc": "meshcat web port (127.0.0.1)"})


class DisplayNode(Node):
    """Wiring: signal blocks -> window means -> JointState per sample."""

    def __init__(self) -> None:
        super().__init__("display")
        self.cfg = declare_config(self, DisplayConfig)
        self.pubs = {}
        self.view = LiveView(self.cfg.model_file, self.cfg.web_port) if self.cfg.meshcat \
            else None
        if self.view is not None:
            self.get_logger().info(f"live view: {self.view.url}")
            self.create_timer(0.5, guarded(self, "live view", self.view.refresh))
        for src, dst in STREAMS.items():
            means = BlockMeans(self.cfg.rate_hz)
            pub = self.create_publisher(JointState, dst, qos_for(dst))
            self.pubs[dst] = pub
            self.create_subscription(
                SignalBlockMsg, src,
                guarded(self, src, lambda msg, m=means, p=pub: self._on_block(msg, m, p)),
                qos_for(src))

    def _on_block(self, msg: SignalBlockMsg, means: BlockMeans, pub: object) -> None:
        out = means.push(block_from_msg(msg))
        if self.view is not None:
            self.view.push(out, twin=pub is self.pubs.get("/display/twin"))
        names = list(out.channel_names)
        for k, stamp in enumerate(out.stamps_ns):
            js = JointState()
            js.header.stamp.sec, js.header.stamp.nanosec = divmod(int(stamp), 10**9)
            js.name = names
            js.position = [float(x) for x in out.values[:, k]]
            pub.publish(js)  # type: ignore[attr-defined]


    def close(self) -> None:
        """Stop the live view's server."""
        if self.view is not None:
            self.view.close()


def main() -> int:
    """Entry point of ``display_node``."""
    return run_node(DisplayNode)
