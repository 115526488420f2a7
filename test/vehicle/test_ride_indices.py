"""Ride of the 3D vehicle: Sperling Wz / Wy on sines, floor PSD against spectral theory,
the carbody-shaking check and the `modal-twin ride` command."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modal_twin.cli import main
from modal_twin.errors import OptionError
from modal_twin.models.hunting import critical_speed
from modal_twin.models.ride import (
    floor_psd,
    sperling_index,
    sperling_weight_lateral,
    sperling_weight_vertical,
)
from modal_twin.models.vehicle3d import build_vehicle3d
from modal_twin.models.vehicle3d_ride import carbody_modes, floor_psd_theory, ride_run
from modal_twin.models.vehicle3d_spec import load_vehicle3d

FS = 400.0


def _sine(a, f, fs=FS, T=10.0):
    t = np.arange(round(T * fs)) / fs
    return a * np.sin(2 * math.pi * f * t)


@pytest.fixture(scope="module")
def vehicle():
    return build_vehicle3d(load_vehicle3d())


# ---------------------------------------------------------------- Sperling on sines
@pytest.mark.parametrize(("f", "F"), [(2.0, 0.8 * 4.0), (8.0, 650.0 / 64.0), (30.0, 1.0)])
def test_lateral_sperling_of_a_sine_is_the_closed_form(f, F):
    a = 0.3  # m/s^2 = 30 cm/s^2
    w_y = sperling_index(_sine(a, f), FS, direction="lateral").W
    # W = 0.896 (a^3 F(f) / f)^(1/10), a in cm/s^2: 2 Hz -> 0.896 (27000 * 3.2 / 2)^0.1
    assert w_y == pytest.approx(0.896 * ((100 * a) ** 3 * F / f) ** 0.1, rel=1e-9)


def test_two_hz_sine_by_hand():
    """0.3 m/s^2 at 2 Hz: Wy = 0.896 * 43200^0.1 = 2.6053, Wz = 0.896 * 17550^0.1 = 2.3809."""
    x = _sine(0.3, 2.0)
    w_y = sperling_index(x, FS, direction="lateral").W
    w_z = sperling_index(x, FS, direction="vertical").W
    assert w_y == pytest.approx(2.6053, abs=1e-4)
    assert w_z == pytest.approx(2.3809, abs=1e-4)


def test_lateral_weighting_pieces():
    assert sperling_weight_lateral([0.3, 2.0, 10.0, 30.0]) == pytest.approx(
        [0.0, 3.2, 6.5, 1.0])
    lo, hi = sperling_weight_lateral([5.4 - 1e-9, 5.4])  # 23.33 against 22.29: 4.6 % step
    assert lo == pytest.approx(hi, rel=0.05)
    assert np.all(sperling_weight_lateral([2.0, 4.0]) > sperling_weight_vertical([2.0, 4.0]))
    with pytest.raises(OptionError, match="direction: expected one of"):
        sperling_index(_sine(0.1, 2.0), FS, direction="longitudinal")


def test_floor_psd_of_a_sine():
    x = _sine(0.5, 3.0, T=100.0)
    r = floor_psd(np.vstack([x, 2 * x]), FS)
    assert r.peaks_hz[0][0] == pytest.approx(3.0) and r.peaks_hz[1][0] == pytest.approx(3.0)
    df = r.f_hz[1] - r.f_hz[0]
    assert np.sum(r.psd[0]) * df == pytest.approx(0.5**2 / 2, rel=1e-3)  # variance a^2 / 2
    assert np.sum(r.psd[1]) / np.sum(r.psd[0]) == pytest.approx(4.0)


# ---------------------------------------------------------------- the vehicle's ride
def test_simulated_floor_psd_matches_spectral_theory(vehicle):
    """Welch PSD of a 400 s run against sum_c |G_c|^2 S_c (delays included), per band."""
    r = ride_run(vehicle, 300.0, duration_s=400.0, seed=2)
    f = r.psd.f_hz
    th = floor_psd_theory(vehicle, 300.0 / 3.6, f[1:])
    for i, name in enumerate(r.channels):
        for lo, hi in ((0.5, 2.0), (2.0, 5.0), (5.0, 10.0), (10.0, 20.0)):
            b = (f[1:] >= lo) & (f[1:] < hi)
            ratio = np.sum(r.psd.psd[i][1:][b]) / np.sum(th[i][b])
            assert ratio == pytest.approx(1.0, abs=0.15), (name, lo, hi)


def test_vertical_index_scales_with_the_track_level(vehicle):
    """Same phases, high vs low track: vertical floor motion x sqrt(A_high / A_low) (the car
    is symmetric, so centre-line vertical motion sees only the vertical profile and cross
    level, both scaled by A_v), so Wz x (10.80 / 4.032)^0.15 exactly."""
    lo = ride_run(vehicle, 250.0, duration_s=20.0, level="low", seed=5)
    hi = ride_run(vehicle, 250.0, duration_s=20.0, level="high", seed=5)
    for c in ("floor_front_z", "floor_mid_z", "floor_rear_z"):
        assert hi.index(c) / lo.index(c) == pytest.approx((10.80 / 4.032) ** 0.15, rel=1e-6)
    assert 1.0 < lo.index("floor_mid_z") < 3.0  # a good HST ride on a good track


def test_carbody_modes_are_the_rigid_ones(vehicle):
    modes = carbody_modes(vehicle, 300.0 / 3.6)
    labels = [m.label for m in modes]
    assert {"sway", "bounce", "roll", "pitch", "yaw"} <= set(labels)
    bounce = next(m for m in modes if m.label == "bounce")
    spec = vehicle.spec
    Ks, Kp = 4 * spec.v("secondary", "kz"), 8 * spec.v("primary", "kz")
    f_series = math.sqrt(Ks * Kp / (Ks + Kp) / spec.v("carbody", "mass")) / (2 * math.pi)
    # damped bounce of the coupled car near the series-spring frequency (0.95 Hz)
    assert bounce.f_hz == pytest.approx(f_series, rel=0.05)


def test_shaking_check_the_lateral_peak_follows_the_hunting_mode(vehicle):
    """Approaching the critical speed, the lateral floor PSD's largest peak sits at the
    kinematic (hunting) mode's frequency and moves up with speed."""
    vc = critical_speed(vehicle, np.arange(20.0, 300.1, 10.0)).v_critical
    f = np.arange(0.3, 20.0, 0.01)
    peaks, kin = [], []
    for frac in (0.9, 0.95, 0.98):
        V = frac * vc
        S = floor_psd_theory(vehicle, V, f)
        peaks.append(f[np.argmax(S[1])])  # floor_front_y
        kin.append(vehicle.least_damped(V)[1])
    assert np.allclose(peaks, kin, atol=0.1)
    assert peaks[0] < peaks[1] < peaks[2]


