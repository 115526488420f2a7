from __future__ import annotations

import numpy as np
import pytest

from modal_twin.identification.peaks import on_peak


def _two_modes(f: np.ndarray) -> np.ndarray:
    """|H|^2 of two 1 %-damped modes at 2 and 3 Hz (closed form), the second 10x weaker."""
    def one(fn: float) -> np.ndarray:
        return 1.0 / ((fn**2 - f**2) ** 2 + (2 * 0.01 * fn * f) ** 2)
    return one(2.0) + 0.1 * one(3.0)


@pytest.mark.parametrize("flank", [(3.0, 6.0), None])
def test_modes_on_their_peaks_valley_and_flank_not(flank: tuple[float, float] | None) -> None:
    f = np.arange(0.0, 6.0, 0.005)
    p = _two_modes(f)
    w = 0.02 * np.array([2.0, 3.0, 2.5, 2.2])  # 2 zeta f: twice the half-power half-width
    ok = on_peak(f, p, [2.0, 3.0, 2.5, 2.2], w, 2.0, flank=flank)
    # both modes (the weak one too); the valley between them and the strong mode's flank not
    assert ok.tolist() == [True, True, False, False]


def test_a_ripple_of_the_ratio_is_not_a_peak() -> None:
    f = np.arange(0.0, 6.0, 0.005)
    ripple = 1.0 + 0.5 * (np.abs(f - 4.0) < 0.0075)  # one line 1.5x (1.8 dB) on a flat floor
    for flank in [(3.0, 6.0), None]:
        assert on_peak(f, ripple, [4.0], [0.05], 1.4, flank=flank).tolist() == [True]
        assert on_peak(f, ripple, [4.0], [0.05], 2.0, flank=flank).tolist() == [False]
    # no line within w: not judged (flank rule); a flat spectrum has no peak: not a mode
    assert on_peak(f, np.ones_like(f), [7.0], [0.05], 2.0).tolist() == [True]
    assert on_peak(f, np.ones_like(f), [5.99], [0.05], 2.0, flank=None).tolist() == [False]
