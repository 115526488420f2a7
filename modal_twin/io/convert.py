"""Conversion between messages and numpy objects.

Works on both kinds of message object: the rclpy classes of ``modal_twin_msgs`` (live
topics) and the rosbags dataclasses (bags). Reading goes by attribute, so one function
serves both; writing takes the target class.
"""

from __future__ import annotations

import array
from typing import Any, cast

import numpy as np

from modal_twin.errors import ShapeError
from modal_twin.signal_block import SignalBlock
from modal_twin.validation import check_field

__all__ = [
    "SPAN_PREFIX",
    "block_from_msg",
    "block_to_msg",
    "block_to_rosbags",
    "channel_map_from_msg",
    "channel_map_to_msg",
    "metrics_span",
    "metrics_to_msg",
    "ns_to_stamp",
    "stamp_to_ns",
    "theta_from_msg",
    "to_float_array",
]


def stamp_to_ns(stamp: Any) -> int:
    """``builtin_interfaces/Time`` -> integer nanoseconds."""
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def ns_to_stamp(ns: int, cls: Any) -> Any:
    """Integer nanoseconds -> ``builtin_interfaces/Time`` of class ``cls``."""
    return cls(sec=int(ns // 1_000_000_000), nanosec=int(ns % 1_000_000_000))


def to_float_array(values: Any) -> array.array[float]:
    """Fast float64 sequence for an rclpy message field (no per-element checks)."""
    out = array.array("d")
    out.frombytes(np.ascontiguousarray(values, dtype=np.float64).tobytes())
    return out


def block_from_msg(msg: Any) -> SignalBlock:
    """SignalBlock message (rclpy or rosbags) -> :class:`SignalBlock`.

    Raises
    ------
    ShapeError
        If ``data`` does not hold ``len(channel_names) * n_samples`` values.
    OptionError
        A channel count, sample count or sample rate outside :data:`~modal_twin.validation.LIMITS`.
    """
    names = tuple(str(c) for c in msg.channel_names)
    check_field(len(names), "SignalBlock.channel_names (count)", "n_channels")
    n = int(check_field(msg.n_samples, "SignalBlock.n_samples", "n_samples"))
    check_field(msg.sample_rate_hz, "SignalBlock.sample_rate_hz", "sample_rate_hz")
    data = np.frombuffer(msg.data, dtype=np.float64) if len(msg.data) else np.zeros(0)
    if data.size != len(names) * n:
        text = (
            f"SignalBlock.data: expected {len(names)} channels x {n} samples = "
            f"{len(names) * n} values, got {data.size}"
        )
        raise ShapeError(text)
    return SignalBlock(
        channel_names=names,
        fs_hz=float(msg.sample_rate_hz),
        first_index=int(msg.first_sample_index),
        data=data.reshape(len(names), n).copy(),
        stamp_ns=stamp_to_ns(msg.header.stamp),
        source=str(msg.source),
    )


def block_to_msg(block: SignalBlock, msg_cls: Any) -> Any:
    """:class:`SignalBlock` -> rclpy ``modal_twin_msgs/msg/SignalBlock``."""
    msg = msg_cls()
    msg.header.stamp.sec = int(block.stamp_ns // 1_000_000_000)
    msg.header.stamp.nanosec = int(block.stamp_ns % 1_000_000_000)
    msg.header.frame_id = block.source
    msg.source = block.source
    msg.channel_names = list(block.channel_names)
    msg.sample_rate_hz = float(block.fs_hz)
    msg.first_sample_index = int(block.first_index)
    msg.n_samples = int(block.n_samples)
    msg.data = to_float_array(block.data.ravel())
    return msg


def block_to_rosbags(block: SignalBlock, store: Any) -> Any:
    """:class:`SignalBlock` -> rosbags ``modal_twin_msgs/msg/SignalBlock`` of ``store``."""
    types = store.types
    header = types["std_msgs/msg/Header"](
        stamp=ns_to_stamp(block.stamp_ns, types["builtin_interfaces/msg/Time"]),
        frame_id=block.source,
    )
    if block.data.ndim != 2:
        text = f"block.data: expected 2-D, got {block.data.ndim}-D"
        raise ShapeError(text)
    return types["modal_twin_msgs/msg/SignalBlock"](
        header=header,
        source=block.source,
        channel_names=list(block.channel_names),
        sample_rate_hz=float(block.fs_hz),
        first_sample_index=int(block.first_index),
        n_samples=int(block.n_samples),
        data=np.ascontiguousarray(block.data, dtype=np.float64).ravel(),
    )


def channel_map_to_msg(channels: Any, source: str, msg_cls: Any, info_cls: Any) -> Any:
    """Sequence of :class:`~modal_twin.channels.ChannelSpec` -> ``ChannelMap`` message."""
    msg = msg_cls()
    msg.source = source
    for c in channels:
        info = info_cls()
        info.name, info.quantity, info.unit = c.name, c.quantity, c.unit
        info.location, info.direction = c.location, c.direction
        info.sensitivity = float(c.sensitivity)
        info.position_m = [float(v) for v in c.position_m]
        info.role, info.node = c.role, c.node
        msg.channels.append(info)
    return msg


def channel_map_from_msg(msg: Any) -> list[Any]:
    """``ChannelMap`` message -> list of :class:`~modal_twin.channels.ChannelSpec`.

    Raises
    ------
    ConfigError
        A channel with a role that is not one of :data:`~modal_twin.channels.ROLES`.
    OptionError
        More channels than :data:`~modal_twin.validation.LIMITS` allow.
    """
    from modal_twin.channels import QUANTITY_UNITS, ChannelSpec

    check_field(len(msg.channels), "ChannelMap.channels (count)", "n_channels")
    return [ChannelSpec(c.name, c.quantity, c.location, c.direction, float(c.sensitivity),
                        cast("tuple[float, float, float]", tuple(float(v) for v in c.position_m)),
                        role=c.role, node=c.node,
                        unit_si="" if QUANTITY_UNITS.get(c.quantity) == c.unit else c.unit)
            for c in msg.channels]


SPAN_PREFIX = "samples "
"""``ComparisonMetrics.header.frame_id`` = ``samples <first>..<last>``: the sample indices
of the stream the metrics span (a replayed record is whole when they are its first and last
and ``samples`` counts them all)."""


def metrics_to_msg(names: list[str], m: Any, window_s: float, version: str,
                   msg_cls: Any, span: tuple[int, int] | None = None) -> Any:
    """:class:`~modal_twin.twin.metrics.ChannelMetrics` -> ``ComparisonMetrics``.

    ``span`` (first, last sample index of the window) goes into ``header.frame_id``
    (:data:`SPAN_PREFIX`).
    """
    msg = msg_cls()
    if span is not None:
        msg.header.frame_id = f"{SPAN_PREFIX}{int(span[0])}..{int(span[1])}"
    msg.model_version = version
    msg.window_s = float(window_s)
    msg.channel_names = list(names)
    msg.rms_error = to_float_array(m.rms_error_pct)
    msg.residual_rms = to_float_array(m.residual_pct)
    msg.rms_measured = to_float_array(m.rms_measured)
    msg.rms_predicted = to_float_array(m.rms_predicted)
    finite = m.rms_error_pct[np.isfinite(m.rms_error_pct)]
    msg.overall_rms_error = float(finite.max()) if finite.size else float("nan")
    msg.samples = int(m.samples)
    return msg


def metrics_span(msg: Any) -> tuple[int, int] | None:
    """(first, last) sample index a ``ComparisonMetrics`` spans (None when it does not say)."""
    text = str(msg.header.frame_id)
    first, sep, last = text.removeprefix(SPAN_PREFIX).partition("..")
    if not text.startswith(SPAN_PREFIX) or not sep:
        return None
    try:
        return int(first), int(last)
    except ValueError:
        return None


def theta_from_msg(msg: Any) -> dict[str, float]:
    """``ModelParameters`` names and values -> a parameter dict, checked.

    Raises
    ------
    OptionError
        Names and values of different lengths, too many, a repeated name or a value that
        is not finite (:data:`~modal_twin.validation.LIMITS`).
    """
    from modal_twin.errors import OptionError

    names = [str(n) for n in msg.names]
    values = list(msg.values)
    check_field(len(names), "ModelParameters.names (count)", "n_parameters")
    if len(names) != len(values) or len(set(names)) != len(names):
        text = (f"ModelParameters: expected unique names, one value each, got {len(names)} "
                f"names ({len(set(names))} distinct) and {len(values)} values")
        raise OptionError(text)
    return {n: check_field(v, f"ModelParameters.values[{n!r}]", "parameter")
            for n, v in zip(names, values, strict=True)}
