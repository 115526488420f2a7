"""Headline error and the noise floor it is judged against, both from the data.

The headline figure is the normalised RMS of the residual per channel,

    NRMSE = RMS(measured - model) / RMS(measured),

which is 0 only when the waveforms agree. Eq. (8) of [004] (a difference of RMS values,
``|RMS(model) - RMS(measured)| / RMS(measured)``) can be 0 while they disagree; it is
reported beside the NRMSE, labelled, never used for a decision.

A model can do no better than the sensor noise: with white noise of standard deviation
``s`` on a channel, the NRMSE of a perfect model is ``s / RMS(measured)``. That floor is
estimated from the record itself: above the band the structure responds in, a measured
spectrum is flat at the noise level (one-sided PSD ``2 s^2 / fs``), so ``s^2`` follows from
the median Welch PSD of the top of the band. Where the response fills the whole band
(a decimated record) the estimate is high, so decisions err towards "nothing significant".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

from modal_twin._types import FloatArray
from modal_twin.twin.metrics import channel_metrics

__all__ = ["ErrorFigures", "error_figures", "noise_floor", "nrmse"]

# a model error counts when the NRMSE exceeds the noise floor by this factor: an error
# beyond the noise of sqrt(ratio^2 - 1) = 1.7 x the noise itself (a model that differs from
# the truth only in its integrator or round-off stays below it)
SIGNIFICANT_RATIO = 2.0


def nrmse(predicted: FloatArray, measured: FloatArray) -> FloatArray:
    """Return RMS(measured - predicted) / RMS(measured) per row (NaN for a silent channel)."""
    return channel_metrics(predicted, measured).residual_pct / 100.0


def eq8_error(predicted: FloatArray, measured: FloatArray) -> FloatArray:
    """Return Eq. (8) of [004], |RMS(predicted) - RMS(measured)| / RMS(measured), per row."""
    return channel_metrics(predicted, measured).rms_error_pct / 100.0


def noise_floor(measured: FloatArray, fs_hz: float, *, top_fraction: float = 0.3
                ) -> FloatArray:
    """Sensor-noise RMS over signal RMS per row, from the flat top of the spectrum.

    Parameters
    ----------
    measured : (n_ch, nt) array
    fs_hz : float
    top_fraction : float
        Share of the band below Nyquist taken as noise-only (default: the top 30 %).

    Returns
    -------
    (n_ch,) array: estimated noise RMS / RMS(measured), in [0, 1].
    """
    x = np.atleast_2d(np.asarray(measured, float))
    nt = x.shape[-1]
    nper = int(min(nt, max(64, 2 ** int(np.log2(max(nt // 16, 64))))))
    f, p = signal.welch(x - x.mean(axis=-1, keepdims=True), fs=fs_hz, nperseg=nper, axis=-1)
    band = f >= (1.0 - top_fraction) * f[-1]
    band[-1] = False  # the Nyquist bin of Welch is one-sided twice
    if not np.any(band):
        return np.ones(x.shape[0])
    s2 = np.median(p[:, band], axis=-1) * fs_hz / 2.0
    rms = np.sqrt(np.mean(x**2, axis=-1))
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(rms > 0, np.sqrt(s2) / rms, 1.0)
    return np.clip(out, 0.0, 1.0)


@dataclass(frozen=True, slots=True)
class ErrorFigures:
    """Model against one record, per channel: NRMSE, its noise floor and Eq. (8)."""

    record: str
    channels: tuple[str, ...]
    nrmse: FloatArray
    noise: FloatArray
    eq8: FloatArray

    @property
    def over_noise(self) -> FloatArray:
        """NRMSE / noise floor per channel (1 = as good as the sensors allow)."""
        return self.nrmse / np.maximum(self.noise, 1e-6)

    @property
    def median_nrmse(self) -> float:
        """Median NRMSE over the channels."""
        return float(np.nanmedian(self.nrmse))

    @property
    def median_over_noise(self) -> float:
        """Median of NRMSE / noise floor over the channels."""
        return float(np.nanmedian(self.over_noise))

    @property
    def total(self) -> float:
        """RMS over the channels of the per-channel NRMSE: the figure fits are ranked by."""
        return float(np.sqrt(np.nanmean(self.nrmse**2)))

    def significant_channels(self, ratio: float = SIGNIFICANT_RATIO) -> tuple[str, ...]:
        """Channels whose error exceeds ``ratio`` x their noise floor."""
        return tuple(c for c, r in zip(self.channels, self.over_noise, strict=True)
                     if r > ratio)

    def line(self) -> str:
        """One line: median NRMSE, noise, ratio, and Eq. (8) labelled."""
        return (f"{self.record}: NRMSE median {100 * self.median_nrmse:.2f} % (noise floor "
                f"{100 * float(np.nanmedian(self.noise)):.2f} %, x{self.median_over_noise:.2f}); "
                f"Eq. (8) of [004] median {100 * float(np.nanmedian(self.eq8)):.2f} %")


def error_figures(predicted: FloatArray, measured: FloatArray, channels: tuple[str, ...],
                  noise: FloatArray, record: str = "") -> ErrorFigures:
    """:class:`ErrorFigures` of a prediction of ``measured`` (noise floor given)."""
    m = channel_metrics(predicted, measured)
    return ErrorFigures(record, tuple(channels), m.residual_pct / 100.0,
                        np.asarray(noise, float), m.rms_error_pct / 100.0)
