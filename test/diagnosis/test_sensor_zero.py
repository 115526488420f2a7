"""Sensor polarity, offset / drift and crossed cables (issue 20, item 2): the plant reads
through them exactly, the screening finds them with their values, and the diagnosis of a
record read through them corrects it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy import signal

from modal_twin.diagnosis.sensors import screen_sensors, shifted_zero
from modal_twin.errors import OptionError
from modal_twin.models.effects import EffectSpec
from modal_twin.models.plant import DelayLine, with_sensor_effects

FS = 200.0
ROOT = Path(__file__).resolve().parents[2]


def _band(n_ch: int, nt: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    sos = signal.butter(4, 12.0, fs=FS, output="sos")
    return signal.sosfiltfilt(sos, rng.standard_normal((n_ch, nt)))


def test_a_creeping_zero_block_by_block_is_offset_plus_rate_times_time() -> None:
    y = _band(3, 1000, 1)
    t = np.arange(1000) / FS
    line = DelayLine([], FS, zeros=[(1, 0.3, -0.05)])
    out = np.concatenate([line.apply(y[:, a:a + 37]) for a in range(0, 1000, 37)], axis=1)
    np.testing.assert_allclose(out[1], y[1] + 0.3 - 0.05 * t, atol=1e-12)
    np.testing.assert_array_equal(out[[0, 2]], y[[0, 2]])
    with pytest.raises(OptionError, match="finite"):
        DelayLine([], FS, zeros=[(0, float("nan"), 0.0)])


def test_shifted_zero_recovers_offset_and_drift_within_their_sigma() -> None:
    rng = np.random.default_rng(3)
    n, b, r = 4000, 0.02, 0.005
    t0 = 1.5  # the first sample given is 1.5 s into the record (an unscored lead)
    t = t0 + np.arange(n) / FS
    noise = 0.01 * rng.standard_normal(n)
    resid = b + r * t + noise
    off, drift = shifted_zero("S_y", resid, FS, t0)
    assert (off.law, drift.law) == ("sensor_offset", "sensor_drift")
    # what is left is the noise: the share removed is 1 - noise energy / residual energy
    assert drift.gain == pytest.approx(1.0 - np.sum(noise**2) / np.sum(resid**2), abs=1e-3)
    assert off.gain < drift.gain - 0.1
    assert drift.params["rate"] == pytest.approx(r, abs=3 * drift.stds["rate"])
    assert drift.params["offset"] == pytest.approx(b, abs=3 * drift.stds["offset"])
    assert drift.stds["rate"] < 0.05 * r
    off, drift = shifted_zero("S_y", b + noise, FS, t0)  # no drift: an offset alone
    assert off.value == pytest.approx(b, abs=3 * off.std)
    assert drift.params["rate"] == pytest.approx(0.0, abs=3 * drift.stds["rate"])
    assert off.gain > 0.7


def test_screening_names_polarity_drift_and_swap_with_their_values() -> None:
    pred = _band(6, 8000, 4)
    names = ("A_x", "A_y", "B_x", "B_y", "C_x", "C_y")
    rng = np.random.default_rng(5)
    meas = pred + 0.005 * rng.standard_normal(pred.shape)
    meas[1] = -meas[1]  # A_y reversed
    t = np.arange(8000) / FS
    meas[2] += 0.1 + 0.02 * t  # B_x creeps
    meas[[4, 5]] = meas[[5, 4]]  # C's cables crossed
    got = screen_sensors(names, meas, pred, ("A_y",), fs_hz=FS)
    assert [(c.channel, c.law, c.value) for c in got] == [("A_y", "sensor_polarity", -1.0)]
    got = screen_sensors(names, meas, pred, ("B_x",), fs_hz=FS)
    assert [(c.channel, c.law) for c in got] == [("B_x", "sensor_drift"),
                                                  ("B_x", "sensor_offset")]
    assert got[0].params["offset"] == pytest.approx(0.1, abs=3 * got[0].stds["offset"])
    assert got[0].params["rate"] == pytest.approx(0.02, abs=3 * got[0].stds["rate"])
    got = screen_sensors(names, meas, pred, ("C_x", "C_y"), fs_hz=FS)
    swap = [c for c in got if c.law == "sensor_swap"]
    assert [c.channel for c in swap] == ["C_x"] and swap[0].gain > 0.99
    # a sensor turned by 12 degrees is not a swap, nor a zero error
    a = np.deg2rad(12.0)
    turned = np.vstack([np.cos(a) * pred[4] + np.sin(a) * pred[5],
                        -np.sin(a) * pred[4] + np.cos(a) * pred[5]])
    got = screen_sensors(("C_x", "C_y"), turned, pred[4:], ("C_x", "C_y"), fs_hz=FS)
    assert {c.law for c in got} == {"sensor_angle"}


def test_a_zero_error_on_a_channel_off_with_its_mates_is_not_tried() -> None:
    pred = _band(2, 8000, 6)
    t = np.arange(8000) / FS
    meas = pred * 1.3 + 0.1 + 0.02 * t  # the whole place off: not one channel's zero
    got = screen_sensors(("P_x", "P_y"), meas, pred, ("P_x", "P_y"), fs_hz=FS)
    assert not {c.law for c in got} & {"sensor_offset", "sensor_drift"}


def _building():
    from modal_twin.models.loading import load_model

    return load_model(ROOT / "config" / "structures" / "building.yaml")


def _record(plant, seconds: float, rms: float, seed: int):
    from modal_twin.diagnosis.fitting import simulate_record
    from modal_twin.diagnosis.record import Record
    from modal_twin.excitation import signals as sg

    fs = 200.0
    ag = sg.band_limited_random(6, seconds, fs, f_min_hz=0.2, f_max_hz=15.0, rms=rms,
                                rng=np.random.default_rng(seed)) * np.array(
                                    [1.0, 0.8, 0.3, 0, 0, 0])[:, None]
    names = plant.channel_names
    blank = Record(fs, plant.input_names, ag, names, np.zeros((len(names), ag.shape[1])))
    clean = simulate_record(plant, blank)
    rng = np.random.default_rng(100 + seed)
    sd = 0.01 * np.sqrt(np.mean(clean**2, axis=1, keepdims=True))
    return Record(fs, plant.input_names, ag, names, clean + sd * rng.standard_normal(
        clean.shape), f"seed{seed}")


def test_plant_reads_reversed_and_crossed_channels_exactly() -> None:
    from modal_twin.diagnosis.fitting import simulate_record

    nominal = _building().plant()
    rec = _record(nominal, 2.0, 1.0, 1)
    base = simulate_record(nominal, rec)
    names = nominal.channel_names
    i, j, k = (names.index(c) for c in ("F1_C2_y", "F3_C1_x", "F3_C1_y"))
    flip = simulate_record(with_sensor_effects(
        nominal, [EffectSpec("F1_C2_y", "sensor_polarity")]), rec)
    np.testing.assert_array_equal(flip[i], -base[i])
    cross = simulate_record(with_sensor_effects(
        nominal, [EffectSpec("F3_C1_x", "sensor_swap")]), rec)
    np.testing.assert_array_equal(cross[[j, k]], base[[k, j]])
    creep = simulate_record(with_sensor_effects(
        nominal, [EffectSpec("F2_C3_y", "sensor_drift", {"offset": 0.02, "rate": 0.005})]), rec)
    m = names.index("F2_C3_y")
    t = np.arange(rec.n_samples) / rec.fs_hz
    np.testing.assert_allclose(creep[m], base[m] + 0.02 + 0.005 * t, atol=1e-12)


@pytest.mark.parametrize(("effect", "law", "values"), [
    (EffectSpec("F1_C2_y", "sensor_polarity"), "sensor_polarity", {}),
    (EffectSpec("F2_C3_y", "sensor_drift", {"offset": 0.02, "rate": 0.005}), "sensor_drift",
     {"offset": 0.02, "rate": 0.005}),
    (EffectSpec("F3_C1_x", "sensor_swap"), "sensor_swap", {}),
])
def test_the_diagnosis_corrects_a_record_read_through_a_sensor_error(
        effect: EffectSpec, law: str, values: dict[str, float]) -> None:
    """A record read through a known sensor error (1 % noise): the diagnosis names that
    error at its channel, with its values, and nothing else."""
    from modal_twin.diagnosis.pipeline import diagnose

    factory = _building()
    truth = with_sensor_effects(factory.plant(), [effect])
    train, test, low = (_record(truth, 4.0, r, s) for r, s in ((1.0, 11), (2.0, 12),
                                                               (0.05, 13)))
    d = diagnose(factory, train, test, levels=[low])
    assert [(f.effect.component, f.effect.law) for f in d.found] == [(effect.component, law)]
    got = d.found[0].effect.params
    for k, v in values.items():
        assert got[k] == pytest.approx(v, rel=0.05)
    assert d.found[0].family == "sensor"
    assert d.after[1].median_over_noise < 1.2
