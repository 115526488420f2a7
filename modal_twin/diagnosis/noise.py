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

The flat top sees white noise only: noise that is coloured (1/f, or low-passed by a
conditioner or an anti-aliasing filter) has little or nothing at the top of the band, and
its estimate is far too low (a low-passed 2 % noise read as 0.001 %). Coloured noise is
told from a model error by its independence between sensors (:func:`redundancy_sd`): what
the other channels of the model's residual cannot predict, in phase or in quadrature, is
each channel's own noise, whatever its spectrum, while a missing effect moves many channels
together. Where that exceeds the flat-top levels on most channels (the median ratio above
:data:`COLOURED_RATIO`: the noise is not white), each channel's level is raised towards it
(:func:`coloured_noise_sd`); for white noise the flat top stands.

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

__all__ = ["COLOURED_RATIO", "MODEL_FORM", "REDUNDANT_CHANNELS", "RESOLUTION", "ErrorFigures",
           "channel_noise", "coloured_noise_sd", "effective_samples", "error_figures",
           "noise_floor", "noise_sd", "nrmse", "redundancy_sd", "whitening_sigma"]

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
# the noise is taken as coloured when the unpredictable part of the residuals exceeds the
# flat-top levels by this median factor (white noise with a model error left: 1.0-1.2)
COLOURED_RATIO = 1.5
# channels needed for that test: with fewer, the others' noise lets a shared model error
# through (about +60 % with 10 channels, +20 % with 30) and the flat top stands
REDUNDANT_CHANNELS = 20


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


def redundancy_sd(residual: FloatArray) -> FloatArray:
    """Per row, the standard deviation of what the other rows cannot predict.

    Each row of ``residual`` (a model's residual, channels by samples) is regressed on the
    other rows and on their Hilbert transforms (a part shifted by a quarter period: modes
    that are not in phase between channels), and the variance left is corrected for the
    regressors fitted, ``N_eff / (N_eff - p)``, with ``N_eff`` the independent samples of
    what is left (:func:`effective_samples`: fewer than ``N`` for coloured noise, whose
    spurious fit to ``p`` regressors of the same colour takes a share ``p / N_eff`` of its
    variance). Noise independent between sensors is left whole, at any spectrum; a model
    error shared by several channels is predicted and removed, but not wholly: the other
    rows' noise lets some of it through, so the estimate errs high, the more so the fewer
    the rows.

    Returns ``inf`` for every row when there are too few samples (fewer than four per
    regressor).
    """
    x = np.atleast_2d(np.asarray(residual, float))
    n, nt = x.shape
    p = 2 * (n - 1)
    if n < 2 or nt < 4 * p:
        return np.full(n, np.inf)
    x = x - x.mean(axis=1, keepdims=True)
    s = x.std(axis=1)
    z = x / np.where(s > 0, s, 1.0)[:, None]
    regs = np.vstack([z, np.imag(signal.hilbert(z, axis=1))])
    cov = regs @ regs.T / nt
    left = np.empty_like(z)
    var = np.empty(n)
    for i in range(n):
        idx = np.array([j for j in range(2 * n) if j not in (i, n + i)])
        b = cov[idx, i]
        w = np.linalg.lstsq(cov[np.ix_(idx, idx)], b, rcond=1e-10)[0]
        left[i] = z[i] - w @ regs[idx]
        var[i] = max(float(cov[i, i] - b @ w), 0.0)
    n_eff = np.nan_to_num(_effective_samples_rows(left), nan=float(nt))  # one FFT, all rows
    keep = np.maximum(1.0 - p / n_eff, 0.2)  # a spurious fit takes at most 80 %
    return np.sqrt(var / keep) * s


