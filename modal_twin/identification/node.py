"""Identification node: modes from a window of /measurement/frames (item 5 of issue 4).

Buffers the frames (the last ``window_s`` seconds; a gap, repeat or change of channel
layout restarts the buffer), runs N4SID (``table_*`` channels as inputs) or output-only
SSI-cov on request (service ``~/run``, RunIdentification) or every ``period_s``
seconds, and publishes ``/identification/modes`` (ModalModel) and
``/identification/stabilization`` (StabilizationDiagram). Bad data never stops the node:
the error is logged and the service answers ``success=False`` with the reason.
"""

from __future__ import annotations

import collections
import dataclasses
import fnmatch
import time
import warnings
from dataclasses import dataclass, field

import numpy as np
from modal_twin_msgs.msg import ModalModel as ModalModelMsg
from modal_twin_msgs.msg import Mode
from modal_twin_msgs.msg import SignalBlock as SignalBlockMsg
from modal_twin_msgs.msg import StabilizationDiagram as DiagramMsg
from modal_twin_msgs.srv import RunIdentification
from rclpy.node import Node

from modal_twin.acquisition.decimation import decimate
from modal_twin.errors import ConfigError, ModalTwinError, SignalError
from modal_twin.identification.modal_model import ModalModel, StabilizationDiagram
from modal_twin.identification.n4sid import n4sid
from modal_twin.identification.ssi_cov import ssi_cov
from modal_twin.identification.stabilization import select_modes, stabilization_diagram
from modal_twin.io.convert import block_from_msg
from modal_twin.io.modal_convert import diagram_to_msg, modal_model_to_msg
from modal_twin.io.params import declare_config
from modal_twin.io.ros import qos_for, run_node
from modal_twin.signal_block import SignalBlock, concatenate_blocks

__all__ = ["IdentificationConfig", "IdentificationNode", "identify_window", "main"]

METHODS = ("n4sid", "ssi_cov")


@dataclass(frozen=True)
class IdentificationConfig:
    """Parameters of the identification node (each one a ROS parameter)."""

    method: str = field(default="n4sid", metadata={"doc": "n4sid | ssi_cov"})
    window_s: float = field(default=120.0, metadata={"doc": "seconds of frames buffered"})
    period_s: float = field(default=0.0, metadata={"doc": "run every period_s s (0 = off)"})
    max_order: int = field(default=40, metadata={"doc": "highest model order"})
    order_step: int = field(default=2, metadata={"doc": "step between model orders"})
    block_rows: int = field(default=0, metadata={"doc": "Hankel block rows (0 = auto)"})
    inputs: str = field(default="table_*", metadata={"doc": "glob of input channels (n4sid)"})
    outputs: str = field(default="*", metadata={"doc": "glob of output channels"})
    fs_target_hz: float = field(default=0.0,
                                metadata={"doc": "decimate to about this rate (0: keep)"})
    f_min_hz: float = field(default=0.0,
                            metadata={"doc": "lowest mode of interest (sets block rows; 0: auto)"})
    rel_tol_f: float = field(default=0.01, metadata={"doc": "stability: frequency"})
    rel_tol_zeta: float = field(default=0.05, metadata={"doc": "stability: damping"})
    mac_min: float = field(default=0.95, metadata={"doc": "stability: MAC"})
    zeta_max: float = field(default=0.2, metadata={"doc": "reject poles above this damping"})

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            msg = f"method: expected one of {METHODS}, got {self.method!r}"
            raise ConfigError(msg)
        if not (self.window_s > 0 and self.period_s >= 0 and self.max_order >= 2
                and self.order_step >= 1 and self.block_rows >= 0):
            msg = (f"window_s > 0, period_s >= 0, max_order >= 2, order_step >= 1, "
                   f"block_rows >= 0 expected, got {self.window_s}, {self.period_s}, "
                   f"{self.max_order}, {self.order_step}, {self.block_rows}")
            raise ConfigError(msg)
        if self.fs_target_hz < 0 or self.f_min_hz < 0:
            msg = (f"fs_target_hz, f_min_hz: expected >= 0, got {self.fs_target_hz}, "
                   f"{self.f_min_hz}")
            raise ConfigError(msg)


def identify_window(
    block: SignalBlock, cfg: IdentificationConfig
) -> tuple[ModalModel, StabilizationDiagram, tuple[str, ...]]:
    """Modes of one window: the node's single call into the identification stage.

    Returns the selected modes, the diagram and the output channel names (shape rows).

    Raises
    ------
    ModalTwinError
        Any error of the estimators (too few samples, NaN, constant channels, ...).
    """
    names = block.channel_names
    is_in = np.array([fnmatch.fnmatch(n, cfg.inputs) for n in names])
    is_out = ~is_in & np.array([fnmatch.fnmatch(n, cfg.outputs) for n in names])
    outs = tuple(n for n, o in zip(names, is_out, strict=True) if o)
    if not outs:
        msg = f"frames: expected output channels besides the inputs {cfg.inputs!r}, got {names}"
        raise SignalError(msg)
    orders = range(cfg.order_step, cfg.max_order + 1, cfg.order_step)
    br = cfg.block_rows or None
    data, fs = block.data, block.fs_hz
    if cfg.fs_target_hz > 0 and fs > 1.5 * cfg.fs_target_hz:  # zero-phase, Sec. 3 of [004]
        d = decimate(data, fs, round(fs / cfg.fs_target_hz))
        data, fs = d.x, d.fs_hz
    active = is_in & (np.std(data, axis=1) > 0)  # a table axis that is not driven
    y = data[is_out]
    f_min = cfg.f_min_hz or None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # fewer std blocks: still a result
        if cfg.method == "n4sid":
            if not active.any():
                msg = (f"frames: n4sid needs driven input channels matching {cfg.inputs!r}, "
                       f"got {names}")
                raise SignalError(msg)
            sweep = n4sid(data[active], y, fs, orders=orders, block_rows=br, f_min_hz=f_min)
        else:
            sweep = ssi_cov(y, fs, orders=orders, block_rows=br, f_min_hz=f_min)
    diagram = stabilization_diagram(sweep, rel_tol_f=cfg.rel_tol_f,
                                    rel_tol_zeta=cfg.rel_tol_zeta, mac_min=cfg.mac_min)
    return select_modes(diagram, zeta_max=cfg.zeta_max), diagram, outs


