"""Sub-stepped simulation of a plant with a friction law (:func:`fitting.substeps`).

Known answers: the inputs held linearly between samples are the samples and the straight
lines between them; the car's highest mode (165 Hz with its 150 Hz Craig-Bampton cutoff)
gives four steps per 200 Hz sample, the building's (62 Hz) one per 500 Hz sample; and the
car with a regularised friction in its front secondary damper, simulated at 200 Hz, agrees
with the same plant stepped at 3.2 kHz (the converged answer) on its stroke and force
channels, where one step per sample does not.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from modal_twin.diagnosis.fitting import held_between_samples, simulate_record, substeps
from modal_twin.diagnosis.record import Record
from modal_twin.models.effects import EffectSpec
from modal_twin.models.loading import load_model
from modal_twin.models.track import random_profile, wheelset_inputs
from modal_twin.twin.simulator import Simulator

ROOT = Path(__file__).resolve().parents[2]
VEHICLE = ROOT / "config" / "vehicles" / "trailer_car.yaml"
BUILDING = ROOT / "config" / "structures" / "building.yaml"
FRICTION = EffectSpec("secondary_front", "regularised_friction",
                      {"Fk": 800.0, "Fs": 800.0, "kp": 1.0, "v_s": 0.0, "v_reg": 0.003,
                       "c_factor": 1.0})


def _f_max_hz(plant) -> float:
    s = plant.system
    K = np.array(s.K, dtype=float)
    for a in s.devices:
        K += a.B.T @ np.atleast_2d(a.device.reference_stiffness()) @ a.B
    lam = np.linalg.eigvals(np.linalg.solve(s.M, K)).real
    return float(np.sqrt(lam.max()) / (2 * np.pi))


def test_inputs_held_between_samples() -> None:
    ag = np.array([[0.0, 1.0, 3.0], [2.0, 2.0, -2.0]])
    up = held_between_samples(ag, 4)
    assert up.shape == (2, 9)
    np.testing.assert_allclose(up[:, ::4], ag)
    np.testing.assert_allclose(up[0], [0, 0.25, 0.5, 0.75, 1, 1.5, 2, 2.5, 3])
    np.testing.assert_allclose(up[1], [2, 2, 2, 2, 2, 1, 0, -1, -2])
    assert held_between_samples(ag, 1) is ag


def test_steps_per_sample_follow_the_highest_mode() -> None:
    car = load_model(VEHICLE)
    assert substeps(car.plant(), 200.0) == 1  # no friction law: one step
    plant = car.plant([FRICTION])
    f_max = _f_max_hz(plant)
    assert f_max == pytest.approx(165.0, rel=0.02)  # the 150 Hz cutoff's last mode
    assert substeps(plant, 200.0) == int(np.ceil(f_max / 50.0)) == 4
    assert substeps(plant, 1000.0) == 1  # 165 Hz < 250 Hz
    building = load_model(BUILDING)
    stick = building.plant([EffectSpec("ESB2", "stick_slip", {})])
    assert _f_max_hz(stick) < 0.25 * 500.0
    assert substeps(stick, 500.0) == 1


def test_friction_car_converges_at_the_record_rate() -> None:
    fs, T = 200.0, 6.0
    car = load_model(VEHICLE)
    plant = car.plant([FRICTION])
    v = 300.0 / 3.6
    u = wheelset_inputs(random_profile(v * T + 40.0, rng=5), car.spec.axle_x, v, fs, T)
    u = u * 1.5  # strokes of some centimetres: the friction slides and turns
    names = plant.channel_names
    rec = Record(fs, plant.input_names, u, names, np.zeros((len(names), u.shape[1])), "t")
    y = simulate_record(plant, rec)
    k_ref = 16
    ref = plant.measure(Simulator(plant.system, 1.0 / (k_ref * fs), modal_histories=False)
                        .step_block(held_between_samples(u, k_ref)))[:, ::k_ref]
    one = plant.measure(Simulator(plant.system, 1.0 / fs, modal_histories=False)
                        .step_block(u))
    rows = [names.index(c) for c in ("secondary_front_dz", "secondary_front_fz")]

    def nrmse(a: np.ndarray) -> np.ndarray:
        return np.sqrt(np.mean((a[rows] - ref[rows]) ** 2, axis=1) /
                       np.mean(ref[rows] ** 2, axis=1))

    assert np.all(nrmse(y) < 1e-3)  # 0.1 % of the channel's RMS
    assert np.all(nrmse(one) > 3.0 * nrmse(y))  # one step per sample does not converge