def effective_samples(residual: FloatArray, *, lags: float = 2.0) -> float:
    """Independent samples a stationary series is worth (one row, or the median over rows).

    For a stationary Gaussian series of autocorrelation ``rho_k`` the variance of its mean
    square is ``2 sigma^4 / N sum_k rho_k^2`` (Bartlett's formula for the variance of a
    sample variance, the sum over all lags, both signs), and a share ``p / N`` of its
    variance is what a least-squares fit of ``p`` regressors of its colour takes by chance
    with ``N`` replaced by the same count: both count the series as

        N_eff = N / sum_k rho_k^2 = N / (1 + 2 sum_(k >= 1) rho_k^2)

    independent samples: ``N`` for white noise, ``N (1 - a^2) / (1 + a^2)`` for an AR(1)
    series of coefficient ``a``, few for a residual that is smooth model error. The sum is
    over ``lags * sqrt(N)`` lags (a window growing slower than ``N``, so that the
    estimates' own scatter, about ``1 / N`` each, adds little), less that white-noise bias;
    the autocorrelation from the FFT of each row (``residual``: one series, or channels by
    samples, then the median over the channels). Used by the backward elimination
    (:func:`.refine.without_idle`) and the coloured-noise test (:func:`redundancy_sd`).
    """
    r = np.atleast_2d(np.asarray(residual, float))
    per_row = _effective_samples_rows(r, lags)
    live = per_row[~np.isnan(per_row)]
    return float(np.median(live)) if live.size else float(r.shape[1])


def _effective_samples_rows(r: FloatArray, lags: float = 2.0) -> FloatArray:
    """:func:`effective_samples` of each row of ``r`` (rows x samples).

    NaN for a row that is constant (no autocorrelation to read).
    """
    r = r - r.mean(axis=1, keepdims=True)
    n = r.shape[1]
    spec = np.abs(np.fft.rfft(r, 2 * n, axis=1)) ** 2
    ac = np.fft.irfft(spec, axis=1)[:, :n]
    out = np.full(r.shape[0], np.nan)
    ok = ac[:, 0] > 0
    rho2 = (ac[ok, 1:max(2, int(lags * np.sqrt(n)))] / ac[ok, :1]) ** 2
    excess = np.maximum(np.sum(rho2, axis=1) - rho2.shape[1] / n, 0.0)
    out[ok] = n / (1.0 + 2.0 * excess)
    return out


def coloured_noise_sd(measured: FloatArray, residual: FloatArray, fs_hz: float
                      ) -> FloatArray:
    """Sensor-noise standard deviation per row, white or coloured.

    The flat-top levels (:func:`noise_sd`) stand unless the noise is coloured: the median
    over the rows of :func:`redundancy_sd` of ``residual`` (the model's residual on
    ``measured``) over the flat-top level above :data:`COLOURED_RATIO`, with at least
    :data:`REDUNDANT_CHANNELS` rows. Then each row takes
    its flat-top level times that median ratio (a spectrum shared by the sensors), but no
    more than its own unpredictable part, and no less than its flat top.
    """
    flat = noise_sd(measured, fs_hz)
    if flat.size < REDUNDANT_CHANNELS:
        return flat
    red = redundancy_sd(residual)
    ok = np.isfinite(flat) & np.isfinite(red) & (flat > 0)
    if not np.any(ok):
        return flat
    ratio = float(np.median(red[ok] / flat[ok]))
    if not ratio > COLOURED_RATIO:
        return flat
    return np.where(ok, np.maximum(flat, np.minimum(red, ratio * flat)), flat)


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


def whitening_sigma(noise: FloatArray, tolerance: float = MODEL_FORM) -> FloatArray:
    """Per channel, the error a correct model may show: ``sqrt(noise^2 + tolerance^2)``.

    ``noise`` the channels' noise floors and ``tolerance`` the stated model-form tolerance
    (:data:`MODEL_FORM`), both fractions of each channel's RMS: the unit every decision
    counts a channel's error in (:attr:`ErrorFigures.sigma`), and the fits their residual
    (:func:`.fitting.channel_scale`). The tolerance keeps a near-noise-free channel (a
    force far above its resolution) from an infinite weight.
    """
    return np.sqrt(np.asarray(noise, float) ** 2 + tolerance**2)


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
        """Per channel, the error a correct model may show: noise and model form together.

        :func:`whitening_sigma` of the noise floors and the tolerance.
        """
        return whitening_sigma(self.noise, self.tolerance)

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
