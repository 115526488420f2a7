"""The noise model the diagnosis decides on: per channel, robust, whitened (issue 20.1-2)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from modal_twin.diagnosis.judge import verdict
from modal_twin.diagnosis.noise import (
    MODEL_FORM,
    ErrorFigures,
    channel_noise,
    coloured_noise_sd,
    effective_samples,
    noise_floor,
    noise_sd,
    redundancy_sd,
)

FS = 200.0


def _band_limited(rng: np.random.Generator, n_ch: int, nt: int) -> np.ndarray:
    sos = signal.butter(6, 20.0, fs=FS, output="sos")
    x = signal.sosfiltfilt(sos, rng.standard_normal((n_ch, nt)))
    return x / x.std(axis=1, keepdims=True)


def test_noise_sd_of_white_noise_on_a_band_limited_response() -> None:
    rng = np.random.default_rng(5)
    sd = np.array([0.003, 0.01, 0.03, 0.1])
    y = _band_limited(rng, 4, 40000) + sd[:, None] * rng.standard_normal((4, 40000))
    np.testing.assert_allclose(noise_sd(y, FS), sd, rtol=0.05)


def test_noise_sd_is_not_fooled_by_a_broadband_response_in_bursts() -> None:
    # a slipping device fills the whole band while the motion is strong (a quarter of the
    # record here, at 5x the sensor noise); the flat top of the whole record takes it for
    # noise, the quiet stretches do not
    rng = np.random.default_rng(7)
    nt, sd = 40000, 0.01
    y = _band_limited(rng, 1, nt) + sd * rng.standard_normal((1, nt))
    burst = np.zeros(nt)
    burst[nt // 2: nt // 2 + nt // 4] = 1.0
    y = y + 0.05 * burst * rng.standard_normal(nt)
    whole = float(noise_floor(y, FS)[0] * np.sqrt(np.mean(y**2)))
    assert whole > 2.0 * sd  # the old estimate: the burst counted as noise
    assert noise_sd(y, FS)[0] == pytest.approx(sd, rel=0.08)


def test_channel_noise_keeps_the_quietest_record() -> None:
    # the same sensor (sd 0.01) in a low-level record and a strong one whose response also
    # fills the top of the band all along: the low-level record shows the sensor noise
    rng = np.random.default_rng(11)
    nt, sd = 20000, 0.01
    low = 0.2 * _band_limited(rng, 1, nt) + sd * rng.standard_normal((1, nt))
    strong = (_band_limited(rng, 1, nt) + sd * rng.standard_normal((1, nt))
              + 0.04 * rng.standard_normal((1, nt)))
    model = channel_noise([(("a",), strong, FS), (("a",), low, FS)])
    assert model["a"] == pytest.approx(sd, rel=0.08)


def _figs(nrmse: list[float], noise: list[float], name: str) -> ErrorFigures:
    n = np.asarray(nrmse)
    return ErrorFigures(name, tuple(f"c{i}" for i in range(n.size)), n, np.asarray(noise),
                        np.zeros_like(n))


def test_score_is_the_rms_of_the_whitened_errors() -> None:
    f = _figs([0.02, 0.005], [0.01, 0.0], "r")
    sigma = np.sqrt(np.array([0.01, 0.0]) ** 2 + MODEL_FORM**2)
    assert f.score == pytest.approx(np.sqrt(np.mean((np.array([0.02, 0.005]) / sigma) ** 2)))
    # the noise-free channel at 2x the model-form tolerance is significant, the noisy one
    # at 2x its noise is not (sigma slightly above its noise)
    assert f.significant_channels() == ("c1",)


def test_verdict_takes_an_effect_that_helps_the_precise_channels() -> None:
    # issue 20, item 1: an added mass lowers the error of the near-noise-free drift and force
    # channels (4 % -> 0.3 %) while the median accelerometer rises within its noise
    # (1.39 % -> 1.42 % at a 1.4 % floor); the old rule (the median channel must not rise)
    # rejected it, the whitened figure takes it
    acc_noise = [0.014] * 5
    precise = [0.0] * 4
    before = [_figs([0.0139] * 5 + [0.04] * 4, acc_noise + precise, n)
              for n in ("train", "test", "low")]
    after = [_figs([0.0142] * 5 + [0.003] * 4, acc_noise + precise, n)
             for n in ("train", "test", "low")]
    # the median channel rose: what the old rule rejected
    assert np.median(after[1].nrmse) > np.median(before[1].nrmse)
    assert verdict(before, after, [0.01] * 3) == ""
    # and a candidate that makes the low-level record worse in the same metric is rejected,
    # naming it
    worse = [after[0], after[1], _figs([0.0139] * 5 + [0.08] * 4, acc_noise + precise, "low")]
    assert verdict(before, worse, [0.01] * 3).startswith("makes low worse")
    # one that does not lower the held-out figure by 1 % is rejected too
    same = [after[0], before[1], after[2]]
    assert verdict(before, same, [0.01] * 3).startswith("does not lower the error on test")


# issue 20, item 1: noise in other forms than white (simulators and sensors written apart)


def test_noise_sd_of_a_quantised_record_is_its_rounding() -> None:
    # a band-limited response read by a converter of step q over a span 20x its RMS (16
    # bits: q = 20 / 2^16 of the RMS) and nothing else: the rounding error is white of
    # variance q^2 / 12 (a pure sine's rounding error is a line spectrum instead, whose
    # median level reads about 12 % low)
    rng = np.random.default_rng(23)
    x = _band_limited(rng, 1, 40000)
    q = 20.0 / 2**16
    assert noise_sd(np.round(x / q) * q, FS)[0] == pytest.approx(q / np.sqrt(12.0), rel=0.05)


def test_effective_samples_of_white_and_ar1_series() -> None:
    # sum_k rho_k^2 of AR(1) of coefficient a is (1 + a^2) / (1 - a^2)
    rng = np.random.default_rng(3)
    nt = 40000
    assert effective_samples(rng.standard_normal(nt)) == pytest.approx(nt, rel=0.05)
    a = 0.5
    x = signal.lfilter([1.0], [1.0, -a], rng.standard_normal(nt))
    assert effective_samples(x) == pytest.approx(nt * (1 - a**2) / (1 + a**2), rel=0.05)


@pytest.mark.parametrize("nt", [207, 5000])
def test_effective_samples_of_all_rows_at_once_are_each_rows_own(nt: int) -> None:
    # redundancy_sd takes every row's in one FFT call: the same figures to the last bit
    from modal_twin.diagnosis.noise import _effective_samples_rows

    rng = np.random.default_rng(nt)
    x = rng.standard_normal((5, nt))
    x[1] = signal.lfilter([1.0], [1.0, -0.9], x[1])
    x[2] = 0.0
    x[3] += 3.0 * np.sin(0.05 * np.arange(nt))
    got = _effective_samples_rows(x)
    assert np.isnan(got[2]) and effective_samples(x[2]) == nt  # a constant row: nothing to read
    live = [0, 1, 3, 4]
    np.testing.assert_array_equal(got[live], [effective_samples(x[i]) for i in live])


def _shared_error(rng: np.random.Generator, n_ch: int, nt: int) -> np.ndarray:
    """A model error moving every channel: three modes (narrow-band sources at 2, 5 and
    9 Hz), each seen by the channels with its own gain and phase (complex modes)."""
    out = np.zeros((n_ch, nt))
    for f0 in (2.0, 5.0, 9.0):
        sos = signal.butter(2, [0.9 * f0, 1.1 * f0], btype="band", fs=FS, output="sos")
        src = signal.sosfiltfilt(sos, rng.standard_normal(nt))
        src /= src.std()
        quad = np.imag(signal.hilbert(src))
        phase = rng.uniform(-np.pi, np.pi, n_ch)
        gain = rng.normal(size=n_ch)
        out += (gain * np.cos(phase))[:, None] * src + (gain * np.sin(phase))[:, None] * quad
    return out


def _ar1(rng: np.random.Generator, sd: np.ndarray, nt: int, a: float) -> np.ndarray:
    x = signal.lfilter([1.0], [1.0, -a], rng.standard_normal((sd.size, nt)), axis=1)
    return sd[:, None] * x / x.std(axis=1, keepdims=True)


def test_coloured_noise_is_told_from_a_shared_model_error() -> None:
    # AR(1) noise (a = 0.95: almost nothing of it at the top of the band) of known standard
    # deviations, independent between 30 sensors, beside a model error 10x larger that
    # moves them all: the flat top reads the noise far too low, the part no other channel
    # predicts reads it to 25 % (high: the others' noise lets some of the shared error through)
    rng = np.random.default_rng(13)
    nt, n_ch = 20000, 30
    sd = np.linspace(0.01, 0.03, n_ch)
    resid = 0.2 * _shared_error(rng, n_ch, nt) + _ar1(rng, sd, nt, 0.95)
    measured = _band_limited(rng, n_ch, nt) + resid
    assert np.all(noise_sd(measured, FS) < 0.5 * sd)
    np.testing.assert_allclose(redundancy_sd(resid), sd, rtol=0.25)
    np.testing.assert_allclose(coloured_noise_sd(measured, resid, FS), sd, rtol=0.25)


def test_white_noise_keeps_its_flat_top_level() -> None:
    # white noise beside the same shared model error: the noise is not coloured, the
    # flat-top levels stand unchanged
    rng = np.random.default_rng(17)
    nt, n_ch = 20000, 30
    sd = np.linspace(0.01, 0.03, n_ch)
    resid = 0.2 * _shared_error(rng, n_ch, nt) + sd[:, None] * rng.standard_normal((n_ch, nt))
    measured = _band_limited(rng, n_ch, nt) + resid
    np.testing.assert_allclose(redundancy_sd(resid), sd, rtol=0.25)
    np.testing.assert_array_equal(coloured_noise_sd(measured, resid, FS),
                                  noise_sd(measured, FS))


def _at(score: float, name: str) -> ErrorFigures:
    """One channel whose whitened figure is ``score`` (noise 1 %, model form beside it)."""
    sigma = float(np.sqrt(0.01**2 + MODEL_FORM**2))
    return _figs([score * sigma], [0.01], name)


@pytest.mark.parametrize(("low_before", "low_after", "refused"),
                         [(0.82, 0.85, False), (0.95, 1.005, False), (1.5, 3.0, True),
                          (0.82, 1.2, True), (1.5, 1.51, False)])
def test_a_level_at_its_noise_floor_is_not_made_worse_by_a_rise_within_the_noise(
        low_before: float, low_after: float, refused: bool) -> None:
    # the narrow-band sinh case at seed offset 100 (session 12): a hardening fit lowered the
    # training and held-out figures 3x and raised the low level from 0.82x to 0.85x its
    # noise: a residual below the noise estimate moving within it is noise, not a misfit;
    # the bound is (1 + tol) x max(figure before, 1). A level above its floor (1.5x) made
    # 3x, or one at its floor made 1.2x (20 % above the noise), is made worse; within the
    # 1 % tolerance above its figure before (1.5x -> 1.51x) it is not.
    before = [_at(3.0, "train"), _at(3.0, "test"), _at(low_before, "low")]
    after = [_at(1.0, "train"), _at(1.0, "test"), _at(low_after, "low")]
    why = verdict(before, after, [0.01] * 3)
    assert why.startswith("makes low worse") if refused else why == ""
