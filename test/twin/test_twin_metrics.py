from __future__ import annotations

import numpy as np
import pytest

from modal_twin.errors import ShapeError
from modal_twin.twin.metrics import SlidingMetrics, StreamMetrics, channel_metrics, rms


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


def test_whole_stream_metrics_equal_batch_over_every_sample() -> None:
    # known answer: the batch Eq. (8) / NRMSE of the concatenated record, whatever the blocks
    rng = np.random.default_rng(2)
    meas = rng.normal(size=(3, 5003)) * np.array([[1.0], [1e-3], [1e4]])
    pred = 1.07 * meas + 0.1 * rng.normal(size=meas.shape) * meas.std(axis=1, keepdims=True)
    s = StreamMetrics(3)
    assert s.metrics() is None
    for k in range(0, 5003, 61):  # uneven blocks, a short last one
        s.push(pred[:, k:k + 61], meas[:, k:k + 61])
    got, want = s.metrics(), channel_metrics(pred, meas)
    assert got is not None and got.samples == 5003
    for a, b in ((got.rms_error_pct, want.rms_error_pct), (got.residual_pct, want.residual_pct),
                 (got.rms_measured, want.rms_measured)):
        np.testing.assert_allclose(a, b, rtol=1e-11)
    with pytest.raises(ShapeError, match="push: expected two"):
        s.push(pred[:2, :5], meas[:2, :5])
