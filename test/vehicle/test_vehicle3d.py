"""3D vehicle on a linear wheel-rail contact: closed forms, statics, hunting, track inputs."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg
import scipy.signal

from modal_twin.errors import ConfigError, ModelError, OptionError
from modal_twin.models.carbody_interface import SEAT_NAMES, ReducedCarbody, rigid_carbody
from modal_twin.models.hunting import critical_speed, hunting_branch
from modal_twin.models.track import wheelset_inputs
from modal_twin.models.track3d import (
    german_alignment_psd,
    german_cross_level_psd,
    random_track_3d,
    track_inputs_3d,
)
from modal_twin.models.vehicle3d import N_AXLES, build_vehicle3d, propagate, zoh
from modal_twin.models.vehicle3d_spec import load_vehicle3d
from modal_twin.models.wheel_rail import (
    WheelRailContact,
    bogie_kinematic_wavelength,
    contact_matrices,
    klingel_wavelength,
)

SPEEDS = np.arange(20.0, 300.1, 10.0)


@pytest.fixture(scope="module")
def spec():
    return load_vehicle3d()


@pytest.fixture(scope="module")
def vehicle(spec):
    return build_vehicle3d(spec)


@pytest.fixture(scope="module")
def hunting(vehicle):
    return critical_speed(vehicle, SPEEDS)


def _undamped(spec):
    return spec.with_values(primary={"cz": 0.0}, vertical_damper={"c": 0.0},
                            lateral_damper={"c": 0.0}, yaw_damper={"c": 0.0})


# ---------------------------------------------------------------- wheel-rail contact
@pytest.mark.parametrize("conicity", [0.05, 0.15, 0.4])
def test_free_wheelset_follows_klingel(conicity):
    """A free wheelset at low speed: kinematic frequency V / (2 pi sqrt(r0 b / lambda))."""
    c = WheelRailContact(conicity, 0.43, 0.7465, 1.0e7, 9.0e6)  # no axle load: no gravity
    V = 3.0
    Cc, Kc, _ = contact_matrices(c, V)
    M = np.diag([1900.0, 900.0])
    A = np.block([[np.zeros((2, 2)), np.eye(2)],
                  [-np.linalg.solve(M, Kc), -np.linalg.solve(M, Cc)]])
    lam = np.linalg.eigvals(A)
    osc = lam[lam.imag > 0]
    f_kin = osc[np.argmin(np.abs(osc))].imag / (2 * math.pi)
    assert f_kin == pytest.approx(V / klingel_wavelength(c), rel=2e-3)
    assert klingel_wavelength(c) == pytest.approx(2 * math.pi * math.sqrt(0.43 * 0.7465
                                                                          / conicity))


def test_bogie_wavelength_closed_form():
    c = WheelRailContact(0.15, 0.43, 0.75, 1e7, 1e7)
    assert bogie_kinematic_wavelength(c, 2.5) == pytest.approx(
        klingel_wavelength(c) * math.sqrt(1 + (1.25 / 0.75) ** 2))


def test_contact_refuses_bad_values():
    with pytest.raises(ModelError, match="conicity: expected a finite value > 0"):
        WheelRailContact(0.0, 0.43, 0.75, 1e7, 1e7)
    with pytest.raises(OptionError, match="speed: expected a finite value > 0"):
        contact_matrices(WheelRailContact(0.1, 0.43, 0.75, 1e7, 1e7), 0.0)


# ---------------------------------------------------------------- vertical closed forms
def test_bounce_frequency_is_the_two_mass_closed_form(spec):
    """Carbody and bogies bouncing on air springs in series with the primary springs."""
    sp = _undamped(spec)
    veh = build_vehicle3d(sp)
    w2 = scipy.linalg.eigh(veh.K, veh.M, eigvals_only=True)
    mc, mb = sp.v("carbody", "mass"), 2 * sp.v("bogie", "mass")
    Ks, Kp = 4 * sp.v("secondary", "kz"), 8 * sp.v("primary", "kz")
    # det([[Ks - mc w2, -Ks], [-Ks, Ks + Kp - mb w2]]) = 0
    a, b, c = mc * mb, -(mc * (Ks + Kp) + mb * Ks), Ks * Kp
    roots = np.roots([a, b, c])
    for r in roots:
        assert np.min(np.abs(w2 / r - 1.0)) < 1e-9
    # with a light bogie the bounce tends to sqrt(k_series / m), k_series = Ks Kp / (Ks + Kp)
    light = build_vehicle3d(sp.with_values(bogie={"mass": 1e-3}))
    w2l = scipy.linalg.eigh(light.K, light.M, eigvals_only=True)
    f_series = math.sqrt(Ks * Kp / (Ks + Kp) / mc) / (2 * math.pi)
    # (without the contact, lateral translation and yaw of the whole car are free: w2 ~ 0)
    assert np.min(np.abs(np.sqrt(np.abs(w2l)) / (2 * math.pi) / f_series - 1.0)) < 1e-6


def test_constant_track_inputs_move_the_car_rigidly(spec, vehicle):
    """A lift, a cross level and an alignment under every wheelset: rigid motions, exactly."""
    A, B = vehicle.state_space(50.0)
    n = vehicle.n_dof
    for comp, amount in ((0, 0.01), (1, 0.002), (2, 0.005)):  # z, phi, ya
        w = np.zeros(24)
        w[comp * N_AXLES:(comp + 1) * N_AXLES] = amount
        s = np.linalg.solve(A, -B @ w)  # static equilibrium 0 = A s + B w
        q = dict(zip(vehicle.dof_names, s[:n], strict=True))
        if comp == 0:
            for d in ("car_z", "bogie1_z", "bogie2_z"):
                assert q[d] == pytest.approx(amount, rel=1e-9)
        elif comp == 1:  # roll about the axle centre line at height r0
            r0 = spec.v("contact", "r0")
            for body, h in (("car", spec.v("carbody", "cg_height")),
                            ("bogie1", spec.v("bogie", "cg_height"))):
                assert q[f"{body}_roll"] == pytest.approx(amount, rel=1e-9)
                assert q[f"{body}_y"] == pytest.approx(-amount * (h - r0), rel=1e-9)
        else:
            for d in ("car_y", "bogie1_y", "bogie2_y", "ws1_y", "ws4_y"):
                assert q[d] == pytest.approx(amount, rel=1e-9)
            assert abs(q["ws1_yaw"]) < 1e-12


def test_maxwell_damper_becomes_a_dashpot_when_its_spring_is_stiff(spec):
    """A Maxwell element with k_series -> inf acts as the plain dashpot c (one DOF check)."""
    sp = spec.with_values(yaw_damper={"k_series": 1e12}, lateral_damper={"k_series": 1e12},
                          vertical_damper={"k_series": 1e12})
    veh = build_vehicle3d(sp)
    # the same car with the dampers as plain dashpots between the same points
    C = veh.C + veh.Gm @ np.diag(veh.cm) @ veh.Gm.T
    K = veh.K - veh.Gm @ np.diag(veh.km) @ veh.Gm.T
    n = veh.n_dof
    V = 80.0
    Cc, Kc = np.zeros_like(K), np.zeros_like(K)
    for a in range(N_AXLES):
        ix = np.ix_(*[[veh.dof(f"ws{a + 1}_y"), veh.dof(f"ws{a + 1}_yaw")]] * 2)
        Cc[ix], Kc[ix] = contact_matrices(veh.contact, V)[:2]
    A2 = np.block([[np.zeros((n, n)), np.eye(n)],
                   [-np.linalg.solve(veh.M, K + Kc), -np.linalg.solve(veh.M, C + Cc)]])
    lam2 = np.linalg.eigvals(A2)
    lam1 = veh.eigenvalues(V)
    lam1 = lam1[np.abs(lam1) < 1e4]  # drop the Maxwell states' -k/c = -4e6 .. -5e7 1/s
    assert lam1.size == lam2.size
    d = np.abs(np.sort_complex(lam1) - np.sort_complex(lam2)) / np.abs(np.sort_complex(lam2))
    assert np.max(d) < 1e-4


# ---------------------------------------------------------------- hunting
def test_critical_speed_and_time_domain_agree(vehicle, hunting):
    vc = hunting.v_critical
    assert 100.0 < vc < 250.0  # 360-900 km/h for this car
    assert hunting.zeta[0] > 0 and hunting.zeta[-1] < 0
    fs, T = 400.0, 20.0
    w = np.zeros((24, round(T * fs) + 1))
    s0 = np.zeros(vehicle.n_state)
    s0[vehicle.dof("ws1_y")] = 1e-3
    rates = {}
    for frac in (0.9, 1.1):
        V = frac * vc
        r = vehicle.simulate(w, fs, V, s0=s0, dofs=("ws1_y",))
        y = r.dofs[0]
        def rms(t0, y=y, t=r.t):
            return np.std(y[(t >= t0) & (t < t0 + 1.0)])

        slope = math.log(rms(18.0) / rms(10.0)) / 8.0  # mean rate of the envelope, 1/s
        rates[frac] = slope
        if frac > 1:  # once the stable modes died out, it grows at the hunting mode's rate
            sigma = np.max(vehicle.kinematic_modes(V).real)
            assert sigma > 0
            assert slope == pytest.approx(sigma, rel=0.05)
    assert rates[0.9] < 0 < rates[1.1]


def test_critical_speed_falls_with_conicity_and_rises_with_yaw_restraint(spec, hunting):
    vc = {}
    for lam in (0.1, 0.2, 0.3):
        vc[lam] = critical_speed(build_vehicle3d(spec.with_values(
            contact={"conicity": lam})), SPEEDS).v_critical
    assert vc[0.1] > hunting.v_critical > vc[0.2] > vc[0.3]
    # primary yaw stiffness (axle-box kx) below its optimum (~13 MN/m here), and the
    # anti-yaw dampers: both raise the critical speed
    kx = [critical_speed(build_vehicle3d(spec.with_values(primary={"kx": k})),
                         SPEEDS).v_critical for k in (2e6, 4e6, 8e6)]
    assert kx[0] < kx[1] < kx[2] < hunting.v_critical
    cy = [critical_speed(build_vehicle3d(spec.with_values(yaw_damper={"c": c})),
                         SPEEDS).v_critical for c in (5e4, 1e5)]
    assert cy[0] < cy[1] < hunting.v_critical


def test_kinematic_frequency_rises_with_speed(vehicle, hunting):
    below = hunting.speeds > 0.8 * hunting.v_critical  # where hunting is the least damped
    f = hunting.f_hz[below]
    assert np.all(np.diff(f) > 0)


def test_hunting_branch_from_critical_speed_down(vehicle, hunting):
    vc = hunting.v_critical
    V = np.array([0.4, 0.6, 0.8, 0.9, 0.98]) * vc
    zeta, f = hunting_branch(vehicle, hunting, V)
    assert np.all(np.diff(f) > 0) and np.all(np.diff(zeta) < 0) and zeta[-1] > 0
    z98, f98 = vehicle.least_damped(V[-1])  # near Vc the branch is the least damped
    assert (zeta[-1], f[-1]) == pytest.approx((z98, f98), rel=1e-9)
    # at low speed (inertia small) the hunting wavelength V / f lies between a free
    # wheelset's and a rigid bogie's (elastic primary yaw guidance); inertia lengthens it
    # with speed
    Lw = klingel_wavelength(vehicle.contact)
    Lb = bogie_kinematic_wavelength(vehicle.contact, vehicle.spec.v("bogie", "wheelbase"))
    V_low = np.array([10.0, 20.0, 40.0])
    _, f_low = hunting_branch(vehicle, hunting, V_low)
    wavelength = V_low / f_low
    assert np.all((Lw < wavelength) & (wavelength < Lb)) and np.all(np.diff(wavelength) > 0)


def test_stiff_primary_hunts_at_the_rigid_bogie_wavelength(spec):
    """Primary stiffened 10x: at a crawl the hunting branch runs at V / L_b (Wickens Sec. 4.2)."""
    stiff = build_vehicle3d(spec.with_values(primary={"kx": 1.2e8, "ky": 4.0e7}))
    h = critical_speed(stiff, SPEEDS)
    V = np.array([3.0, 5.0])
    _, f = hunting_branch(stiff, h, V, step=0.5)
    Lb = bogie_kinematic_wavelength(stiff.contact, spec.v("bogie", "wheelbase"))
    assert V / f == pytest.approx([Lb, Lb], rel=0.03)


# ---------------------------------------------------------------- simulation
def test_propagate_matches_dlsim():
    rng = np.random.default_rng(2)
    A = rng.standard_normal((6, 6)) - 3 * np.eye(6)
    B = rng.standard_normal((6, 2))
    Cm = rng.standard_normal((3, 6))
    Ad, Bd = zoh(A, B, 0.01)
    # ZOH of a scalar system against its closed form
    ad, bd = zoh(np.array([[-2.0]]), np.array([[1.0]]), 0.1)
    assert ad[0, 0] == pytest.approx(math.exp(-0.2))
    assert bd[0, 0] == pytest.approx((1 - math.exp(-0.2)) / 2.0)
    w = rng.standard_normal((2, 500))
    s0 = rng.standard_normal(6)
    y = propagate(Ad, Bd, w, s0, Cm)
    _, y_ref, _ = scipy.signal.dlsim((Ad, Bd, Cm, np.zeros((3, 2)), 0.01), w.T, x0=s0)
    assert np.allclose(y, y_ref.T, rtol=1e-9, atol=1e-9)


def test_simulate_refuses_bad_input(vehicle):
    with pytest.raises(Exception, match=r"w: expected shape \(24, nt\)"):
        vehicle.simulate(np.zeros((3, 10)), 400.0, 50.0)
    with pytest.raises(OptionError, match="dof: expected one of"):
        vehicle.simulate(np.zeros((24, 10)), 400.0, 50.0, dofs=("nope",))


# ---------------------------------------------------------------- carbody interface
def test_flexible_carbody_interface_takes_a_reduced_model(spec, vehicle):
    """The rigid carbody written as a generic reduced model gives the same vehicle."""
    rc = vehicle.carbody
    generic = ReducedCarbody(name="generic", M=rc.M.copy(), K=rc.K, C=rc.C,
                             seats=dict(rc.seats), points=dict(rc.points))
    other = build_vehicle3d(spec, generic)
    assert np.allclose(other.state_space(80.0)[0], vehicle.state_space(80.0)[0])
    assert set(SEAT_NAMES) <= set(rc.seats)
    with pytest.raises(ModelError, match="seats: expected"):
        rigid_carbody(1.0, (1.0, 1.0, 1.0), (0, 0, 0), {"seat_1L": (0, 0, 0)}, {})


def test_vehicle_file_errors(tmp_path):
    p = tmp_path / "v.yaml"
    p.write_text("kind: vehicle3d\ncarbody: {mass: 1}\n")
    with pytest.raises(ConfigError, match=r"carbody.Ixx: missing"):
        load_vehicle3d(p)
    p.write_text("carbody: {}\n")
    with pytest.raises(ConfigError, match="kind: expected 'vehicle3d'"):
        load_vehicle3d(p)


# ---------------------------------------------------------------- track
def test_alignment_and_cross_level_spectra():
    """Variance of a drawn profile = integral of its spectrum over the band."""
    band = (2.0, 60.0)
    Om = np.linspace(2 * math.pi / band[1], 2 * math.pi / band[0], 20001)
    var_a = np.trapezoid(german_alignment_psd(Om), Om)
    var_c = np.trapezoid(german_cross_level_psd(Om), Om)
    va, vcl = [], []
    for seed in range(6):
        tr = random_track_3d(3000.0, wavelength_band_m=band, rng=seed)
        va.append(np.var(tr.alignment.z))
        vcl.append(np.var(tr.cross_level.z))
    assert np.mean(va) == pytest.approx(var_a, rel=0.1)
    assert np.mean(vcl) == pytest.approx(var_c, rel=0.1)
    assert german_alignment_psd(0.3, "high") / german_alignment_psd(0.3) == pytest.approx(
        6.125 / 2.119)


def test_wheelset_inputs_are_delayed_by_axle_spacing_over_speed(spec):
    V, fs = 50.0, 400.0
    tr = random_track_3d(400.0, rng=1)
    w = track_inputs_3d(tr, spec.axle_x, V, fs, 5.0)
    assert w.shape == (24, 2001)
    lag = round((spec.axle_x[0] - spec.axle_x[1]) / V * fs)  # 2.5 m at 50 m/s: 20 samples
    assert lag == 20
    for comp in range(3):  # z, phi, ya: wheelset 2 sees wheelset 1's input 20 samples later
        a1, a2 = w[comp * 4], w[comp * 4 + 1]
        assert np.allclose(a2[lag:], a1[:-lag], rtol=0, atol=1e-9 * np.max(np.abs(a1)))
    ref = wheelset_inputs(tr.alignment, spec.axle_x, V, fs, 5.0)
    assert np.array_equal(w[8:12], ref[:4]) and np.array_equal(w[20:24], ref[4:])
