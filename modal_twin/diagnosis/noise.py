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

The noise model a diagnosis decides on (:func:`noise_sd`, :func:`channel_noise`) is made
robust to a non-linear response, which also fills the top of the band (friction adds
broadband acceleration while it slips): the flat-top level is taken in several stretches of
each record and the quiet ones count (a low quantile over the stretches). Each record keeps
its own levels: a sensor's noise need not be the same at another level of a test (a
conditioner's range set for the level; noise stated relative to the signal), so taking the
lowest over the records would make the strong records' floors far too low. A channel that
shows no noise at all (a simulated drift or force, a load cell far above its resolution)
gets the floor of its resolution, :data:`RESOLUTION` of its RMS.

Every decision is made on residuals whitened by that model: a channel's error counts in
units of ``sigma = sqrt(noise^2 + MODEL_FORM^2)`` (:attr:`ErrorFigures.sigma`), where
:data:`MODEL_FORM` is the stated model-form tolerance (what an integrator, a discretisation
or a truth written in another form may differ by), and a record's figure is the RMS of the
whitened errors over its channels (:attr:`ErrorFigures.score`): for Gaussian residuals its
square is the log-likelihood per sample up to a constant, so channels of very different
noise (accelerometers at 1-3 %, drift channels at 0.01 %) weigh by what they can tell.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy import signal

from modal_twin._types import FloatArray
from modal_twin.twin.metrics import channel_metrics

__all__ = ["MODEL_FORM", "RESOLUTION", "ErrorFigures", "channel_noise", "error_figures",
           "noise_floor", "noise_sd", "nrmse"]

# a model error counts when the NRMSE exceeds the noise floor by this factor: an error
# beyond the noise of sqrt(ratio^2 - 1) = 1.7 x the noise itself (a model that differs from
# the truth only in its integrator or round-off stays below it)
SIGNIFICANT_RATIO = 2.0
# stated model-form tolerance, a fraction of a channel's RMS: two correct models written in
# other forms (integrators, discretisations) differ by about this much
MODEL_FORM = 0.002
# the floor of a channel that shows no noise: a 16-bit converter whose full scale is a few
# times the channel's RMS resolves about 1e-4 of it
RESOLUTION = 1e-4


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
    s2 = _flat_top_var(x, fs_hz, top_fraction)
    if not np.all(np.isfinite(s2)):
        return np.ones(x.shape[0])
    rms = np.sqrt(np.mean(x**2, axis=-1))
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(rms > 0, np.sqrt(s2) / rms, 1.0)
    return np.clip(out, 0.0, 1.0)


def _flat_top_var(x: FloatArray, fs_hz: float, top_fraction: float) -> FloatArray:
    """White-noise variance per row from the median Welch PSD of the top of the band."""
    nt = x.shape[-1]
    nper = int(min(nt, max(64, 2 ** int(np.log2(max(nt // 16, 64))))))
    f, p = signal.welch(x - x.mean(axis=-1, keepdims=True), fs=fs_hz, nperseg=nper, axis=-1)
    band = f >= (1.0 - top_fraction) * f[-1]
    band[-1] = False  # the Nyquist bin of Welch is one-sided twice
    if not np.any(band):
        return np.full(x.shape[0], np.inf)
    return np.median(p[:, band], axis=-1) * fs_hz / 2.0


def noise_sd(measured: FloatArray, fs_hz: float, *, top_fraction: float = 0.3,
             n_stretches: int = 8, quantile: float = 0.25) -> FloatArray:
    """Sensor-noise standard deviation per row (absolute), robust to a broadband response.

    The record is cut into ``n_stretches`` stretches (fewer when it is short: each keeps at
    least 2048 samples); in each, the flat top of the spectrum gives a white-noise variance
    (one-sided PSD ``2 s^2 / fs``) and the ``quantile`` over the stretches is kept: a response
    that fills the top of the band only while it is strong (a slipping friction device)
    raises some stretches, not the quiet ones. For white noise alone every stretch agrees and
    the quantile is the noise itself (tested to 5 %).

    Parameters
    ----------
    measured : (n_ch, nt) array
    fs_hz : float
    top_fraction : float
        Share of the band below Nyquist taken as noise-only (default: the top 30 %).
    n_stretches : int
        Stretches the record is cut into at most.
    quantile : float
        Quantile of the stretches' estimates kept, in (0, 1].

    Returns
    -------
    (n_ch,) array of noise standard deviations in the channels' units.
    """
    x = np.atleast_2d(np.asarray(measured, float))
    nt = x.shape[-1]
    n = int(max(1, min(n_stretches, nt // 2048)))
    edges = np.linspace(0, nt, n + 1).astype(int)
    var = np.stack([_flat_top_var(x[:, a:b], fs_hz, top_fraction)
                    for a, b in itertools.pairwise(edges)])
    s2 = np.quantile(var, quantile, axis=0) if n > 1 else var[0]
    return np.sqrt(np.where(np.isfinite(s2), s2, np.inf))


def channel_noise(records: Iterable[tuple[Sequence[str], FloatArray, float]]
                  ) -> dict[str, float]:
    """Noise standard deviation of every channel: the lowest over the records given.

    ``records`` yields ``(channel names, data (n_ch, nt), fs_hz)``; give several records
    only when their sensors' noise is known to be the same (the same conditioner ranges),
    e.g. stretches of one run.
    """
    out: dict[str, float] = {}
    for names, data, fs_hz in records:
        for name, sd in zip(names, noise_sd(data, fs_hz), strict=True):
            out[name] = min(out.get(name, np.inf), float(sd))
    return out


@dataclass(frozen=True, slots=True)
class ErrorFigures:
    """Model against one record, per channel: NRMSE, its noise floor and Eq. (8)."""

    record: str
    channels: tuple[str, ...]
    nrmse: FloatArray
    noise: FloatArray
    eq8: FloatArray
    tolerance: float = MODEL_FORM

    @property
    def sigma(self) -> FloatArray:
        """Per channel, the error a correct model may show: noise and model form together."""
        return np.sqrt(np.asarray(self.noise, float) ** 2 + self.tolerance**2)

    @property
    def whitened(self) -> FloatArray:
        """NRMSE / sigma per channel: the error in units of what it may be."""
        return self.nrmse / self.sigma

    @property
    def score(self) -> float:
        """RMS over the channels of the whitened error: the figure every decision is on.

        Its square is, up to a constant, minus the Gaussian log-likelihood per sample of the
        residuals under the noise model (module docstring).
        """
        return float(np.sqrt(np.nanmean(self.whitened**2)))

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
        """Channels whose error exceeds ``ratio`` x what it may be (:attr:`sigma`)."""
        return tuple(c for c, r in zip(self.channels, self.whitened, strict=True)
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
