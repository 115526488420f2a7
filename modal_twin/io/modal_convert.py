"""Identification results <-> messages: ModalModel / Mode and StabilizationDiagram.

Works with rclpy message classes (passed in, so this module needs no generated code at
import time). Complex shapes travel as real and imaginary arrays, one entry per channel
of ``ModalModel.channel_names``; MPC (Eqs. (6)-(9) of [002]) and complexity are computed
here for each mode.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from modal_twin.errors import ShapeError
from modal_twin.identification.metrics import complexity, mpc
from modal_twin.identification.modal_model import ModalModel, StabilizationDiagram
from modal_twin.io.convert import ns_to_stamp, to_float_array
from modal_twin.validation import check_field

__all__ = ["diagram_to_msg", "modal_model_from_msg", "modal_model_to_msg", "stability_codes"]


def modal_model_to_msg(
    mm: ModalModel, channel_names: list[str] | tuple[str, ...], msg_cls: Any, mode_cls: Any,
    *, stamp_ns: int = 0, source: str = "", model_version: str = "",
) -> Any:
    """:class:`ModalModel` -> ``modal_twin_msgs/msg/ModalModel``.

    Raises
    ------
    ShapeError
        If the shapes do not have one row per channel name.
    """
    names = list(channel_names)
    if mm.shapes.shape[0] != len(names):
        msg = (f"channel_names: expected {mm.shapes.shape[0]} names (shape rows), "
               f"got {len(names)}")
        raise ShapeError(msg)
    msg = msg_cls()
    msg.header.stamp = ns_to_stamp(stamp_ns, type(msg.header.stamp))
    msg.method = mm.method
    msg.order = int(mm.order)
    msg.source = source
    msg.model_version = model_version
    msg.channel_names = names
    n = mm.f_hz.size
    mp = mpc(mm.shapes) if n and names else np.full(n, np.nan)
    cx = complexity(mm.shapes) if n and names else np.full(n, np.nan)
    modes = []
    for k in range(n):
        m = mode_cls()
        m.frequency_hz = float(mm.f_hz[k])
        m.damping_ratio = float(mm.zeta[k])
        m.std_frequency_hz = float(mm.std_f_hz[k])
        m.std_damping_ratio = float(mm.std_zeta[k])
        m.shape_real = to_float_array(mm.shapes[:, k].real)
        m.shape_imag = to_float_array(mm.shapes[:, k].imag)
        m.mpc = float(mp[k])
        m.complexity = float(cx[k])
        modes.append(m)
    msg.modes = modes
    return msg


def modal_model_from_msg(msg: Any) -> tuple[ModalModel, tuple[str, ...]]:
    """``ModalModel`` message -> (:class:`ModalModel`, channel names).

    ``mode_orders`` are set to the message's order and ``n_support`` to 0 (not carried).

    Raises
    ------
    ShapeError
        If a mode's shape does not have one entry per channel name.
    """
    names = tuple(msg.channel_names)
    n = len(msg.modes)
    check_field(len(names), "ModalModel.channel_names (count)", "n_channels")
    check_field(n, "ModalModel.modes (count)", "n_channels")
    shapes = np.zeros((len(names), n), dtype=np.complex128)
    for k, m in enumerate(msg.modes):
        re, im = np.asarray(m.shape_real, float), np.asarray(m.shape_imag, float)
        if re.size != len(names) or im.size != len(names):
            text = (f"Mode[{k}].shape_real/imag: expected {len(names)} entries, got "
                    f"{re.size}/{im.size}")
            raise ShapeError(text)
        shapes[:, k] = re + 1j * im

    def col(attr: str) -> np.ndarray:
        return np.array([float(getattr(m, attr)) for m in msg.modes], dtype=np.float64)

    order = int(msg.order)
    return ModalModel(
        col("frequency_hz"), col("damping_ratio"), shapes, col("std_frequency_hz"),
        col("std_damping_ratio"), str(msg.method), order,
        np.full(n, order, dtype=np.int64), np.zeros(n, dtype=np.int64),
    ), names


def stability_codes(d: StabilizationDiagram) -> tuple[np.ndarray, ...]:
    """Per order, the code of each pole: 0 new, 1 stable f, 2 + damping, 3 + shape (all)."""
    out = []
    for sf, sz, st in zip(d.stable_f, d.stable_zeta, d.stable, strict=True):
        c = sf.astype(np.uint8) + (sf & sz).astype(np.uint8) + st.astype(np.uint8)
        out.append(c)
    return tuple(out)


def diagram_to_msg(d: StabilizationDiagram, msg_cls: Any, *, stamp_ns: int = 0) -> Any:
    """:class:`StabilizationDiagram` -> flattened ``StabilizationDiagram`` message."""
    msg = msg_cls()
    msg.header.stamp = ns_to_stamp(stamp_ns, type(msg.header.stamp))
    msg.method = d.method
    codes = stability_codes(d)
    orders = [np.full(p.f_hz.size, int(o), dtype=np.uint32)
              for o, p in zip(d.orders, d.poles, strict=True)]
    cat = np.concatenate
    msg.order = cat(orders).astype(np.uint32).tolist() if orders else []
    msg.frequency_hz = to_float_array(cat([p.f_hz for p in d.poles]) if d.poles else [])
    msg.damping_ratio = to_float_array(cat([p.zeta for p in d.poles]) if d.poles else [])
    msg.stability = cat(codes).astype(np.uint8).tobytes() if codes else b""
    return msg

