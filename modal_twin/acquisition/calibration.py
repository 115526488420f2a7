"""Sensitivity calibration: raw transducer volts to SI units, channel by channel.

A transducer of sensitivity :math:`S_c` (V per SI unit, e.g. V/(m/s^2)) and offset
:math:`V_{0,c}` gives :math:`x_c = (v_c - V_{0,c}) / S_c`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from modal_twin._types import FloatArray
from modal_twin.errors import OptionError, ShapeError
from modal_twin.validation import as_channels

__all__ = ["calibrate"]


def calibrate(
    v: ArrayLike,
    sensitivity: ArrayLike,
    *,
    offset_v: ArrayLike | None = None,
) -> FloatArray:
    """Convert volts to SI units with a per-channel sensitivity.

    Parameters
    ----------
    v : array_like, shape (n_channels, n_samples) or (n_samples,)
        Raw samples in volts.
    sensitivity : array_like, shape (n_channels,) or scalar
        Sensitivity in V per SI unit; negative values flip the polarity, zero is refused.
    offset_v : array_like, shape (n_channels,) or scalar, optional
        Zero offset in volts subtracted before scaling (default 0).

    Returns
    -------
    ndarray, shape (n_channels, n_samples)
        Samples in SI units.

    Raises
    ------
    ShapeError
        If ``sensitivity`` or ``offset_v`` does not match the number of channels.
    OptionError
        If a sensitivity is zero or not finite.
    SignalError
        If ``v`` holds NaN or Inf.

    Examples
    --------
    >>> calibrate([[0.1, 0.2]], [0.01])  # 10 mV/(m/s^2)
    array([[10., 20.]])
    """
    x = as_channels(v, "v", min_samples=1)
    n_ch = x.shape[0]
    s = np.asarray(sensitivity, dtype=np.float64)
    s = np.full(n_ch, float(s)) if s.ndim == 0 else s
    if s.shape != (n_ch,):
        msg = f"sensitivity: expected shape ({n_ch},), got {s.shape}"
        raise ShapeError(msg)
    if not np.all(np.isfinite(s)) or np.any(s == 0.0):
        bad = np.nonzero(~np.isfinite(s) | (s == 0.0))[0].tolist()
        msg = f"sensitivity: expected finite non-zero values, got {s[bad].tolist()} at {bad}"
        raise OptionError(msg)
    off = np.zeros(n_ch) if offset_v is None else np.asarray(offset_v, dtype=np.float64)
    off = np.full(n_ch, float(off)) if off.ndim == 0 else off
    if off.shape != (n_ch,):
        msg = f"offset_v: expected shape ({n_ch},), got {off.shape}"
        raise ShapeError(msg)
    return (x - off[:, None]) / s[:, None]
