from __future__ import annotations

import numpy as np
import pytest

from modal_twin.identification import select_modes, ssi_cov, stabilization_diagram
from modal_twin.identification.auto import choose_settings, drifting_modes, rms_spread


def _two_tone(fs: float, seconds: float, f_hz: tuple[float, ...], seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = np.arange(int(fs * seconds)) / fs
    y = np.array([sum(np.sin(2 * np.pi * f * t + k) for f in f_hz) for k in range(3)])
    return y + 0.01 * rng.standard_normal(y.shape)


@pytest.mark.parametrize(("fs", "tones"), [(200.0, (1.0, 3.0)), (5000.0, (150.0, 400.0))])
def test_settings_scale_with_the_record(fs: float, tones: tuple[float, float]) -> None:
    y = _two_tone(fs, 60.0 if fs < 1000 else 6.0, tones)
    s = choose_settings(y, fs, 1)
    lo, hi = s.band_hz
    assert lo == pytest.approx(20.0 / (y.shape[1] / fs))  # 20 cycles of the record
    assert tones[1] <= hi <= 1.1 * tones[1]  # the 99 % power point: the upper tone
    assert s.factor == int(fs // (2.5 * hi))
    assert s.fs_hz == pytest.approx(fs / s.factor)
    assert s.block_rows * (1 + 3) <= 1200
    assert s.orders[-1] <= 3 * (s.block_rows - 1)
    assert "decimation" in s.describe()
    # stated corners and a user band override the spectrum
    s2 = choose_settings(y, fs, 1, f_max_hz=tones[0] * 1.5, corners_hz=(2 * lo, np.nan))
    assert s2.band_hz == (pytest.approx(2 * lo), pytest.approx(tones[0] * 1.5))


def test_rms_spread_stationary_and_transient() -> None:
    rng = np.random.default_rng(3)
    y = rng.standard_normal((2, 8000))
    assert rms_spread(y) < 1.2
    env = np.exp(-np.arange(8000) / 800.0)
    assert rms_spread(y * env) > 20


def test_drift_check_on_a_clean_record_finds_none() -> None:
    rng = np.random.default_rng(5)
    fs, n = 50.0, 20000
    # two lightly damped modes driven by white noise (AR(2) filters)
    y = np.zeros((2, n))
    e = rng.standard_normal((2, n))
    for f, k in ((2.0, 0), (6.0, 1)):
        r, th = np.exp(-0.02 * 2 * np.pi * f / fs), 2 * np.pi * f / fs
        for t in range(2, n):
            y[k, t] = 2 * r * np.cos(th) * y[k, t - 1] - r * r * y[k, t - 2] + e[k, t]
    y = np.array([y[0] + y[1], y[0] - 0.5 * y[1]])
    sw = ssi_cov(y, fs, orders=range(2, 21, 2), block_rows=20, n_blocks_std=0)
    d = stabilization_diagram(sw)
    mm = select_modes(d)
    np.testing.assert_allclose(mm.f_hz, [2.0, 6.0], rtol=0.02)
    assert drifting_modes(d, mm) == []
    assert drifting_modes(d, mm, rel_drift=-1.0) != []  # every column "drifts" at < 0