def test_ride_run_refuses_bad_options(vehicle):
    with pytest.raises(OptionError, match="speed_kmh: expected"):
        ride_run(vehicle, -5.0)
    with pytest.raises(OptionError, match="duration_s: expected"):
        ride_run(vehicle, 300.0, duration_s=1e6)
    with pytest.raises(OptionError, match="level: expected one of"):
        ride_run(vehicle, 300.0, level="medium")
    with pytest.raises(OptionError, match="above the hunting critical speed"):
        ride_run(vehicle, 650.0)  # critical speed 573 km/h
    crawl = ride_run(vehicle, 1.0, duration_s=10.0)  # creep damps every wheelset motion
    assert crawl.kinematic[0] == math.inf and all(m.f_hz > 0.1 for m in crawl.modes)


# ---------------------------------------------------------------- command line
def test_ride_command_prints_indices_and_critical_speed(capsys):
    assert main(["ride", "--speed", "300", "--duration", "10"]) == 0
    out = capsys.readouterr().out
    assert "hunting: critical speed" in out and "km/h" in out
    assert "mid" in out and "Wz" in out and "Wy" in out and "bounce" in out


def test_ride_command_sweep_and_json(capsys):
    import json

    assert main(["ride", "--sweep", "200:600:200", "--duration", "10", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [r["speed_kmh"] for r in doc["runs"]] == [200.0, 400.0]
    assert doc["unstable_speeds_kmh"] == [600.0]
    assert 100 < doc["critical_speed_kmh"] < 1000
    assert set(doc["runs"][0]["sperling"]) >= {"floor_mid_z", "floor_mid_y"}


@pytest.mark.parametrize("argv", [["ride", "--sweep", "3:1:1"], ["ride", "--speed", "-1"],
                                  ["ride", "nowhere.yaml"]])
def test_ride_command_errors_are_one_line(argv, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("modal-twin ride: ") and err.count("\n") == 1


def test_model_info_lists_the_3d_car(capsys):
    from modal_twin.models.vehicle3d_spec import DEFAULT_VEHICLE3D_YAML

    assert main(["model", "info", str(DEFAULT_VEHICLE3D_YAML), "--json"]) == 0
    import json

    doc = json.loads(capsys.readouterr().out)
    assert doc["n_dof"] == 6 + 12 + 8 and len(doc["maxwell_elements"]) == 10
    assert doc["total_mass_kg"] == pytest.approx(41030 + 2 * 2600 + 4 * 1900)
    assert "bounce" in [m["label"] for m in doc["carbody_modes"]]


# ---------------------------------------------------------------- a flexible carbody
def test_beam_bending_mode_shape():
    from modal_twin.models.carbody_interface import _beam_mode

    L = 25.0
    x = np.linspace(-L / 2, L / 2, 20001)
    phi = np.array([_beam_mode(v, L)[0] for v in x])
    assert np.trapezoid(phi**2, x) == pytest.approx(L, rel=1e-6)  # Blevins' normalisation
    assert abs(np.trapezoid(phi, x)) < 1e-6 * L  # orthogonal to the rigid translation
    assert abs(np.trapezoid(phi * x, x)) < 1e-6 * L**2  # and to the rigid pitch
    assert phi[0] == pytest.approx(2.0) and phi[-1] == pytest.approx(2.0)  # free ends


@pytest.fixture(scope="module")
def flexible(vehicle):
    from modal_twin.models.carbody_interface import with_bending_mode

    spec = vehicle.spec
    cb = with_bending_mode(vehicle.carbody, length=spec.v("carbody", "length"), f_hz=8.73,
                           zeta=0.02, mass=spec.v("carbody", "mass"))
    return build_vehicle3d(spec, cb)


def test_flexible_carbody_enters_through_the_interface(flexible):
    modes = carbody_modes(flexible, 300.0 / 3.6)
    bend = next(m for m in modes if m.label == "bending1")
    assert bend.f_hz == pytest.approx(8.73, rel=0.01)  # free-free 8.73 Hz, on its suspension
    assert {"bounce", "pitch", "sway"} <= {m.label for m in modes}
    r = ride_run(flexible, 280.0, duration_s=60.0)
    mid = r.channels.index("floor_mid_z")
    assert np.any(np.abs(r.psd.peaks_hz[mid] - bend.f_hz) < 0.15)  # [002]'s shaking peak


def test_speed_sweep_shows_the_flexible_resonance_filtered_by_the_bogie_spacing(flexible):
    """The symmetric bending is driven by both bogies, ~ |1 + exp(-i w L_p / V)|, and by
    both wheelsets of each, ~ |1 + exp(-i w a / V)|: at the bending frequency the mid-floor
    PSD vanishes where f_b L_p / V = k + 1/2 (224, 374 km/h) and f_b a / V = 1/2 (157 km/h)."""
    fb = next(m for m in carbody_modes(flexible, 80.0) if m.label == "bending1").f_hz
    Lp = flexible.spec.v("carbody", "pivot_spacing")
    a = flexible.spec.v("bogie", "wheelbase")
    V = np.arange(180.0, 450.0, 1.0) / 3.6
    S = np.array([floor_psd_theory(flexible, v, np.array([fb]))[2, 0] for v in V])  # mid_z
    mins = [V[i] for i in range(1, V.size - 1) if S[i] < S[i - 1] and S[i] < S[i + 1]]
    expected = [fb * Lp / (k + 0.5) for k in (2, 1)]  # 224 and 374 km/h
    assert len(mins) == 2
    assert np.allclose(mins, expected, rtol=0.02)
    assert S.max() > 30 * max(S[np.searchsorted(V, m)] for m in mins)
    v_wb = 2 * fb * a  # wheelbase null
    s_wb = floor_psd_theory(flexible, v_wb, np.array([fb]))[2, 0]
    assert S.max() > 30 * s_wb
