"""Running at 300 km/h over the German low-interference track: floor levels and S2 effect."""

from __future__ import annotations

import numpy as np
import pytest

from modal_twin.models.ride import psd_band_error, sperling_index
from modal_twin.models.track import random_profile, wheelset_inputs
from modal_twin.models.vehicle import build_vehicle, equipment_mounted, load_vehicle
from modal_twin.twin.simulator import simulate

FS = 400.0
T = 20.0


@pytest.fixture(scope="module")
def runs():
    spec = load_vehicle()
    prof = random_profile(spec.speed * T + 40.0, rng=1)
    u = wheelset_inputs(prof, spec.axle_x, spec.speed, FS, T)
    out = {}
    for label, sp in (("rigid", spec), ("elastic", equipment_mounted(spec, "EQ1", 10.0, 0.05))):
        plant = build_vehicle(sp)
        out[label] = (plant, plant.measure(simulate(plant.system, u, 1.0 / FS)))
    out["u"] = u
    return out


def test_floor_accelerations_are_realistic(runs):
    plant, y = runs["rigid"]
    assert y.shape == (len(plant.channels), round(T * FS) + 1)
    assert np.all(np.isfinite(y))
    mid = plant.channel_names.index("floor_mid_z")
    rms = float(np.std(y[mid]))
    assert 0.05 < rms < 0.5  # measured 0.240 m/s^2 (seed 1)
    W = sperling_index(y[mid], FS).W
    assert 1.5 < W < 3.0  # measured 2.11: "good" ride, below the 3.00 limit of [002]


def test_elastic_equipment_changes_the_floor_psd(runs):
    plant, y_r = runs["rigid"]
    _, y_e = runs["elastic"]
    e = psd_band_error(y_r, y_e, FS, band=(4.0, 15.0))
    mid = plant.channel_names.index("floor_mid_z")
    eq1 = plant.channel_names.index("floor_eq1_z")
    # measured: mid-car band power 0.0276 (rigid) vs 0.0117 (elastic) (m/s^2)^2, 58 %
    assert e.rel_power_error[mid] > 0.4
    assert e.rel_power_error[eq1] > 0.4
    assert e.db_rms_error[mid] > 3.0  # measured 6.6 dB
    # the change is largest near mid-car, smallest above the pivots
    piv = plant.channel_names.index("floor_front_pivot_z")
    assert e.rel_power_error[mid] > e.rel_power_error[piv]


def test_secondary_devices_reproduce_the_linear_run(runs):
    plant = build_vehicle(load_vehicle(), secondary_devices=True)
    y = plant.measure(simulate(plant.system, runs["u"][:, :2001], 1.0 / FS))
    y0 = runs["rigid"][1][:, :2001]
    assert np.abs(y - y0).max() <= 1e-9 * np.abs(y0).max()
