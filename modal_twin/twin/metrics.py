"""Model-versus-measurement metrics per channel, over a sliding window or a whole stream.

The relative error in RMS (Eq. (8) of [004]) and the normalised RMS of the residual.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.errors import ShapeError

__all__ = ["ChannelMetrics", "SlidingMetrics", "StreamMetrics", "channel_metrics", "rms"]


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
    return _from_rms(rms(measured), rms(predicted), rms(predicted - measured),
                     int(measured.shape[-1]))


def _from_rms(r_m: FloatArray, r_p: FloatArray, r_e: FloatArray, n: int) -> ChannelMetrics:
    """Eq. (8) of [004] and the residual NRMSE from the RMS of measured, model, residual."""
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = np.where(r_m > 0, r_m, np.nan)
        err = 100.0 * np.abs(r_p - r_m) / denom  # Eq. (8) of [004]
        res = 100.0 * r_e / denom
    return ChannelMetrics(r_m, r_p, err, res, n)


def _check_pair(predicted: FloatArray, measured: FloatArray, n_channels: int) -> None:
    if predicted.shape != measured.shape or predicted.shape[0] != n_channels:
        msg = (f"push: expected two ({n_channels}, n) arrays, got {predicted.shape} "
               f"and {measured.shape}")
        raise ShapeError(msg)


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
        _check_pair(predicted, measured, self.n_channels)
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


class StreamMetrics:
    """Metrics over every sample pushed since the start, fed block by block.

    Keeps per channel the sums of squares of measured, model and residual samples (memory
    per channel, not per sample), so a whole record of any length is scored: the same
    figures as :func:`channel_metrics` on the concatenated record, up to round-off.
    """

    def __init__(self, n_channels: int) -> None:
        self.n_channels = n_channels
        self._sums = np.zeros((3, n_channels))  # sum m^2, sum p^2, sum (p - m)^2
        self._n = 0

    def push(self, predicted: FloatArray, measured: FloatArray) -> None:
        """Add a block (n_channels, n) of predictions and measurements."""
        _check_pair(predicted, measured, self.n_channels)
        self._sums += np.stack([np.einsum("ij,ij->i", x, x) for x in
                                (measured, predicted, predicted - measured)])
        self._n += predicted.shape[1]

    def metrics(self) -> ChannelMetrics | None:
        """Metrics over every sample so far (None before the first block)."""
        if self._n == 0:
            return None
        r = np.sqrt(self._sums / self._n)
        return _from_rms(r[0], r[1], r[2], self._n)
