"""One identification run on a window of frames: the identification node's single call.

The configuration (:class:`IdentificationConfig`, one ROS parameter per field) chooses
N4SID (``inputs`` channels as measured inputs) or output-only SSI-cov, the orders and the
stability tolerances; :func:`identify_window` returns the selected modes and the diagram.
"""

from __future__ import annotations

import dataclasses
import fnmatch
import warnings
from dataclasses import dataclass, field

import numpy as np

from modal_twin.acquisition.decimation import decimate
from modal_twin.errors import ConfigError, SignalError
from modal_twin.identification.modal_model import ModalModel, StabilizationDiagram
from modal_twin.identification.n4sid import n4sid
from modal_twin.identification.ssi_cov import ssi_cov
from modal_twin.identification.stabilization import select_modes, stabilization_diagram
from modal_twin.signal_block import SignalBlock
from modal_twin.validation import check_field

__all__ = ["METHODS", "IdentificationConfig", "identify_window", "run_config"]

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
        check_field(self.max_order, "max_order", "max_order")
        check_field(self.window_s, "window_s", "window_s")
        check_field(self.period_s, "period_s", "window_s")
        check_field(self.block_rows, "block_rows", "block_rows")
        check_field(self.order_step, "order_step", "max_order")
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




def run_config(cfg: IdentificationConfig, method: str = "", max_order: int = 0,
               window_s: float = 0.0) -> tuple[IdentificationConfig, float]:
    """Return the configuration and window of one run request (empty / 0 fields: ``cfg``'s).

    Raises
    ------
    OptionError, ConfigError
        A field outside its limits (:data:`~modal_twin.validation.LIMITS`), named.

    """
    order = int(check_field(max_order, "max_order", "max_order"))
    win = check_field(window_s, "window_s", "window_s")
    if method or order:
        cfg = dataclasses.replace(cfg, method=method or cfg.method,
                                  max_order=order or cfg.max_order)
    return cfg, win
