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


def test_live_deflections_are_the_expanded_sensor_motion() -> None:
    """Sensor samples made from two known mode shapes expand back onto every node."""
    rng = np.random.default_rng(2)
    xyz = rng.normal(size=(6, 3))
    sensors = {"A": xyz[0], "B": xyz[3], "C": xyz[5]}
    basis = rng.normal(size=(2, 6, 3))
    names = ("A_x", "A_y", "B_z", "C_x", "C_y")
    where = [(0, 0), (0, 1), (3, 2), (5, 0), (5, 1)]
    at_ch = np.stack([basis[:, n, a] for n, a in where])
    q = rng.normal(size=(2, 10))
    live = LiveResidual(sensors, window=10)
    stamps = np.arange(10, dtype=np.int64)
    live.push(DisplaySamples(names, stamps, at_ch @ q), None)
    live.push(None, DisplaySamples(names, stamps, 0.5 * at_ch @ q))  # twin: half
    shapes = live.deflections(xyz, basis)
    assert shapes is not None
    um, ut = shapes
    full = np.einsum("k,knd->nd", q[:, -1], basis)  # the latest sample on every node
    peak = np.abs(np.einsum("kt,knd->tnd", q, basis)).max()  # largest of the window
    np.testing.assert_allclose(um, full / peak, atol=1e-10)
    np.testing.assert_allclose(ut, 0.5 * full / peak, atol=1e-10)
    edges = np.array([[0, 1], [2, 5]])
    cmds = [c.lower() for c in live.shape_commands(xyz, edges, basis, 2.0)]
    assert [c["path"] for c in cmds] == ["/modal_twin/live/measured_shape",
                                         "/modal_twin/live/twin_shape"]
    assert LiveResidual(sensors).deflections(xyz, basis) is None
