"""Zero-phase anti-alias filtering and decimation (sec. 3 of [004]).

[004] low-passes the table and structure accelerations with an 8th-order Chebyshev type I
filter run "first forward and then backward" and downsamples 1 kHz -> 71.4 Hz (factor 14,
cut-off 28.6 Hz = 0.8 x the new Nyquist frequency). The forward-backward pass squares the
magnitude response and cancels the phase, so mode shapes keep their phase across channels.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.signal as sig
from numpy.typing import ArrayLike

from modal_twin._types import FloatArray
from modal_twin.errors import OptionError, ShapeError
from modal_twin.validation import as_channels, check_positive

__all__ = ["Decimated", "decimate", "lowpass_zero_phase"]

_FTYPES = ("cheby1", "butter")


@dataclass(frozen=True, slots=True)
class Decimated:
    """A decimated multichannel signal.

    Attributes
    ----------
    x : ndarray, shape (n_channels, n_samples_out)
        Filtered and downsampled samples (same units as the input).
    fs_hz : float
        New sample rate in Hz.
    factor : int
        Downsampling factor.
    cutoff_hz : float
        Anti-alias cut-off frequency (edge of the pass band) in Hz.
    """

    x: FloatArray
    fs_hz: float
    factor: int
    cutoff_hz: float


def _design(
    fs_hz: float, cutoff_hz: float, order: int, ftype: str, ripple_db: float
) -> FloatArray:
    if ftype not in _FTYPES:
        msg = f"ftype: expected one of {_FTYPES}, got {ftype!r}"
        raise OptionError(msg)
    if not 0.0 < cutoff_hz < 0.5 * fs_hz:
        msg = f"cutoff_hz: expected 0 < cutoff_hz < fs_hz/2 = {0.5 * fs_hz:g}, got {cutoff_hz:g}"
        raise OptionError(msg)
    if int(order) < 1:
        msg = f"order: expected an integer >= 1, got {order!r}"
        raise OptionError(msg)
    if ftype == "cheby1":
        sos: FloatArray = sig.cheby1(
            int(order), ripple_db, cutoff_hz, btype="low", fs=fs_hz, output="sos"
        )
    else:
        sos = sig.butter(int(order), cutoff_hz, btype="low", fs=fs_hz, output="sos")
    return sos


def lowpass_zero_phase(
    x: ArrayLike,
    fs_hz: float,
    cutoff_hz: float,
    *,
    order: int = 8,
    ftype: Literal["cheby1", "butter"] = "cheby1",
    ripple_db: float = 0.05,
) -> FloatArray:
    """Low-pass filter forward and backward (zero phase), sec. 3 of [004].

    Parameters
    ----------
    x : array_like, shape (n_channels, n_samples) or (n_samples,)
    fs_hz : float
        Sample rate in Hz.
    cutoff_hz : float
        Pass-band edge in Hz (for ``cheby1`` the frequency where the ripple band ends).
    order : int
        Order of the single-pass filter (the forward-backward response has twice the
        attenuation in dB).
    ftype : {"cheby1", "butter"}
    ripple_db : float
        Pass-band ripple of the Chebyshev filter in dB.

    Returns
    -------
    ndarray, shape (n_channels, n_samples)

    Raises
    ------
    OptionError
        Cut-off outside (0, fs/2), unknown filter type, order < 1.
    ShapeError
        Record shorter than the filter's edge padding.
    SignalError
        NaN / Inf samples.
    """
    fs = check_positive(fs_hz, "fs_hz")
    sos = _design(fs, float(cutoff_hz), order, ftype, ripple_db)
    pad = 3 * (2 * len(sos) + 1)
    a = as_channels(x, "x", min_samples=1)
    if a.shape[1] <= pad:
        msg = f"x: expected more than {pad} samples for the order-{order} filter, got {a.shape[1]}"
        raise ShapeError(msg)
    y: FloatArray = sig.sosfiltfilt(sos, a, axis=-1)
    return y


def decimate(
    x: ArrayLike,
    fs_hz: float,
    factor: int,
    *,
    order: int = 8,
    cutoff_ratio: float = 0.8,
    ftype: Literal["cheby1", "butter"] = "cheby1",
    ripple_db: float = 0.05,
) -> Decimated:
    """Zero-phase anti-alias filter, then keep every ``factor``-th sample (sec. 3 of [004]).

    Parameters
    ----------
    x : array_like, shape (n_channels, n_samples) or (n_samples,)
    fs_hz : float
        Input sample rate in Hz.
    factor : int
        Downsampling factor >= 1 (1 returns a copy, unfiltered).
    order : int
        Single-pass filter order (8 as in [004]).
    cutoff_ratio : float
        Pass-band edge as a fraction of the new Nyquist frequency, in (0, 1);
        0.8 reproduces the 28.6 Hz / 35.7 Hz of [004].
    ftype, ripple_db
        See :func:`lowpass_zero_phase`.

    Returns
    -------
    Decimated

    Raises
    ------
    OptionError
        ``factor`` < 1 or ``cutoff_ratio`` outside (0, 1); see also :func:`lowpass_zero_phase`.

    Examples
    --------
    >>> t = np.arange(14000) / 1000.0
    >>> d = decimate(np.sin(2 * np.pi * 5.0 * t), 1000.0, 14)
    >>> round(d.fs_hz, 1), round(d.cutoff_hz, 1)
    (71.4, 28.6)
    """
    fs = check_positive(fs_hz, "fs_hz")
    q = int(factor)
    if q != factor or q < 1:
        msg = f"factor: expected an integer >= 1, got {factor!r}"
        raise OptionError(msg)
    if not 0.0 < cutoff_ratio < 1.0:
        msg = f"cutoff_ratio: expected a value in (0, 1), got {cutoff_ratio!r}"
        raise OptionError(msg)
    fs_out = fs / q
    cutoff = cutoff_ratio * 0.5 * fs_out
    if q == 1:
        return Decimated(as_channels(x, "x", min_samples=1).copy(), fs, 1, 0.5 * fs)
    y = lowpass_zero_phase(x, fs, cutoff, order=order, ftype=ftype, ripple_db=ripple_db)
    return Decimated(np.ascontiguousarray(y[:, ::q]), fs_out, q, cutoff)