class IdentificationNode(Node):
    """Wiring: frames -> buffer -> identify_window -> modes and diagram."""

    def __init__(self, **kwargs: object) -> None:
        super().__init__("identification", **kwargs)  # type: ignore[arg-type]
        self.cfg = declare_config(self, IdentificationConfig)
        self.buffer: collections.deque[SignalBlock] = collections.deque()
        self.n_buffered = 0
        self.n_received = 0
        self.runs = 0
        self.last_msg: ModalModelMsg | None = None
        self.pub_modes = self.create_publisher(ModalModelMsg, "/identification/modes",
                                               qos_for("/identification/modes"))
        self.pub_diag = self.create_publisher(DiagramMsg, "/identification/stabilization",
                                              qos_for("/identification/stabilization"))
        self.create_subscription(SignalBlockMsg, "/measurement/frames", self._on_frame,
                                 qos_for("/measurement/frames"))
        self.create_service(RunIdentification, "~/run", self._on_run)
        if self.cfg.period_s > 0:
            self.create_timer(self.cfg.period_s, self._on_timer)

    def _on_frame(self, msg: SignalBlockMsg) -> None:
        try:
            blk = block_from_msg(msg)
        except ModalTwinError as err:
            self.get_logger().error(f"frame dropped: {err}")
            return
        last = self.buffer[-1] if self.buffer else None
        if last is not None and (blk.channel_names != last.channel_names
                                 or blk.fs_hz != last.fs_hz
                                 or blk.first_index != last.next_index):
            self.get_logger().warning(
                f"frames: discontinuity at sample {blk.first_index} (expected "
                f"{last.next_index}) or new channel layout; buffer restarted")
            self.buffer.clear()
            self.n_buffered = 0
        self.buffer.append(blk)
        self.n_buffered += blk.n_samples
        self.n_received += blk.n_samples
        keep = int(self.cfg.window_s * blk.fs_hz)
        while self.buffer and self.n_buffered - self.buffer[0].n_samples >= keep:
            self.n_buffered -= self.buffer.popleft().n_samples

    def run(self, method: str = "", max_order: int = 0, window_s: float = 0.0
            ) -> tuple[ModalModel | None, str]:
        """Identify on the buffer; returns (modes or None, message). Never raises."""
        try:
            cfg = self.cfg
            if method or max_order:
                cfg = dataclasses.replace(cfg, method=method or cfg.method,
                                          max_order=max_order or cfg.max_order)
            if not self.buffer:
                return None, "no frames buffered on /measurement/frames"
            blk = concatenate_blocks(list(self.buffer))
            if window_s > 0:
                n = min(blk.n_samples, max(int(window_s * blk.fs_hz), 1))
                blk = SignalBlock(blk.channel_names, blk.fs_hz,
                                  blk.first_index + blk.n_samples - n, blk.data[:, -n:],
                                  blk.stamp_ns + round((blk.n_samples - n) / blk.fs_hz * 1e9),
                                  blk.source)
            t0 = time.perf_counter()
            mm, diagram, outs = identify_window(blk, cfg)
            sec = time.perf_counter() - t0
        except (ModalTwinError, ValueError, np.linalg.LinAlgError) as err:
            self.get_logger().error(f"identification failed: {err}")
            return None, f"{type(err).__name__}: {err}"
        except Exception as err:  # never let bad data take the node down
            self.get_logger().error(f"identification failed unexpectedly: {err!r}")
            return None, f"{type(err).__name__}: {err}"
        source = f"/measurement/frames [{blk.first_index}, {blk.next_index}) {blk.source}"
        msg = modal_model_to_msg(mm, outs, ModalModelMsg, Mode, stamp_ns=blk.stamp_ns,
                                 source=source)
        self.pub_modes.publish(msg)
        self.pub_diag.publish(diagram_to_msg(diagram, DiagramMsg, stamp_ns=blk.stamp_ns))
        self.runs += 1
        text = (f"{cfg.method}: {mm.f_hz.size} modes from {blk.n_samples} samples x "
                f"{blk.n_channels} channels in {sec:.2f} s")
        self.get_logger().info(text)
        self.last_msg = msg
        return mm, text

    def _on_run(self, req: RunIdentification.Request,
                res: RunIdentification.Response) -> RunIdentification.Response:
        mm, text = self.run(req.method, int(req.max_order), float(req.window_s))
        res.success = mm is not None
        res.message = text
        if mm is not None:
            res.model = self.last_msg
        return res

    def _on_timer(self) -> None:
        self.run()


def main() -> int:
    """Entry point of ``identification_node``."""
    return run_node(IdentificationNode)


if __name__ == "__main__":
    import sys

    sys.exit(main())
