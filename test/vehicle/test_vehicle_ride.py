"""Sperling index and floor-PSD band error: closed forms and monotonicity."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modal_twin.errors import OptionError, ShapeError, SignalError
from modal_twin.models.ride import psd_band_error, sperling_index, sperling_weight_vertical


def _sine(a, f, fs=500.0, T=10.0):
    t = np.arange(round(T * fs)) / fs
    return a * np.sin(2 * math.pi * f * t)


@pytest.mark.parametrize(("f", "F"), [(2.0, 0.325 * 4.0), (8.0, 400.0 / 64.0), (25.0, 1.0)])
def test_sinusoid_gives_the_closed_form(f, F):
    a = 0.3  # m/s^2 = 30 cm/s^2
    r = sperling_index(_sine(a, f), 500.0)
    W = 0.896 * ((100 * a) ** 3 * F / f) ** 0.1  # Sperling for one harmonic
    w_run = r.W
    assert w_run == pytest.approx(W, rel=1e-9)
    assert r.W_segments.shape == (2,)
    assert r.segment_s == 5.0


def test_weighting_is_nearly_continuous_at_59_hz():
    lo, hi = sperling_weight_vertical([5.9 - 1e-9, 5.9])
    assert lo == pytest.approx(hi, rel=0.02)  # 11.31 against 11.49
    assert sperling_weight_vertical(0.3) == 0.0


def test_index_is_monotone_in_amplitude():
    rng = np.random.default_rng(4)
    base = rng.standard_normal(5000)
    Ws = [sperling_index(s * base, 500.0).W for s in (0.01, 0.05, 0.1, 0.5, 1.0)]
    assert np.all(np.diff(Ws) > 0)
    # W scales as a^(3/10)
    assert Ws[4] / Ws[2] == pytest.approx(10.0**0.3, rel=1e-9)


def test_whole_record_segment():
    r = sperling_index(_sine(0.1, 4.0, T=3.0), 500.0, segment_s=None)
    assert r.W_segments.shape == (1,)
    w_run = r.W
    assert w_run == pytest.approx(0.896 * (1000 * 0.325 * 16 / 4) ** 0.1, rel=1e-9)


def test_sperling_errors():
    with pytest.raises(ShapeError, match=r"acc: expected a 1-D record \(nt,\), got shape"):
        sperling_index(np.zeros((2, 10)), 100.0)
    with pytest.raises(SignalError, match="acc: expected finite samples"):
        sperling_index(np.array([0.0, np.nan]), 100.0)
    with pytest.raises(OptionError, match="fs_hz: expected a positive finite rate, got 0"):
        sperling_index(np.zeros(10), 0.0)
    with pytest.raises(OptionError, match=r"band_hz: expected 0 < low < high"):
        sperling_index(np.zeros(10), 100.0, band_hz=(5.0, 1.0))
    with pytest.raises(OptionError, match="segment_s: expected a positive length or None"):
        sperling_index(np.zeros(10), 100.0, segment_s=-1.0)
    with pytest.raises(SignalError, match="acc: expected at least one segment of 500"):
        sperling_index(np.zeros(10), 100.0)


def test_psd_band_error_known_answers():
    rng = np.random.default_rng(1)
    x = rng.standard_normal((2, 40000))
    e = psd_band_error(x, 2.0 * x, 200.0)  # PSD x4: band power error 3, 6.02 dB
    assert e.rel_power_error == pytest.approx([3.0, 3.0], rel=1e-12)
    assert e.db_rms_error == pytest.approx([10 * math.log10(4)] * 2, rel=1e-9)
    e1 = psd_band_error(x[0], x[0], 200.0)
    assert e1.rel_power_error.shape == (1,) and e1.rel_power_error[0] == 0.0
    # white noise of unit variance at 200 Hz: PSD 1/100 per Hz, 11 Hz band -> 0.11
    assert e1.power_measured[0] == pytest.approx(0.11, rel=0.05)


def test_psd_band_error_errors():
    x = np.ones(800)
    with pytest.raises(ShapeError, match="measured, predicted: expected equal shapes"):
        psd_band_error(x, x[:10], 200.0)
    with pytest.raises(SignalError, match="measured, predicted: expected finite samples"):
        psd_band_error(x, np.full(800, np.inf), 200.0)
    with pytest.raises(OptionError, match="fs: expected a positive finite rate"):
        psd_band_error(x, x, -1.0)
    with pytest.raises(OptionError, match=r"band: expected 0 <= low < high <= fs / 2 = 100"):
        psd_band_error(x, x, 200.0, band=(4.0, 150.0))
    with pytest.raises(OptionError, match="band: expected at least 2 Welch bins"):
        psd_band_error(x, x, 200.0, band=(4.0, 4.1))
    with pytest.raises(SignalError, match="measured: expected a positive band power"):
        psd_band_error(np.zeros(800), x, 200.0)
