from __future__ import annotations

import numpy as np
import pytest

from modal_twin.acquisition.calibration import calibrate
from modal_twin.errors import OptionError, ShapeError, SignalError


def test_per_channel_sensitivity_and_offset() -> None:
    v = np.array([[0.10, 0.20, -0.05], [1.0, 2.0, 3.0]])
    x = calibrate(v, [0.01, -0.5], offset_v=[0.0, 1.0])
    np.testing.assert_allclose(x[0], [10.0, 20.0, -5.0])
    np.testing.assert_allclose(x[1], [0.0, -2.0, -4.0])  # negative sensitivity flips polarity


def test_scalar_sensitivity_and_1d_input() -> None:
    np.testing.assert_allclose(calibrate([1.0, 2.0], 0.1), [[10.0, 20.0]])


def test_errors() -> None:
    with pytest.raises(ShapeError, match=r"sensitivity: expected shape \(2,\)"):
        calibrate(np.ones((2, 4)), [1.0, 2.0, 3.0])
    with pytest.raises(OptionError, match="finite non-zero"):
        calibrate(np.ones((2, 4)), [1.0, 0.0])
    with pytest.raises(ShapeError, match=r"offset_v: expected shape \(2,\)"):
        calibrate(np.ones((2, 4)), [1.0, 1.0], offset_v=[0.0, 0.0, 0.0])
    with pytest.raises(SignalError, match=r"NaN/Inf in channel\(s\) \[1\]"):
        calibrate([[1.0, 2.0], [np.nan, 1.0]], [1.0, 1.0])
    with pytest.raises(ShapeError, match="expected \\(n_channels, n_samples\\)"):
        calibrate(np.ones((2, 2, 2)), 1.0)
