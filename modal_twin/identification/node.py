"""Identification node: modes from a window of /measurement/frames.

Buffers the frames (the last ``window_s`` seconds, :class:`~modal_twin.block_window.BlockWindow`),
keeps the stream's channel map (``/measurement/channels``: the roles say which channels are
inputs and outputs; without one, the names do), runs
:func:`~modal_twin.identification.window.identify_window` on request (service
``~/run``, RunIdentification) or every ``period_s`` seconds, and publishes
``/identification/modes`` (ModalModel) and ``/identification/stabilization``. Bad data or a
bad request never stops the node: one logged line, and the service answers
``success=False`` with the reason.
"""

from __future__ import annotations

import time

from modal_twin_msgs.msg import ChannelMap, Mode
from modal_twin_msgs.msg import ModalModel as ModalModelMsg
from modal_twin_msgs.msg import SignalBlock as SignalBlockMsg
from modal_twin_msgs.msg import StabilizationDiagram as DiagramMsg
from modal_twin_msgs.srv import RunIdentification
from rclpy.node import Node

from modal_twin.block_window import BlockWindow
from modal_twin.channels import ChannelSpec
from modal_twin.identification.window import IdentificationConfig, identify_window, run_config
from modal_twin.io.convert import block_from_msg, channel_map_from_msg
from modal_twin.io.modal_convert import diagram_to_msg, modal_model_to_msg
from modal_twin.io.params import declare_config
from modal_twin.io.ros import guarded, guarded_service, qos_for, run_node

__all__ = ["IdentificationConfig", "IdentificationNode", "identify_window", "main"]


class IdentificationNode(Node):
    """Wiring: frames -> window -> identify_window -> modes and diagram."""

    def __init__(self, **kwargs: object) -> None:
        super().__init__("identification", **kwargs)  # type: ignore[arg-type]
        self.cfg = declare_config(self, IdentificationConfig)
        self.window = BlockWindow(self.cfg.window_s, "frames")
        self.runs = 0
        self.last_msg: ModalModelMsg | None = None
        self.channels: list[ChannelSpec] | None = None
        self.pub_modes = self.create_publisher(ModalModelMsg, "/identification/modes",
                                               qos_for("/identification/modes"))
        self.pub_diag = self.create_publisher(DiagramMsg, "/identification/stabilization",
                                              qos_for("/identification/stabilization"))
        self.create_subscription(SignalBlockMsg, "/measurement/frames",
                                 guarded(self, "frame", self._on_frame),
                                 qos_for("/measurement/frames"))
        self.create_subscription(ChannelMap, "/measurement/channels",
                                 guarded(self, "/measurement/channels", self._on_channels),
                                 qos_for("/measurement/channels"))
        self.create_service(RunIdentification, "~/run",
                            guarded_service(self, "~/run", self._on_run))
        if self.cfg.period_s > 0:
            self.create_timer(self.cfg.period_s, guarded(self, "scheduled run", self.run))

    def _on_frame(self, msg: SignalBlockMsg) -> None:
        blk = block_from_msg(msg)
        if not self.window.add(blk):
            self.get_logger().warning(f"frames: discontinuity or new channel layout at sample "
                                      f"{blk.first_index}; window restarted")

    def _on_channels(self, msg: ChannelMap) -> None:
        """Keep the stream's channel map (roles); a refused map changes nothing."""
        self.channels = channel_map_from_msg(msg)
        self.get_logger().info(f"channel map of {msg.source or 'the stream'}: "
                               f"{len(self.channels)} channels, identified by their roles")

    def run(self, method: str = "", max_order: int = 0, window_s: float = 0.0) -> str:
        """Identify on the window and publish; returns the summary (raises on any error)."""
        cfg, last_s = run_config(self.cfg, method, max_order, window_s)
        blk = self.window.joined(last_s)
        t0 = time.perf_counter()
        rec = identify_window(blk, cfg, self.channels)
        mm, diagram, outs = rec.modes, rec.diagram, rec.output_names
        source = f"/measurement/frames [{blk.first_index}, {blk.next_index}) {blk.source}"
        self.last_msg = modal_model_to_msg(mm, outs, ModalModelMsg, Mode, stamp_ns=blk.stamp_ns,
                                           source=source)
        self.pub_modes.publish(self.last_msg)
        self.pub_diag.publish(diagram_to_msg(diagram, DiagramMsg, stamp_ns=blk.stamp_ns))
        self.runs += 1
        text = (f"{rec.method}: {mm.f_hz.size} modes from {blk.n_samples} samples x "
                f"{blk.n_channels} channels in {time.perf_counter() - t0:.2f} s; "
                f"{rec.settings.describe()}" + "".join(f"; {n}" for n in rec.notes)
                + "".join(f"; warning: {w}" for w in rec.warnings))
        self.get_logger().info(text)
        return text

    def _on_run(self, req: RunIdentification.Request, res: RunIdentification.Response):
        res.message = self.run(str(req.method), req.max_order, req.window_s)
        res.success, res.model = True, self.last_msg
        return res


def main() -> int:
    """Entry point of ``identification_node``."""
    return run_node(IdentificationNode)


if __name__ == "__main__":
    import sys

    sys.exit(main())
