"""Sub-steps of the simulator for a plant with a Coulomb friction law (``substeps_for``).

Known answers:

* the inputs between samples are the straight lines between them;
* the trailer car's highest mode (165 Hz with its 150 Hz Craig-Bampton cutoff) gives four
  steps per 200 Hz sample with a friction law, one without it or at 1 kHz; the building's
  (62 Hz) one per 500 Hz sample;
* sub-stepping is the simulation at the step rate read at the samples, in one block or in
  many (the live twin's frames);
* an oscillator of 40 Hz with Coulomb friction, sampled at 100 Hz, under a step load from
  rest: it swings about P / k with an amplitude that falls by 4 F / k per cycle (closed
  form, e.g. Den Hartog, "Forced vibrations with combined Coulomb and viscous friction",
  1931; per half cycle the motion is a half cosine about P / k -+ F / k); stepped once per
  sample the decrement is missed by more than half, with the sub-steps of the rule it is
  within a quarter, and at 16 steps per sample within 1.5 %;
* the live twin (frames of 50 samples) gives the offline simulation's figures on a car
  with friction in its front secondary damper, to round-off; its stroke and force channels
  are within 0.1 % of the same plant at 16 steps per sample, and more than 3x further
  off at one step per sample.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from modal_twin.diagnosis.fitting import simulate_record
from modal_twin.diagnosis.record import Record
from modal_twin.models.devices.coulomb import CoulombFriction
from modal_twin.models.effects import EffectSpec
from modal_twin.models.loading import load_model
from modal_twin.models.reduced import DeviceAttachment, ReducedSystem
from modal_twin.models.track import random_profile, wheelset_inputs
from modal_twin.signal_block import SignalBlock
from modal_twin.twin.runner import TwinRunner
from modal_twin.twin.simulator import Simulator, held_between_samples, substeps_for

ROOT = Path(__file__).resolve().parents[2]
VEHICLE = ROOT / "config" / "vehicles" / "trailer_car.yaml"
BUILDING = ROOT / "config" / "structures" / "building.yaml"
FRICTION = EffectSpec("secondary_front", "regularised_friction",
                      {"Fk": 800.0, "Fs": 800.0, "kp": 1.0, "v_s": 0.0, "v_reg": 0.003,
                       "c_factor": 1.0})
# the oscillator: m 1 kg, 40 Hz, sampled at 100 Hz (fs / 4 = 25 Hz), step load P 10 N,
# Coulomb force F 2 % of P
M_, FN, FS_SDOF, P, F = 1.0, 40.0, 100.0, 10.0, 0.2
K_ = M_ * (2 * np.pi * FN) ** 2


def _f_max_hz(plant) -> float:
    s = plant.system
    K = np.array(s.K, dtype=float)
    for a in s.devices:
        K += a.B.T @ np.atleast_2d(a.device.reference_stiffness()) @ a.B
    lam = np.linalg.eigvals(np.linalg.solve(s.M, K)).real
    return float(np.sqrt(lam.max()) / (2 * np.pi))


def _oscillator(law: str) -> ReducedSystem:
    dev = (CoulombFriction(F, F, 20.0 * K_) if law == "stick_slip"  # stuck contact 20 k
           else CoulombFriction(F, F, 1.0, v_reg=1e-3))  # 1 mm/s: 2.5 % of the peak speed
    return ReducedSystem(np.eye(1) * M_, np.zeros((1, 1)), np.eye(1) * K_, np.eye(1),
                         (DeviceAttachment(dev, np.eye(1)),), np.array([[1.0, 0.0, 0.0]]),
                         np.zeros((1, 1)))


def test_inputs_interpolated_between_samples() -> None:
    ag = np.array([[0.0, 1.0, 3.0], [2.0, 2.0, -2.0]])
    up = held_between_samples(ag, 4)
    assert up.shape == (2, 9)
    np.testing.assert_allclose(up[:, ::4], ag)
    np.testing.assert_allclose(up[0], [0, 0.25, 0.5, 0.75, 1, 1.5, 2, 2.5, 3])
    np.testing.assert_allclose(up[1], [2, 2, 2, 2, 2, 1, 0, -1, -2])
    assert held_between_samples(ag, 1) is ag


def test_steps_per_sample_follow_the_highest_mode() -> None:
    car = load_model(VEHICLE)
    assert substeps_for(car.plant().system, 1 / 200.0) == 1  # no friction law: one step
    plant = car.plant([FRICTION])
    f_max = _f_max_hz(plant)
    assert f_max == pytest.approx(165.0, rel=0.02)  # the 150 Hz cutoff's last mode
    assert substeps_for(plant.system, 1 / 200.0) == int(np.ceil(f_max / 50.0)) == 4
    assert substeps_for(plant.system, 1 / 1000.0) == 1  # 165 Hz < 250 Hz
    sim = Simulator(plant.system, 1 / 200.0)
    assert sim.substeps == 4 and sim.h == pytest.approx(1 / 800.0)
    building = load_model(BUILDING)
    stick = building.plant([EffectSpec("ESB2", "stick_slip", {})])
    assert _f_max_hz(stick) < 0.25 * 500.0
    assert substeps_for(stick.system, 1 / 500.0) == 1
    assert substeps_for(_oscillator("stick_slip"), 1 / FS_SDOF) == 2  # 40 Hz / 25 Hz


def test_sub_steps_are_the_simulation_at_the_step_rate_in_any_blocks() -> None:
    s = _oscillator("regularised_friction")
    rng = np.random.default_rng(3)
    ag = np.cumsum(rng.standard_normal((1, 301)), axis=1) * 2.0  # slides and turns
    sim = Simulator(s, 1 / FS_SDOF, modal_histories=True)
    k = sim.substeps
    whole = sim.step_block(ag)
    fine = Simulator(s, 1 / (k * FS_SDOF), substeps=1).step_block(held_between_samples(ag, k))
    scale = np.abs(fine.y).max()
    np.testing.assert_allclose(whole.y, fine.y[:, ::k], rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(whole.force, fine.force[:, ::k], rtol=0,
                               atol=1e-12 * np.abs(fine.force).max())
    assert whole.q is not None and fine.q is not None
    np.testing.assert_allclose(whole.q, fine.q[:, ::k], rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(whole.t, np.arange(301) / FS_SDOF)
    # evaluations per sample: the sum over the steps that led to it
    its = np.concatenate([[0] * (k - 1), fine.newton_iterations]).reshape(-1, k).sum(1)
    np.testing.assert_array_equal(whole.newton_iterations, its)
    sim.reset()
    parts = [sim.step_block(ag[:, a:b]) for a, b in ((0, 1), (1, 8), (8, 9), (9, 200),
                                                      (200, 200), (200, 301))]
    np.testing.assert_allclose(np.hstack([p.y for p in parts]), whole.y, rtol=0,
                               atol=1e-12 * scale)
    np.testing.assert_allclose(np.concatenate([p.t for p in parts]), whole.t)


@pytest.mark.parametrize("law", ["stick_slip", "regularised_friction"])
def test_coulomb_amplitude_decrement_with_and_without_sub_steps(law: str) -> None:
    s = _oscillator(law)
    w, xe, e = 2 * np.pi * FN, P / K_, F / K_
    t_slide = (xe / (2 * e)) * np.pi / w  # half cycles until it sticks, each pi / w
    nt = int(0.8 * t_slide * FS_SDOF) + 1
    ag = -np.full((1, nt), P / M_)  # the load from the first (rest) sample on: a step
    t = np.arange(nt) / FS_SDOF

    def decrement(substeps: int | None) -> float:
        """Fall of the amplitude about P / k -+ F / k per cycle, in units of 4 F / k."""
        r = Simulator(s, 1 / FS_SDOF, substeps=substeps).step_block(ag)
        assert r.q is not None and r.qd is not None
        x, v = r.q[0], r.qd[0]
        amp = np.hypot(x - (xe - np.sign(v) * e), v / w)  # constant within a half cycle
        sel = t > 0.05 * t_slide
        return float(-np.polyfit(t[sel], amp[sel], 1)[0] / FN / (4 * e))

    rule, one, fine = decrement(None), decrement(1), decrement(16)
    assert abs(rule - 1.0) < 0.25
    assert abs(one - 1.0) > 2.5 * abs(rule - 1.0)  # missed by far more at one step
    assert abs(fine - 1.0) < 0.015


def test_the_live_twin_gives_the_offline_figures_on_a_friction_car() -> None:
    fs, T = 200.0, 6.0
    car = load_model(VEHICLE)
    plant = car.plant([FRICTION])
    v = 300.0 / 3.6
    u = wheelset_inputs(random_profile(v * T + 40.0, rng=5), car.spec.axle_x, v, fs, T)
    u = u * 1.5  # strokes of some centimetres: the friction slides and turns
    names = plant.channel_names
    rec = Record(fs, plant.input_names, u, names, np.zeros((len(names), u.shape[1])), "t")
    off = simulate_record(plant, rec)
    runner = TwinRunner(plant, fs, window_s=1.0)
    assert runner.sim.substeps == 4
    live = []
    for k in range(0, u.shape[1], 50):
        frame = SignalBlock((*(f"table_{n}" for n in plant.input_names), *names), fs, k,
                            np.vstack([u[:, k:k + 50], off[:, k:k + 50]]))
        live.append(runner.step(frame).prediction.data)
    pred = np.concatenate(live, axis=1)
    assert runner.compare is not None
    rows = [names.index(c) for c in runner.compare]
    scale = np.abs(off[rows]).max(axis=1)
    assert np.all(np.abs(pred - off[rows]).max(axis=1) <= 1e-9 * scale)  # round-off
    # the sub-steps converge on the stroke and force channels (the same plant at 16 steps
    # per sample), where one step per sample does not
    i = [names.index(c) for c in ("secondary_front_dz", "secondary_front_fz")]

    def nrmse(substeps: int) -> np.ndarray:
        sim = Simulator(plant.system, 1 / fs, modal_histories=False, substeps=substeps)
        a = plant.measure(sim.step_block(u))[i]
        return np.sqrt(np.mean((a - ref) ** 2, axis=1) / np.mean(ref ** 2, axis=1))

    ref = plant.measure(Simulator(plant.system, 1 / fs, modal_histories=False, substeps=16)
                        .step_block(u))[i]
    assert np.all(nrmse(4) < 1e-3)  # 0.1 % of the channel's RMS
    assert np.all(nrmse(1) > 3.0 * nrmse(4))
