from __future__ import annotations

import numpy as np
import pytest

from modal_twin.acquisition.detrend import detrend
from modal_twin.errors import OptionError, ShapeError


def test_linear_trend_removed_and_signal_kept() -> None:
    t = np.linspace(0.0, 10.0, 1001)
    s = np.sin(2 * np.pi * 1.0 * t)
    x = np.vstack([3.0 + 0.5 * t + s, -2.0 * t])
    out = detrend(x)
    # a sine over whole periods has zero mean and zero slope: it survives unchanged
    np.testing.assert_allclose(out[0], s - np.polyval(np.polyfit(t, s, 1), t), atol=1e-12)
    np.testing.assert_allclose(out[1], 0.0, atol=1e-10)


def test_constant_and_breakpoints() -> None:
    x = np.r_[np.zeros(50), np.arange(50.0)]
    np.testing.assert_allclose(detrend([1.0, 3.0], kind="constant"), [[-1.0, 1.0]])
    np.testing.assert_allclose(detrend(x, breakpoints=[50]), 0.0, atol=1e-10)


def test_errors() -> None:
    with pytest.raises(OptionError, match="kind: expected one of"):
        detrend([1.0, 2.0], kind="cubic")  # type: ignore[arg-type]
    with pytest.raises(OptionError, match="breakpoints: expected indices in"):
        detrend(np.arange(10.0), breakpoints=[10])
    with pytest.raises(ShapeError, match="at least 2 samples"):
        detrend([1.0])
