"""Live view: residual per sensor and its colour (known answers)."""

from __future__ import annotations

import numpy as np
import pytest

from modal_twin.viz.display import DisplaySamples
from modal_twin.viz.live import LiveResidual, residual_colour


def test_colour_scale_green_yellow_red() -> None:
    assert residual_colour(0.0) == 0x2CA02C
    assert residual_colour(0.1) == 0xF0C020
    assert residual_colour(0.3) == residual_colour(5.0) == 0xD62728
    assert residual_colour(float("nan")) == 0xD62728  # unknown shows as failing
    mid = residual_colour(0.05)  # halfway between green and yellow
    assert (mid >> 16) == round((0x2C + 0xF0) / 2)


def test_relative_residual_per_sensor_is_the_worst_axis() -> None:
    t = np.linspace(0.0, 2.0, 40, endpoint=False)
    m = np.vstack([np.sin(2 * np.pi * t), np.cos(2 * np.pi * t), np.sin(2 * np.pi * t)])
    names = ("R_P1_x", "R_P1_y", "F1_C1_x")
    # the twin: exact at F1_C1, 10 % low in x and 20 % low in y at R_P1
    tw = m * np.array([0.9, 0.8, 1.0])[:, None]
    live = LiveResidual({"R_P1": np.zeros(3), "F1_C1": np.ones(3)}, window=40)
    stamps = np.arange(40, dtype=np.int64)
    live.push(DisplaySamples(names, stamps, m), None)
    live.push(None, DisplaySamples(names, stamps, tw))
    rel = live.relative()
    assert rel["R_P1"] == pytest.approx(0.2, rel=1e-12)  # worst axis
    assert rel["F1_C1"] == pytest.approx(0.0, abs=1e-15)
    cmds = live.commands(0.1)
    assert len(cmds) == 4  # a coloured sphere and its position per sensor
