"""Evidence before fits: closed-form loops, family decisions on clear cases, noise floor,
sensor faults, judgement flags and ranking."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from modal_twin.diagnosis.evidence import cycle_features, device_evidence, turning_points
from modal_twin.diagnosis.families import family_of, place_of
from modal_twin.diagnosis.fitting import FittedEffect
from modal_twin.diagnosis.judge import rank
from modal_twin.diagnosis.noise import eq8_error, noise_floor, nrmse
from modal_twin.diagnosis.restoring_force import stop_operator
from modal_twin.diagnosis.sensors import screen_sensors
from modal_twin.models.effects import EffectSpec

FS = 1000.0
K, C = 1.5e6, 4.0e4


def harmonic(amps: list[float], f_hz: float = 0.5, cycles: int = 3) -> tuple[np.ndarray, ...]:
    """Drift of ``cycles`` whole cycles at each amplitude in turn, and its exact velocity."""
    n = int(cycles * FS / f_hz)
    t = np.arange(n) / FS
    w = 2 * np.pi * f_hz
    u = np.concatenate([a * np.sin(w * t) for a in amps])
    v = np.concatenate([a * w * np.cos(w * t) for a in amps])
    return u, v, w


def test_coulomb_loop_dissipates_4_f_a_per_cycle() -> None:
    F = 5.0e4
    u, v, _ = harmonic([0.05, 0.1, 0.2])
    f = K * u + F * np.tanh(v / 1e-5)
    cf = cycle_features(u, f, v, K, 0.0, FS)
    # cycles at each amplitude: E = 4 F A (closed form of a rigid-plastic loop)
    assert cf.amplitude.size >= 6
    np.testing.assert_allclose(cf.energy_excess, 4 * F * cf.amplitude, rtol=0.02)
    e_slope, _ = cf.slopes()
    assert e_slope == pytest.approx(1.0, abs=0.05)


def test_viscous_change_dissipates_pi_dc_w_a2() -> None:
    dc = 2.0e4
    u, v, w = harmonic([0.05, 0.1, 0.2])
    f = K * u + (C + dc) * v
    cf = cycle_features(u, f, v, K, C, FS)
    np.testing.assert_allclose(cf.energy_excess, np.pi * dc * w * cf.amplitude**2, rtol=0.02)
    np.testing.assert_allclose(cf.energy_nominal, np.pi * C * w * cf.amplitude**2, rtol=0.02)
    assert cf.slopes()[0] == pytest.approx(2.0, abs=0.05)


def test_cubic_secant_stiffness_against_amplitude() -> None:
    k3 = 2.0e8
    u, v, _ = harmonic([0.05, 0.1, 0.2])
    cf = cycle_features(u, K * u + k3 * u**3, v, K, 0.0, FS)
    np.testing.assert_allclose(cf.k_secant_ratio, 1 + k3 * cf.amplitude**2 / K, rtol=1e-3)
    assert cf.slopes()[1] > 0  # hardening: the secant rises with amplitude


def test_turning_points_ignore_ripples() -> None:
    t = np.arange(4000) / FS
    u = np.sin(2 * np.pi * t) + 0.01 * np.sin(2 * np.pi * 40 * t)
    ext = turning_points(u, 0.1)
    # peaks and valleys of the 1 Hz wave only: 0.25, 0.75, 1.25 ... s
    np.testing.assert_allclose(t[ext[1:]], 0.25 + 0.5 * np.arange(ext.size - 1), atol=0.01)


def random_drift(seed: int = 0, seconds: float = 12.0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    sos = signal.butter(4, [0.3, 3.0], btype="band", fs=FS, output="sos")
    u = np.vstack([signal.sosfiltfilt(sos, rng.standard_normal(int(seconds * FS)))
                   for _ in range(2)])
    return 0.1 * u / u.std()


def evidence_of(force_extra, seed: int = 0):  # type: ignore[no-untyped-def]
    u = random_drift(seed)
    v = np.gradient(u, 1 / FS, axis=1)
    f = K * u + C * v + force_extra(u, v)
    rng = np.random.default_rng(seed + 1)
    noise = 0.01 * f.std(axis=1, keepdims=True)
    f = f + noise * rng.standard_normal(f.shape)
    return device_evidence("D", u, f, [K, K], [C, C], FS, noise_var=noise[:, 0] ** 2)


def top(ev) -> str:  # type: ignore[no-untyped-def]
    sc = ev.family_scores()
    nonlinear = {g: s for g, s in sc.items() if g not in ("stiffness", "damping") and s > 0}
    pick = nonlinear or {g: s for g, s in sc.items() if s > 0}
    return max(pick, key=lambda g: pick[g]) if pick else "nothing"


@pytest.mark.parametrize(("name", "extra", "family"), [
    ("coulomb", lambda u, v: 6e4 * np.tanh(v / 0.002), "friction"),
    ("stribeck", lambda u, v: (4e4 + 4e4 * np.exp(-np.abs(v) / 0.05)) * np.tanh(v / 0.002),
     "friction"),
    ("iwan", lambda u, v: np.vstack([sum(0.1 * K * stop_operator(x, r)
                                         for r in np.linspace(0.01, 0.1, 10)) for x in u]),
     "hysteresis"),
    ("tanh softening", lambda u, v: -0.5 * K * (u - 0.08 * np.tanh(u / 0.08)), "softening"),
    ("quintic hardening", lambda u, v: 3e9 * u**5, "hardening"),
    ("contact", lambda u, v: 2 * K * np.sign(u) * np.maximum(np.abs(u) - 0.12, 0), "gap"),
    ("dashpot", lambda u, v: 3 * C * v, "damping"),
    ("stiffness", lambda u, v: 0.2 * K * u, "stiffness"),
])
def test_family_named_from_the_evidence(name: str, extra, family: str) -> None:  # type: ignore[no-untyped-def]
    assert top(evidence_of(extra)) == family, name


def test_nominal_device_shows_nothing() -> None:
    ev = evidence_of(lambda u, v: 0.0 * u)
    assert ev.significant == ()
    assert top(ev) == "nothing"
    assert all(0.0 <= s <= 1.0 for s in (*ev.alone.values(), *ev.unique.values()))


def test_noise_floor_of_a_band_limited_signal_with_white_noise() -> None:
    rng = np.random.default_rng(3)
    sos = signal.butter(6, 20.0, fs=FS, output="sos")
    x = signal.sosfiltfilt(sos, rng.standard_normal((3, 20000)))
    x /= x.std(axis=1, keepdims=True)
    sigma = np.array([0.01, 0.03, 0.1])
    y = x + sigma[:, None] * rng.standard_normal(x.shape)
    est = noise_floor(y, FS)
    np.testing.assert_allclose(est, sigma / y.std(axis=1), rtol=0.1)


def test_nrmse_sees_what_eq8_misses() -> None:
    t = np.arange(2000) / FS
    meas = np.sin(2 * np.pi * 2 * t)[None]
    shifted = np.sin(2 * np.pi * 2 * t + np.pi / 2)[None]  # same RMS, wrong waveform
    assert eq8_error(shifted, meas)[0] == pytest.approx(0.0, abs=1e-3)
    assert nrmse(shifted, meas)[0] == pytest.approx(np.sqrt(2.0), rel=1e-2)


def test_sensor_gain_on_one_channel_is_found() -> None:
    rng = np.random.default_rng(4)
    pred = rng.standard_normal((4, 5000))
    meas = pred + 0.01 * rng.standard_normal(pred.shape)
    meas[2] *= 1.08
    names = ("P1_x", "P1_y", "P2_x", "P2_y")
    found = screen_sensors(names, meas, pred, ("P2_x",))
    assert found and found[0].channel == "P2_x" and found[0].law == "sensor_gain"
    assert found[0].value == pytest.approx(1.08, abs=0.002)
    # when other places are as far off, it is structural, not one sensor
    pred3 = rng.standard_normal((6, 5000))
    meas3 = pred3 * 1.08 + 0.01 * rng.standard_normal(pred3.shape)
    names3 = ("P1_x", "P1_y", "P2_x", "P2_y", "P3_x", "P3_y")
    assert screen_sensors(names3, meas3, pred3, names3) == []
    # and when one sensor holds most of the error, both its axes are candidates
    meas3[4:] = pred3[4:] * 1.3
    both = screen_sensors(names3, meas3, pred3, names3)
    assert {c.channel for c in both} == {"P3_x", "P3_y"}


def test_sensor_orientation_is_found() -> None:
    rng = np.random.default_rng(5)
    pred = rng.standard_normal((2, 5000))
    a = np.deg2rad(6.0)
    meas = pred.copy()
    meas[0] = np.cos(a) * pred[0] + np.sin(a) * pred[1]
    found = screen_sensors(("P_x", "P_y"), meas, pred, ("P_x",))
    assert found[0].law == "sensor_angle"
    assert found[0].value == pytest.approx(6.0, abs=0.05)


def fitted(component: str, law: str, params: dict[str, float], held: float, bic: float, *,
           at_bound: tuple[str, ...] = (), rejected: str = "", flags: tuple[str, ...] = ()
           ) -> FittedEffect:
    eff = EffectSpec(component, law, params)
    return FittedEffect(eff, len(params), 1.0, held, 10.0, bic, 1, 0.0, at_bound=at_bound,
                        family=family_of(eff), place=place_of(eff), rejected=rejected,
                        flags=flags, records=(("train", 0.3, 0.1, 2.0, 30.0, 10.0),
                                              ("held", 0.3, held, 2.0, 30.0, 100 * held)))


def test_rank_usable_first_ties_by_bic_and_evidence() -> None:
    a = fitted("ESB1", "stick_slip", {"Fk": 1.0}, 0.100, bic=-50.0)
    b = fitted("ESB1", "bouc_wen", {"uy": 1.0}, 0.102, bic=-60.0)  # tied, better BIC
    c = fitted("RB1", "linear", {"k": 1.0}, 0.050, bic=-90.0, flags=("k at its bound",))
    d = fitted("RB2", "gap", {"g": 1.0}, 0.040, bic=-99.0, rejected="makes low worse")
    order = rank([a, b, c, d])
    assert [f.effect.law for f in order[:2]] == ["bouc_wen", "stick_slip"]
    assert order[2:] == [d, c] or order[2:] == [c, d]
    # the evidence at ESB1 named friction: among ties it wins over a better BIC
    order = rank([a, b], {"ESB1": "friction"})
    assert order[0].effect.law == "stick_slip"


def test_parameter_text_says_not_determined() -> None:
    f = FittedEffect(EffectSpec("RB1", "gap", {"g": 0.01, "k": 2.0}), 2, 1, 1, 1, 0, 1, 0,
                     std={"g": float("nan"), "k": 0.1})
    assert f.parameter_text() == "g=0.01 (not determined), k=2±0.1"
    assert "nan" not in f.parameter_text()


def test_family_of_fitted_laws() -> None:
    assert family_of(EffectSpec("A", "bilinear", {"ratio": 0.7})) == "softening"
    assert family_of(EffectSpec("A", "bilinear", {"ratio": 1.4})) == "hardening"
    assert family_of(EffectSpec("A", "cubic", {"k3": -1.0})) == "softening"
    assert family_of(EffectSpec("m_F2", "added_mass", {"m_F2": 1.0})) == "mass"
    assert place_of(EffectSpec("m_F2", "added_mass", {"m_F2": 1.0})) == "F2"
    assert family_of(EffectSpec("A", "linear", {"k": 2.0, "c": 1.0}), nominal_k=1.0,
                     nominal_c=1.0) == "stiffness"
