"""Model-versus-measurement metrics per channel over a sliding window.

The relative error in RMS (Eq. (8) of [004]) and the normalised RMS of the residual.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.errors import ShapeError

__all__ = ["ChannelMetrics", "SlidingMetrics", "channel_metrics", "rms"]


def rms(x: FloatArray, axis: int = -1) -> FloatArray:
    """Root mean square along ``axis``: [n^-1 sum x^2]^(1/2) (below Eq. (8) of [004])."""
    return np.sqrt(np.mean(np.square(x), axis=axis))


@dataclass(frozen=True, slots=True)
class ChannelMetrics:
    """Per-channel comparison (all arrays shape (n_channels,), errors in percent)."""

    rms_measured: FloatArray
    rms_predicted: FloatArray
    rms_error_pct: FloatArray  # Eq. (8) of [004]
    residual_pct: FloatArray  # 100 RMS(pred - meas) / RMS(meas)
    samples: int


def channel_metrics(predicted: FloatArray, measured: FloatArray) -> ChannelMetrics:
    """Compute Eq. (8) of [004] per channel: Err = |RMS(w_hat) - RMS(w)| / RMS(w) x 100 %.

    Also the residual RMS relative to the measured RMS. Channels whose measured RMS is zero
    get NaN (no relative error is defined).
    """
    if predicted.shape != measured.shape:
        msg = f"predicted: expected shape {measured.shape} (as measured), got {predicted.shape}"
        raise ShapeError(msg)
    r_m, r_p = rms(measured), rms(predicted)
    r_e = rms(predicted - measured)
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = np.where(r_m > 0, r_m, np.nan)
        err = 100.0 * np.abs(r_p - r_m) / denom  # Eq. (8) of [004]
        res = 100.0 * r_e / denom
    return ChannelMetrics(r_m, r_p, err, res, int(measured.shape[-1]))


class SlidingMetrics:
    """Metrics over the last ``window`` samples, fed block by block."""

    def __init__(self, n_channels: int, window: int) -> None:
        self.n_channels = n_channels
        self.window = window
        self._pred: deque[FloatArray] = deque()
        self._meas: deque[FloatArray] = deque()
        self._n = 0

    def push(self, predicted: FloatArray, measured: FloatArray) -> None:
        """Add a block (n_channels, n) of predictions and measurements."""
        if predicted.shape != measured.shape or predicted.shape[0] != self.n_channels:
            msg = (f"push: expected two ({self.n_channels}, n) arrays, got {predicted.shape} "
                   f"and {measured.shape}")
            raise ShapeError(msg)
        self._pred.append(predicted)
        self._meas.append(measured)
        self._n += predicted.shape[1]
        while self._n - self._pred[0].shape[1] >= self.window:
            self._n -= self._pred.popleft().shape[1]
            self._meas.popleft()

    def metrics(self) -> ChannelMetrics | None:
        """Metrics over the window (None before the first block)."""
        if not self._pred:
            return None
        p = np.concatenate(self._pred, axis=1)[:, -self.window:]
        m = np.concatenate(self._meas, axis=1)[:, -self.window:]
        return channel_metrics(p, m)
