from __future__ import annotations

import numpy as np
import pytest

from modal_twin.errors import ShapeError
from modal_twin.twin.metrics import SlidingMetrics, channel_metrics, rms


def test_eq8_known_values() -> None:
    t = np.arange(10000) / 1000.0
    meas = np.vstack([np.sin(2 * np.pi * 5 * t), np.ones_like(t)])
    pred = np.vstack([1.1 * meas[0], np.zeros_like(t)])
    m = channel_metrics(pred, meas)
    assert rms(meas[0]) == pytest.approx(1 / np.sqrt(2), rel=1e-9)
    assert m.rms_error_pct[0] == pytest.approx(10.0, rel=1e-9)  # |1.1 - 1| / 1
    assert m.residual_pct[0] == pytest.approx(10.0, rel=1e-9)
    assert m.rms_error_pct[1] == pytest.approx(100.0)
    # a phase error is invisible to Eq. (8) but not to the residual
    shifted = np.vstack([np.cos(2 * np.pi * 5 * t), meas[1]])
    m2 = channel_metrics(shifted, meas)
    assert m2.rms_error_pct[0] < 1e-9
    assert m2.residual_pct[0] == pytest.approx(100 * np.sqrt(2), rel=1e-6)
    with pytest.raises(ShapeError, match="predicted: expected shape"):
        channel_metrics(pred[:1], meas)


def test_sliding_window_equals_batch() -> None:
    rng = np.random.default_rng(1)
    meas, pred = rng.normal(size=(2, 3, 1000))
    s = SlidingMetrics(3, window=300)
    assert s.metrics() is None
    for k in range(0, 1000, 70):
        s.push(pred[:, k:k + 70], meas[:, k:k + 70])
    got = s.metrics()
    want = channel_metrics(pred[:, -300:], meas[:, -300:])
    assert got is not None and got.samples == 300
    np.testing.assert_allclose(got.rms_error_pct, want.rms_error_pct, rtol=1e-12)
    with pytest.raises(ShapeError, match="push: expected two"):
        s.push(pred[:2, :5], meas[:2, :5])
