from __future__ import annotations

import numpy as np
import pytest

from modal_twin.acquisition.decimation import decimate, lowpass_zero_phase
from modal_twin.errors import OptionError, ShapeError, SignalError

FS = 1000.0


def _tone(f: float, n: int = 28000, phase: float = 0.3) -> np.ndarray:
    return np.sin(2 * np.pi * f * np.arange(n) / FS + phase)


def test_004_rates() -> None:
    d = decimate(_tone(5.0), FS, 14)
    assert d.factor == 14
    assert d.fs_hz == pytest.approx(71.43, abs=0.01)  # 1 kHz -> 71.4 Hz, sec. 3 of [004]
    assert d.cutoff_hz == pytest.approx(28.57, abs=0.01)  # 28.6 Hz cut-off


@pytest.mark.parametrize("f", [0.7, 5.0, 20.0, 27.0])
def test_tone_in_band_keeps_amplitude_and_phase(f: float) -> None:
    d = decimate(_tone(f), FS, 14)
    t = np.arange(d.x.shape[1]) / d.fs_hz
    ref = np.sin(2 * np.pi * f * t + 0.3)
    core = slice(200, -200)  # away from the edge transients
    # forward-backward cheby1: ripple 2 x 0.05 dB -> amplitude within 1.2 %; zero phase
    basis = np.stack([np.sin(2 * np.pi * f * t), np.cos(2 * np.pi * f * t)], axis=1)[core]
    coef = np.linalg.lstsq(basis, d.x[0, core], rcond=None)[0]
    amp = float(np.hypot(*coef))
    assert np.arctan2(coef[1], coef[0]) == pytest.approx(0.3, abs=1e-3)  # zero phase
    assert amp == pytest.approx(1.0, rel=0.012)
    np.testing.assert_allclose(d.x[0, core], amp * ref[core], atol=2e-3)


def test_out_of_band_tone_is_removed() -> None:
    d = decimate(_tone(60.0), FS, 14)  # would alias to 11.4 Hz without the filter
    assert np.std(d.x[0, 200:-200]) < 1e-4


def test_lowpass_zero_phase_butter_and_factor_one() -> None:
    x = _tone(2.0, 5000)
    y = lowpass_zero_phase(x, FS, 50.0, ftype="butter", order=4)
    np.testing.assert_allclose(y[0, 500:-500], x[500:-500], atol=1e-3)
    d1 = decimate(x, FS, 1)
    np.testing.assert_array_equal(d1.x[0], x)


def test_errors() -> None:
    with pytest.raises(OptionError, match="factor: expected an integer >= 1"):
        decimate(_tone(1.0), FS, 0)
    with pytest.raises(OptionError, match="cutoff_ratio"):
        decimate(_tone(1.0), FS, 4, cutoff_ratio=1.2)
    with pytest.raises(OptionError, match="cutoff_hz: expected 0 < cutoff_hz"):
        lowpass_zero_phase(_tone(1.0), FS, 600.0)
    with pytest.raises(OptionError, match="ftype: expected one of"):
        lowpass_zero_phase(_tone(1.0), FS, 10.0, ftype="ellip")  # type: ignore[arg-type]
    with pytest.raises(OptionError, match="order: expected an integer >= 1"):
        lowpass_zero_phase(_tone(1.0), FS, 10.0, order=0)
    with pytest.raises(OptionError, match="fs_hz: expected a finite value > 0"):
        decimate(_tone(1.0), -1.0, 2)
    with pytest.raises(ShapeError, match="expected more than 27 samples"):
        lowpass_zero_phase(np.ones(20), FS, 10.0)
    with pytest.raises(SignalError, match="NaN/Inf"):
        decimate(np.r_[np.inf, _tone(1.0)], FS, 2)
