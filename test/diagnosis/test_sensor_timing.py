"""Sensor timing (issue 20, item 3): a delay line that is causal and exact on known signals,
the delay found from the record, and the candidate it makes."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from modal_twin.diagnosis.sensors import delay_of, screen_sensors
from modal_twin.models.plant import DelayLine

FS = 200.0


def test_a_delayed_sine_is_the_sine_shifted() -> None:
    t = np.arange(4000) / FS
    f = 3.7  # Hz, well below a tenth of the rate
    tau = 0.0123  # 2.46 samples
    y = np.sin(2 * np.pi * f * t)[None, :]
    out = DelayLine([(0, tau)], FS).apply(y)[0]
    ref = np.sin(2 * np.pi * f * (t - tau))
    np.testing.assert_allclose(out[10:], ref[10:], atol=2e-4)


def test_block_by_block_equals_the_whole_record() -> None:
    rng = np.random.default_rng(2)
    y = rng.standard_normal((3, 1000))
    whole = DelayLine([(0, 0.004), (2, 0.031)], FS).apply(y)
    line = DelayLine([(0, 0.004), (2, 0.031)], FS)
    blocks = np.concatenate([line.apply(y[:, a:a + 37]) for a in range(0, 1000, 37)], axis=1)
    np.testing.assert_allclose(blocks, whole, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(whole[1], y[1])  # an undelayed channel is untouched


def test_an_integer_delay_is_exact() -> None:
    y = np.arange(20.0)[None, :] ** 3  # a cubic: the Lagrange weights are exact
    out = DelayLine([(0, 3 / FS)], FS).apply(y)[0]
    np.testing.assert_allclose(out[3:], y[0, :-3], atol=1e-9)
    np.testing.assert_allclose(out[:3], 0.0)


def test_delay_of_finds_a_fractional_lag() -> None:
    rng = np.random.default_rng(5)
    sos = signal.butter(4, 15.0, fs=FS, output="sos")
    p = signal.sosfiltfilt(sos, rng.standard_normal(8000))
    tau = 0.0175  # 3.5 samples
    y = DelayLine([(0, tau)], FS).apply(p[None, :])[0] + 0.01 * rng.standard_normal(8000)
    assert delay_of(y, p, FS) == pytest.approx(tau, abs=0.15 / FS)


def test_a_late_channel_becomes_a_delay_candidate_and_its_partner_does_not() -> None:
    rng = np.random.default_rng(8)
    sos = signal.butter(4, 12.0, fs=FS, output="sos")
    pred = signal.sosfiltfilt(sos, rng.standard_normal((4, 8000)))
    names = ("F1_C1_x", "F1_C1_y", "F2_C1_x", "F2_C1_y")
    meas = pred.copy()
    meas[2] = DelayLine([(0, 0.02)], FS).apply(pred[2:3])[0]
    cands = screen_sensors(names, meas, pred, ("F2_C1_x",), fs_hz=FS)
    assert [c.law for c in cands] == ["sensor_delay"]
    assert cands[0].channel == "F2_C1_x"
    assert cands[0].value == pytest.approx(0.02, abs=0.1 / FS)


def test_both_axes_of_a_turned_sensor_make_an_orientation_candidate() -> None:
    rng = np.random.default_rng(9)
    sos = signal.butter(4, 12.0, fs=FS, output="sos")
    pred = signal.sosfiltfilt(sos, rng.standard_normal((2, 8000)))
    a = np.deg2rad(12.0)
    meas = np.vstack([np.cos(a) * pred[0] + np.sin(a) * pred[1],
                      -np.sin(a) * pred[0] + np.cos(a) * pred[1]])
    cands = screen_sensors(("S_x", "S_y"), meas, pred, ("S_x", "S_y"), fs_hz=FS)
    assert {c.law for c in cands} == {"sensor_angle"}
    assert sorted(c.value for c in cands) == pytest.approx([12.0, 12.0], abs=0.01)


def test_a_plant_with_a_late_sensor_live_and_offline() -> None:
    """The building read through a sensor 15 ms late: the twin runner (100-sample frames)
    and the offline simulation give the same channels, the late one the nominal shifted."""
    from pathlib import Path

    from modal_twin.diagnosis.fitting import simulate_record
    from modal_twin.diagnosis.record import Record
    from modal_twin.errors import OptionError
    from modal_twin.excitation import signals as sg
    from modal_twin.models.effects import EffectSpec
    from modal_twin.models.loading import load_model
    from modal_twin.models.plant import with_sensor_effects
    from modal_twin.signal_block import SignalBlock
    from modal_twin.twin.runner import TwinRunner
    from modal_twin.twin.simulator import Simulator

    fs = 1000.0
    root = Path(__file__).resolve().parents[2]
    nominal = load_model(root / "config" / "structures" / "building.yaml").plant()
    ch = "F2_C2_x"
    late = with_sensor_effects(nominal, [EffectSpec(ch, "sensor_delay", {"delay_s": 0.015})])
    ag = sg.band_limited_random(6, 2.0, fs, f_min_hz=0.2, f_max_hz=20.0, rms=1.0,
                                rng=np.random.default_rng(1)) * np.array(
                                    [1.0, 0.7, 0, 0, 0, 0])[:, None]
    names = nominal.channel_names
    rec = Record(fs, nominal.input_names, ag, names, np.zeros((len(names), ag.shape[1])))
    off_nom = simulate_record(nominal, rec)
    off_late = simulate_record(late, rec)
    i = names.index(ch)
    np.testing.assert_allclose(off_late[i, 15:], off_nom[i, :-15],
                               atol=1e-9 * np.abs(off_nom[i]).max())
    keep = [k for k in range(len(names)) if k != i]
    np.testing.assert_array_equal(off_late[keep], off_nom[keep])
    runner = TwinRunner(late, fs, window_s=1.0)
    live = []
    for k in range(0, ag.shape[1], 100):
        frame = SignalBlock((*(f"table_{n}" for n in nominal.input_names), *names), fs, k,
                            np.vstack([ag[:, k:k + 100], off_late[:, k:k + 100]]))
        live.append(runner.step(frame).prediction.data)
    pred = np.concatenate(live, axis=1)
    j = runner.compare.index(ch)
    np.testing.assert_allclose(pred[j], off_late[i], atol=1e-12 * np.abs(off_nom[i]).max())
    with pytest.raises(OptionError, match="delay_line"):
        late.measure(Simulator(late.system, 1 / fs).step_block(ag))


def test_both_axes_of_a_late_sensor_make_delay_candidates() -> None:
    rng = np.random.default_rng(10)
    sos = signal.butter(4, 12.0, fs=FS, output="sos")
    pred = signal.sosfiltfilt(sos, rng.standard_normal((2, 8000)))
    meas = DelayLine([(0, 0.01), (1, 0.01)], FS).apply(pred)
    cands = screen_sensors(("S_x", "S_y"), meas, pred, ("S_x", "S_y"), fs_hz=FS)
    assert {c.law for c in cands} == {"sensor_delay"}
    assert sorted(c.value for c in cands) == pytest.approx([0.01, 0.01], abs=0.1 / FS)
