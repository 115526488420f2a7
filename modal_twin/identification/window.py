"""One identification run on a window of frames: the identification node's single call.

The configuration (:class:`IdentificationConfig`, one ROS parameter per field) is turned
into :class:`~modal_twin.identification.record.IdentifyOptions` (0 / ``""`` = from the
record) and :func:`identify_window` calls
:func:`~modal_twin.identification.record.identify_record`, as ``modal-twin identify`` and
``campaign`` do: the same record gives the same modes on every path.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field

from modal_twin.channels import ChannelSpec
from modal_twin.errors import ConfigError, OptionError
from modal_twin.identification.record import (
    METHODS,
    SELECTIONS,
    IdentifyOptions,
    RecordModes,
    identify_record,
)
from modal_twin.signal_block import SignalBlock
from modal_twin.validation import check_field

__all__ = ["METHODS", "IdentificationConfig", "identify_window", "run_config"]


def _names(text: str) -> tuple[str, ...] | None:
    return tuple(n.strip() for n in text.split(",") if n.strip()) or None


@dataclass(frozen=True)
class IdentificationConfig:
    """Parameters of the identification node (each one a ROS parameter; 0 / '' = auto)."""

    method: str = field(default="", metadata={
        "doc": "n4sid | ssi-cov | polymax ('' = n4sid with driven inputs, else ssi-cov)"})
    window_s: float = field(default=120.0, metadata={"doc": "seconds of frames buffered"})
    period_s: float = field(default=0.0, metadata={"doc": "run every period_s s (0 = off)"})
    max_order: int = field(default=0, metadata={"doc": "highest model order (0: auto)"})
    order_step: int = field(default=2, metadata={"doc": "step between model orders"})
    block_rows: int = field(default=0, metadata={"doc": "Hankel block rows (0 = auto)"})
    inputs: str = field(default="", metadata={
        "doc": "input channels name,name,... ('' = the channels of role input)"})
    outputs: str = field(default="", metadata={
        "doc": "output channels name,name,... ('' = the channels of role output)"})
    fs_target_hz: float = field(default=0.0,
                                metadata={"doc": "decimate to about this rate (0: auto)"})
    f_min_hz: float = field(default=0.0, metadata={"doc": "lower band edge (0: auto)"})
    f_max_hz: float = field(default=0.0, metadata={"doc": "upper band edge (0: auto)"})
    rel_tol_f: float = field(default=0.01, metadata={"doc": "stability: frequency"})
    rel_tol_zeta: float = field(default=0.05, metadata={"doc": "stability: damping"})
    mac_min: float = field(default=0.95, metadata={"doc": "stability: MAC"})
    relax: bool = field(default=True, metadata={
        "doc": "no mode at these thresholds: try 2 %, 20 %, MAC 0.9"})
    selection: str = field(default="", metadata={
        "doc": "clusters | stability ('' = clusters, stability for polymax)"})
    zeta_max: float = field(default=0.2, metadata={"doc": "reject poles above this damping"})

    def __post_init__(self) -> None:
        if self.method and self.method not in METHODS:
            msg = f"method: expected one of {list(METHODS)} or '', got {self.method!r}"
            raise ConfigError(msg)
        if self.selection and self.selection not in SELECTIONS:
            msg = f"selection: expected one of {list(SELECTIONS)}, got {self.selection!r}"
            raise ConfigError(msg)
        if not (self.window_s > 0 and self.period_s >= 0 and self.max_order in range(0, 401)
                and self.max_order != 1 and self.order_step >= 1 and self.block_rows >= 0):
            msg = (f"window_s > 0, period_s >= 0, max_order 0 or >= 2, order_step >= 1, "
                   f"block_rows >= 0 expected, got {self.window_s}, {self.period_s}, "
                   f"{self.max_order}, {self.order_step}, {self.block_rows}")
            raise ConfigError(msg)
        check_field(self.max_order, "max_order", "max_order")
        check_field(self.window_s, "window_s", "window_s")
        check_field(self.period_s, "period_s", "window_s")
        check_field(self.block_rows, "block_rows", "block_rows")
        check_field(self.order_step, "order_step", "max_order")
        if min(self.fs_target_hz, self.f_min_hz, self.f_max_hz) < 0:
            msg = (f"fs_target_hz, f_min_hz, f_max_hz: expected >= 0, got "
                   f"{self.fs_target_hz}, {self.f_min_hz}, {self.f_max_hz}")
            raise ConfigError(msg)

    def options(self) -> IdentifyOptions:
        """Return these choices as :func:`identify_record`'s options (0 / '' -> None)."""
        orders = (tuple(range(self.order_step, self.max_order + 1, self.order_step))
                  if self.max_order else None)
        return IdentifyOptions(
            method=self.method or None, inputs=_names(self.inputs),
            outputs=_names(self.outputs), f_max_hz=self.f_max_hz or None,
            f_min_hz=self.f_min_hz or None, fs_target_hz=self.fs_target_hz or None,
            block_rows=self.block_rows or None,
            orders=orders if orders is None or len(orders) >= 2 else None,
            thresholds={"rel_tol_f": self.rel_tol_f, "rel_tol_zeta": self.rel_tol_zeta,
                        "mac_min": self.mac_min},
            relax=self.relax, selection=self.selection or None, zeta_max=self.zeta_max)


def identify_window(block: SignalBlock, cfg: IdentificationConfig,
                    channels: Sequence[ChannelSpec] | None = None) -> RecordModes:
    """Modes of one window: the node's single call into the identification stage.

    ``channels`` is the stream's channel map (``/measurement/channels``); without one,
    roles come from the channel names.

    Raises
    ------
    ModalTwinError
        Any error of the estimators (too few samples, NaN, constant channels, ...).
    """
    try:
        opts = cfg.options()
    except OptionError as err:
        raise ConfigError(str(err)) from err
    return identify_record(block, channels, opts)


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
