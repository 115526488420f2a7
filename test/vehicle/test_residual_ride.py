"""``residual --ride``: the Sperling index and floor-PSD band error beside the twin's error."""

from __future__ import annotations

import numpy as np
import pytest

from modal_twin.channels import ChannelSpec
from modal_twin.commands.residual import ride_lines


def test_ride_lines_of_a_sinusoid_equal_the_closed_form() -> None:
    fs, f, a = 200.0, 6.0, 0.5  # 0.5 m/s^2 = 50 cm/s^2 at 6 Hz, 10 s (two 5 s segments)
    t = np.arange(int(10 * fs)) / fs
    meas = np.vstack([a * np.sin(2 * np.pi * f * t), 0.1 * np.sin(2 * np.pi * f * t)])
    pred = 0.8 * meas  # the model's floor moves 20 % less
    chans = [ChannelSpec("floor_A_z", "acceleration", "floor_A", "z"),
             ChannelSpec("floor_A_y", "acceleration", "floor_A", "y")]
    lines = ride_lines(chans, ("floor_A_z", "floor_A_y"), meas, pred, fs)
    assert len(lines) == 2 and lines[1].startswith("floor_A_z")  # the lateral one left out
    w_rec, w_model, err = (float(x) for x in lines[1].split()[1:])
    # W = 0.896 (a^3 F(f) / f)^(1/10), a in cm/s^2, F(f) = 400 / f^2 for 5.9 <= f < 20 Hz
    w = 0.896 * ((100 * a) ** 3 * (400.0 / f**2) / f) ** 0.1
    assert w_rec == pytest.approx(w, abs=1e-3)
    assert w_model == pytest.approx(w * 0.8**0.3, abs=1e-3)
    assert err == pytest.approx(100 * (1 - 0.8**2), abs=0.01)  # band power 0.64x


def test_ride_lines_without_vertical_channels_say_so() -> None:
    chans = [ChannelSpec("F1_x", "acceleration", "F1", "x")]
    z = np.zeros((1, 400))
    assert ride_lines(chans, ("F1_x",), z, z, 200.0) == ["ride: no vertical acceleration channel"]
