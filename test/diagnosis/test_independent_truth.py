"""Known answers of the independent truth of ``test/benchmarks/bench_hidden_effects.py``.

The truth (``test/benchmarks/_truth``) must be right on its own: its linear part equals the
library's linear plant (a second solver: RK4 against the library's exact modal hold), each
law meets its closed form, and it never calls the library's device laws or kernels.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import numpy as np
import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))

from _truth import laws  # noqa: E402
from _truth.building import BuildingTruth, add_masses  # noqa: E402
from _truth.records import table_random, track_inputs  # noqa: E402
from _truth.vehicle import VehicleTruth  # noqa: E402

from modal_twin.diagnosis.fitting import simulate_record  # noqa: E402
from modal_twin.diagnosis.record import Record  # noqa: E402
from modal_twin.models.loading import load_model  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


def _nrmse(pred: np.ndarray, meas: np.ndarray) -> np.ndarray:
    return np.sqrt(np.mean((pred - meas) ** 2, axis=1) / np.mean(meas**2, axis=1))


def test_building_linear_part_equals_library_plant() -> None:
    truth = BuildingTruth()
    fs = 500.0
    ag = table_random(3.0, fs, 1.0, seed=3)
    y = truth.simulate(ag, fs)
    rec = Record(fs, ("ax", "ay", "az", "arx", "ary", "arz"), ag, truth.channel_names(), y)
    lib = simulate_record(
        load_model(ROOT / "config" / "structures" / "building.yaml").plant(), rec)
    assert np.max(_nrmse(lib, y)) < 1e-3  # brief: < 1 %; RK4 at h = 0.5 ms gives ~1e-7


def test_vehicle_linear_part_equals_library_plant() -> None:
    truth = VehicleTruth()
    fs = 200.0
    u = track_inputs(truth.spec.axle_x, 300.0, 4.0, fs, 1.5e-3, seed=4)
    y = truth.simulate(u, fs)
    rec = Record(fs, ("zt1", "zt2", "zt3", "zt4", "vt1", "vt2", "vt3", "vt4"), u,
                 truth.channel_names(), y)
    lib = simulate_record(
        load_model(ROOT / "config" / "vehicles" / "trailer_car.yaml").plant(), rec)
    assert np.max(_nrmse(lib, y)) < 1e-2


def _cycle_energy(law: laws.Law, a: float, f_hz: float, n_cycles: int = 5,
                  n_per: int = 2000) -> float:
    """Energy of the last of ``n_cycles`` sine cycles of drift amplitude ``a`` (x only),
    the law's ODE states advanced by RK4 on the prescribed drift."""
    w = 2 * np.pi * f_hz
    h = 1.0 / (f_hz * n_per)
    law.reset()
    z = np.zeros(law.n_ode)
    t = np.arange(n_cycles * n_per + 1) * h
    f = np.empty(t.size)

    def uv(tt: float) -> tuple[np.ndarray, np.ndarray]:
        return (np.array([a * np.sin(w * tt), 0.0]), np.array([a * w * np.cos(w * tt), 0.0]))

    for i, ti in enumerate(t):
        u, v = uv(ti)
        f[i] = law.force(u, v, z)[0][0]
        if i == t.size - 1:
            break
        k1 = law.force(*uv(ti), z)[1]
        k2 = law.force(*uv(ti + h / 2), z + h / 2 * k1)[1]
        k3 = law.force(*uv(ti + h / 2), z + h / 2 * k2)[1]
        k4 = law.force(*uv(ti + h), z + h * k3)[1]
        z = z + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        law.commit(uv(ti + h)[0])
    last = slice((n_cycles - 1) * n_per, None)
    u = a * np.sin(w * t[last])
    return float(np.trapezoid(f[last], u))


@pytest.mark.parametrize(("a", "c"), [(0.005, 0.0), (0.03, 0.0), (0.03, 2.0e4)])
def test_boucwen_n1_loop_energy_equals_closed_form(a: float, c: float) -> None:
    k, alpha, uy, f_hz = 1.0e6, 0.3, 0.01, 0.5
    law = laws.BoucWenN1(k=k, alpha=alpha, uy=uy, c=c)
    expected = laws.boucwen_n1_loop_energy(k, alpha, uy, a) + np.pi * c * 2 * np.pi * f_hz * a**2
    assert _cycle_energy(law, a, f_hz) == pytest.approx(expected, rel=2e-3)


def test_boucwen_n1_closed_form_limits() -> None:
    k, alpha, uy = 1.0e6, 0.3, 0.01
    # far beyond yield the loop is a parallelogram of height 2 uy: area -> 4 uy (a - ...)
    big = laws.boucwen_n1_loop_energy(k, alpha, uy, 1.0)
    assert big == pytest.approx((1 - alpha) * k * 4 * uy * 1.0, rel=0.05)
    assert laws.boucwen_n1_loop_energy(k, alpha, uy, 1e-5) < 1e-6 * big


def test_iwan_backbone_equals_closed_form_of_uniform_slip_distribution() -> None:
    k, phi = 2.0e6, 0.02
    law = laws.IwanJoint(k=k, phi_max=phi, k_res=0.0, c=0.0, n_el=400)
    u = np.linspace(0.0, 1.5 * phi, 301)
    f = []
    for ui in u:
        x = np.array([ui, 0.0])
        f.append(law.force(x, np.zeros(2), np.zeros(0))[0][0])
        law.commit(x)
    expected = laws.iwan_backbone(k, phi, u)
    assert np.max(np.abs(np.array(f) - expected)) < 1e-3 * expected.max()
    assert expected[-1] == pytest.approx(0.5 * k * phi)  # all elements slip


def test_iwan_loop_energy_equals_masing_closed_form() -> None:
    k, phi, a = 2.0e6, 0.02, 0.012
    law = laws.IwanJoint(k=k, phi_max=phi, k_res=5.0e5, c=0.0, n_el=400)
    assert _cycle_energy(law, a, 1.0, n_cycles=2) == pytest.approx(
        laws.iwan_loop_energy(k, phi, a), rel=5e-3)


def test_hertz_contact_force_has_power_one_and_a_half() -> None:
    law = laws.HertzGap(k=1.0e6, c=0.0, k_h=3.0e7, g=0.05)
    zero = np.zeros(2)

    def contact(u: float) -> float:
        x = np.array([u, -u])
        f = law.force(x, zero, np.zeros(0))[0]
        assert f[1] == pytest.approx(-f[0])  # odd, per direction
        return float(f[0] - 1.0e6 * u)

    assert contact(0.049) == 0.0
    assert contact(0.05 + 0.01) == pytest.approx(3.0e7 * 0.01**1.5)
    slope = np.log(contact(0.05 + 0.02) / contact(0.05 + 0.005)) / np.log(4.0)
    assert slope == pytest.approx(1.5, rel=1e-12)


def test_stribeck_curve() -> None:
    law = laws.StribeckFriction(W=1.0e6, mu_s=0.06, mu_k=0.03, v_s=0.05, k=0.0, c=0.0,
                             eps=1e-5)
    assert law.mu(0.0) == pytest.approx(0.06)
    assert law.mu(0.05) == pytest.approx(0.03 + 0.03 / np.e)
    assert law.mu(1.0) == pytest.approx(0.03, rel=1e-9)
    speeds = np.linspace(0.0, 0.3, 50)
    assert np.all(np.diff(law.mu(speeds)) < 0)  # the coefficient falls with speed
    f = law.force(np.zeros(2), np.array([0.3, 0.4]), np.zeros(0))[0]  # |v| = 0.5 m/s
    assert f == pytest.approx(law.mu(0.5) * 1.0e6 * np.array([0.6, 0.8]), rel=1e-6)
    assert np.allclose(law.force(np.zeros(2), np.zeros(2), np.zeros(0))[0], 0.0)


def _torsion_frequency(truth: BuildingTruth, modes: slice) -> float:
    """Frequency of the mode with the largest rotary participation (arz) in ``modes``."""
    j = int(np.argmax(np.abs(truth.mb.Gamma[modes, 5])))
    return float(truth.mb.f_hz[modes][j])


ADDED = [("R_3B", 6000.0, 8.0, 12.0), ("R_B23", 4000.0, 8.0, 9.0), ("R_3AB", 4000.0, 4.0, 12.0)]


def test_eccentric_roof_mass_carries_translation_rotary_inertia_and_eccentricity() -> None:
    nominal = BuildingTruth()
    added = BuildingTruth(edits=[add_masses([(n, m) for n, m, _, _ in ADDED])])
    dM = (added.bld.P.T @ (added.bld.assembly.M @ added.bld.P)
          - nominal.bld.P.T @ (nominal.bld.assembly.M @ nominal.bld.P))
    m = np.array([a[1] for a in ADDED])
    dx, dy = np.array([a[2] for a in ADDED]) - 4.0, np.array([a[3] for a in ADDED]) - 6.0
    assert dM[0, 0] == pytest.approx(m.sum())  # translation
    assert dM[5, 5] == pytest.approx(np.sum(m * (dx**2 + dy**2)))  # rotary inertia
    assert dM[0, 5] == pytest.approx(-np.sum(m * dy))  # eccentricity: u_x = -theta_z dy
    assert dM[1, 5] == pytest.approx(np.sum(m * dx))  # u_y = theta_z dx
    for modes in (slice(0, 3), slice(3, 8)):  # isolation modes, first superstructure modes
        f0, f1 = _torsion_frequency(nominal, modes), _torsion_frequency(added, modes)
        assert f0 * 0.9 < f1 < f0  # more rotary inertia: torsion lower, by a few %


def test_elastic_mount_law_sinh_hardens() -> None:
    law = laws.SinhHardening(k=1.0e7, u0=1e-3, c=0.0)
    u = np.array([1e-6, 2e-3])
    f = law.force(u, np.zeros(2), np.zeros(0))[0]
    assert f[0] == pytest.approx(1.0e7 * 1e-6, rel=1e-6)  # tangent k at rest
    assert f[1] == pytest.approx(1.0e7 * 1e-3 * np.sinh(2.0))


BANNED = ("modal_twin.models.devices", "modal_twin.models.effects", "modal_twin.twin",
          "modal_twin.diagnosis", "modal_twin.rig")


def test_truth_imports_nothing_of_the_library_laws_or_kernels() -> None:
    files = sorted((BENCH / "_truth").glob("*.py"))
    assert len(files) >= 6
    for path in files:
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            names: list[str] = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            bad = [n for n in names if n.startswith(BANNED)]
            assert not bad, f"{path.name} imports {bad}"


def test_bench_scores_families_places_and_false_claims() -> None:
    from _truth.cases import CASES
    from bench_hidden_effects import score

    cases = {c.name: c for c in CASES}

    def eff(family: str, place: str) -> dict:
        return {"family": family, "place": place, "law": "x", "params": {}}

    two = cases["two_bw1_RB2_stribeck_ESB1"]
    got = score(two, {"effects": [eff("hysteresis", "RB2"), eff("friction", "esb1")]})
    assert got == {"family": True, "place": True, "both": True, "false_claims": 0,
                   "extra_claims": 0}
    got = score(two, {"effects": [eff("friction", "RB2"), eff("hysteresis", "ESB1")]})
    assert got == {"family": True, "place": True, "both": False, "false_claims": 0,
                   "extra_claims": 2}
    # an effect named beside the hidden ones is an extra claim
    got = score(two, {"effects": [eff("hysteresis", "RB2"), eff("friction", "ESB1"),
                                  eff("damping", "SDP1")]})
    assert got["both"] and got["extra_claims"] == 1
    got = score(two, {"effects": [eff("hysteresis", "RB2")]})
    assert got["family"] is False and got["place"] is False
    assert score(cases["mass_roof_eccentric"], {"effects": [eff("mass", "m_R")]})["both"]
    assert score(cases["control_nothing_1pct"], {"effects": [eff("mass", "R")]}) == {
        "family": False, "place": False, "both": False, "false_claims": 1, "extra_claims": 0}
    gain = cases["control_sensor_gain_F2_C2_x"]
    got = score(gain, {"effects": [eff("sensor", "F2_C2_x"), eff("damping", "SDP1")]})
    assert got["both"] and got["false_claims"] == 1


# --- the truth's pieces of the new cases (issue 20) -----------------------------------


def test_sensor_delay_and_turned_axes() -> None:
    from _truth.records import delayed, rotated

    fs, tau = 500.0, 0.010
    t = np.arange(2000) / fs
    x = np.sin(2 * np.pi * 1.5 * t)
    # a whole number of samples: an exact shift, zero before the start
    np.testing.assert_allclose(delayed(x, fs, tau)[5:], x[:-5], atol=1e-12)
    assert np.all(delayed(x, fs, tau)[:5] == 0.0)
    # half a sample: the sine delayed, within the error of linear interpolation
    half = delayed(x, fs, 0.001)
    np.testing.assert_allclose(half[1:], np.sin(2 * np.pi * 1.5 * (t[1:] - 0.001)),
                               atol=(2 * np.pi * 1.5 / fs) ** 2)
    # a pure x motion read by axes turned by 6 degrees: (cos, -sin); turned back: itself
    xy = np.vstack([x, np.zeros_like(x)])
    turned = rotated(xy, 6.0)
    np.testing.assert_allclose(turned[0], np.cos(np.radians(6.0)) * x)
    np.testing.assert_allclose(turned[1], -np.sin(np.radians(6.0)) * x)
    np.testing.assert_allclose(rotated(turned, -6.0), xy, atol=1e-15)


def test_arctan_friction_force_and_loop_energy() -> None:
    law = laws.ArctanFriction(F=800.0, v_eps=0.003)
    f = law.force(np.zeros(2), np.array([6.3 * 0.003, -1.0]), np.zeros(0))[0]
    assert f[0] == pytest.approx(0.9 * 800.0, rel=2e-3)  # 90 % at 6.3 v_eps
    assert f[1] == pytest.approx(-800.0 * 2 / np.pi * np.arctan(1.0 / 0.003))
    # at a sliding speed far above v_eps a cycle dissipates the Coulomb 4 F a
    e = _cycle_energy(law, 0.01, 2.0, n_cycles=2)
    assert e == pytest.approx(4 * 800.0 * 0.01, rel=0.03)


def test_per_channel_noise_levels() -> None:
    from _truth.records import measured

    rng = np.random.default_rng(1)
    clean = rng.standard_normal((3, 20000))
    names = ("a_x", "RB1_dx", "RB1_fx")
    rec = measured(("ax",), np.zeros((1, 20000)), names, clean, 500.0, 2.0, 3, "t",
                   pct_of={"RB1_dx": 0.02, "RB1_fx": 0.02})
    np.testing.assert_allclose(rec.noise_floor, [0.02, 2e-4, 2e-4], rtol=0.03)


def test_added_bending_damping_raises_the_first_bending_mode_only() -> None:
    import scipy.linalg as sla

    base, more = VehicleTruth(), VehicleTruth(bending_zeta_add=0.03)
    phi, w = more.bending_mode()
    assert w / (2 * np.pi) == pytest.approx(more.vm.carbody.f_free_hz[2], rel=0.05)
    floor = dict(zip(more.channel_names(), more.vm.S @ phi, strict=True))
    # bending: the ends move against the middle (nodes at 0.22 L from the ends)
    assert np.sign(floor["floor_front_end_z"]) == np.sign(floor["floor_rear_end_z"]) \
        != np.sign(floor["floor_mid_z"])

    def zetas(t: VehicleTruth) -> tuple[np.ndarray, np.ndarray]:
        K, C, _ = t.matrices()
        n = K.shape[0]
        A = np.block([[np.zeros((n, n)), np.eye(n)],
                      [-np.linalg.solve(t.vm.M, K), -np.linalg.solve(t.vm.M, C)]])
        lam = sla.eigvals(A)
        lam = lam[lam.imag > 1e-6]
        return np.abs(lam), -lam.real / np.abs(lam)

    (w0, z0), (w1, z1) = zetas(base), zetas(more)
    j0, j1 = np.argmin(np.abs(w0 - w)), np.argmin(np.abs(w1 - w))
    assert z1[j1] - z0[j0] == pytest.approx(0.03, abs=0.005)  # damped modes: nearly 0.03
    others0 = np.delete(z0[np.argsort(w0)], np.argsort(np.argsort(w0))[j0])
    others1 = np.delete(z1[np.argsort(w1)], np.argsort(np.argsort(w1))[j1])
    np.testing.assert_allclose(others1[:4], others0[:4], atol=0.005)


def test_car_device_channels_are_stroke_and_spring_dashpot_friction_force() -> None:
    fs = 200.0
    fric = laws.ArctanFriction(800.0, 0.003)
    truth = VehicleTruth(damper_law=(0, fric), device_channels=True)
    u = track_inputs(truth.spec.axle_x, 300.0, 3.0, fs, 1.5e-3, seed=5)
    y = truth.simulate(u, fs)
    names = truth.channel_names()
    s, f = y[names.index("secondary_rear_dz")], y[names.index("secondary_rear_fz")]
    rate = np.gradient(s, 1.0 / fs)
    lin = truth.spec.k_secondary * s + truth.spec.c_secondary * rate
    # the rate by central differences at 200 Hz: a few % off the exact one
    assert _nrmse(lin[None, 10:-10], f[None, 10:-10])[0] < 0.05  # no friction at the rear
    s, f = y[names.index("secondary_front_dz")], y[names.index("secondary_front_fz")]
    rate = np.gradient(s, 1.0 / fs)
    extra = (f - truth.spec.k_secondary * s - truth.spec.c_secondary * rate)[10:-10]
    fr = fric.force(np.vstack([np.zeros_like(rate), np.zeros_like(rate)]),
                    np.vstack([rate, np.zeros_like(rate)]), np.zeros(0))[0][0][10:-10]
    assert np.corrcoef(extra, fr)[0, 1] > 0.9  # the front force carries the friction
    assert 0.5 * 800.0 < np.sqrt(np.mean(extra**2)) < 800.0


def test_bench_scores_new_cases_strictly() -> None:
    from _truth.cases import NEW_CASES
    from bench_hidden_effects import score_strict

    cases = {c.name: c for c in NEW_CASES}
    assert len(cases) >= 12 and all(c.new for c in NEW_CASES)

    def eff(family: str, place: str, law: str = "x") -> dict:
        return {"family": family, "place": place, "law": law, "params": {}}

    two = cases["new_two_stribeck_ESB2_bw1_RB1"]
    right = [eff("friction", "ESB2"), eff("hysteresis", "RB1")]
    assert score_strict(two, {"effects": right}) == {
        "family": True, "place": True, "both": True, "false_claims": 0, "extra_claims": 0}
    # anything named beside the hidden effects makes the case wrong and is a false claim
    got = score_strict(two, {"effects": [*right, eff("damping", "SDP1")]})
    assert not got["both"] and got["false_claims"] == 1
    got = score_strict(two, {"effects": [eff("friction", "ESB2")]})
    assert not got["both"] and got["false_claims"] == 0
    # a sensor effect must be of the hidden kind, on a channel of that sensor
    delay = cases["new_sensor_delay_F3_C2"]
    assert score_strict(delay, {"effects": [eff("sensor", "F3_C2_x", "sensor_delay"),
                                            eff("sensor", "F3_C2_y", "sensor_delay")]})["both"]
    got = score_strict(delay, {"effects": [eff("sensor", "F3_C2_x", "sensor_gain")]})
    assert not got["family"] and got["place"] and got["false_claims"] == 1
    turn = cases["new_sensor_orientation_F1_C3"]
    assert score_strict(turn, {"effects": [eff("sensor", "F1_C3_x", "sensor_angle")]})["both"]
    # a mass one floor too low: family right, place wrong
    got = score_strict(cases["new_mass_F3_quiet_devices"], {"effects": [eff("mass", "F2")]})
    assert got["family"] and not got["place"] and got["false_claims"] == 1
    assert score_strict(cases["new_veh_carbody_bending_damping"],
                        {"effects": [eff("damping", "zeta_carbody", "damping")]})["both"]
    ctrl = cases["new_veh_control_devices"]
    assert score_strict(ctrl, {"effects": []})["both"]
    assert score_strict(ctrl, {"effects": [eff("damping", "secondary")]})["false_claims"] == 1
    # issue 20, item 2: a reversed polarity is not a gain, a drift not an offset, a swap not
    # a turn
    flip = cases["new_sensor_polarity_F1_C2_y"]
    assert score_strict(flip, {"effects": [eff("sensor", "F1_C2_y", "sensor_polarity")]})["both"]
    assert not score_strict(flip, {"effects": [eff("sensor", "F1_C2_y", "sensor_gain")]})["both"]
    creep = cases["new_sensor_drift_F2_C3_y"]
    assert score_strict(creep, {"effects": [eff("sensor", "F2_C3_y", "sensor_drift")]})["both"]
    assert not score_strict(creep, {"effects": [eff("sensor", "F2_C3_y",
                                                    "sensor_offset")]})["both"]
    cross = cases["new_sensor_swap_F3_C1"]
    assert score_strict(cross, {"effects": [eff("sensor", "F3_C1_x", "sensor_swap")]})["both"]
    assert not score_strict(cross, {"effects": [eff("sensor", "F3_C1_x", "sensor_angle"),
                                                eff("sensor", "F3_C1_y", "sensor_angle")]})["both"]


def test_reversed_creeping_and_crossed_readings() -> None:
    from _truth.records import creeping, measured

    fs, nt = 500.0, 5000
    rng = np.random.default_rng(2)
    clean = rng.standard_normal((3, nt))
    names = ("S_x", "S_y", "S_z")
    rec = measured(("ax",), np.zeros((1, nt)), names, clean, fs, 0.0, 3, "t",
                   {"S_z": -1.0}, drifts={"S_y": (0.1, -0.02)}, swaps=(("S_x", "S_y"),))
    t = np.arange(nt) / fs
    np.testing.assert_allclose(creeping(nt, fs, 0.1, -0.02), 0.1 - 0.02 * t)
    np.testing.assert_allclose(rec.data[0], clean[1] + 0.1 - 0.02 * t)  # S_y's, on S_x
    np.testing.assert_allclose(rec.data[1], clean[0])
    np.testing.assert_allclose(rec.data[2], -clean[2])


def test_car3d_hung_box_truth_equals_library_plant_and_its_hanger_law_acts(
        tmp_path: Path) -> None:
    """The 3D truth with EQ1 on its hangers (session 8): its linear part, floor and hanger
    strokes and forces, is the library plant of the file with EQ1 elastic; a linear law of
    the hanger's own k at one hanger is the linear truth; the softening law's force channel
    is ``k_r d + (k - k_r) u0 tanh(d / u0) + c d'``."""
    from _truth.vehicle3d import INPUTS as V3_INPUTS
    from _truth.vehicle3d import VEHICLE3D_YAML, Vehicle3DTruth, track_inputs_3d

    hangers = tuple(f"EQ1_hanger{j}_z" for j in range(1, 5))
    truth = Vehicle3DTruth(hung=("EQ1",), device_channels=hangers)
    fs = 200.0
    u = track_inputs_3d(truth.spec.axle_x, truth.spec.speed_kmh, 4.0, fs, 1.5e-3, seed=5)
    y = truth.simulate(u, fs)
    rec = Record(fs, V3_INPUTS, u, truth.channel_names(), y)
    path = tmp_path / "car3d_eq1.yaml"
    path.write_text(VEHICLE3D_YAML.read_text().replace("hanger: rigid ", "hanger: elastic ", 1))
    lib = simulate_record(load_model(path).plant(), rec)
    assert np.max(_nrmse(lib, y)) < 1e-2
    k = truth.element_k("EQ1_hanger1_z")
    same = Vehicle3DTruth(hung=("EQ1",), device_channels=hangers,
                          hanger_law=("EQ1_hanger1_z", laws.LinearKC(k, 0.0)))
    np.testing.assert_allclose(same.simulate(u, fs), y, rtol=0, atol=1e-9 * np.abs(y).max())
    law = laws.TanhSoftening(k=k, k_r=0.35 * k, u0=8e-5, c=0.0)
    soft = Vehicle3DTruth(hung=("EQ1",), device_channels=hangers,
                          hanger_law=("EQ1_hanger1_z", law))
    ys = soft.simulate(u, fs)
    names = soft.channel_names()
    d, f = ys[names.index("EQ1_hanger1_z_dz")], ys[names.index("EQ1_hanger1_z_fz")]
    c = soft.elements["EQ1_hanger1_z"].c
    spring = 0.35 * k * d + 0.65 * k * 8e-5 * np.tanh(d / 8e-5)
    rate = np.gradient(d, 1.0 / fs)  # the rest is the dashpot's c d' (to the difference's error)
    c_fit = float(np.dot(f - spring, rate) / np.dot(rate, rate))
    assert c_fit == pytest.approx(c, rel=0.05)
    assert np.max(np.abs(f - k * d)) > 0.1 * np.max(np.abs(f))  # not the linear spring
    assert np.std(ys[0] - y[0]) > 0.05 * np.std(y[0])  # the floor sees it


def test_wider_cases_carry_what_they_state() -> None:
    """Session 11's ``WIDER_CASES``: the narrow-band drive stays in its band, the weak
    friction slides at ``mu_k W`` (4-5 % of the bearing's RMS restoring force), the worn
    primary damper of wheelset 1 carries ``k s + 0.4 c s'`` and its neighbour the nominal
    force, and the device-beside-sensor case is right only with a gain on that axis."""
    from _truth.building_own import BuildingOwn
    from _truth.cases import NEW_CASES, WIDER_CASES, records
    from bench_hidden_effects import score_strict
    from scipy import signal

    assert len(WIDER_CASES) >= 8 and NEW_CASES[-len(WIDER_CASES):] == WIDER_CASES
    cases = {c.name: c for c in WIDER_CASES}
    # a narrow-band drive: 0.9-1.1 Hz holds nearly all the table's power
    fs = 500.0
    a = table_random(40.0, fs, 0.5, 7, (0.9, 1.1))
    f, p = signal.welch(a[0], fs, nperseg=16384)
    assert p[(f > 0.8) & (f < 1.2)].sum() / p.sum() > 0.9
    # the weak friction: sliding force mu_k W beside the nominal spring and dashpot
    weak = cases["new_wide_weak_friction_ESB1"]
    law = weak.build().laws["ESB1"]
    w = BuildingOwn().weight("ESB1")
    v = np.array([0.3, 0.0])
    f_fric = law.force(np.zeros(2), v, np.zeros(0))[0][0] - law.c[0] * v[0]
    assert f_fric == pytest.approx(0.0018 * w, rel=1e-3)
    rec = records(weak, quick=True)["train"]
    names = rec.channel_names
    restoring = law.k[0] * rec.data[names.index("ESB1_dx")]
    assert 0.03 < f_fric / np.sqrt(np.mean(restoring**2)) < 0.06
    # the worn primary damper (wheelset 1 at 40 % of c), the others nominal
    car_case = cases["new_wide_veh_primary_wear_w1_mount_softening"]
    car = car_case.build()
    fs = 200.0
    u = track_inputs(car.axle_x, 300.0, 3.0, fs, 1.5e-3, seed=5)
    y = car.simulate(u, fs)
    names = car.channel_names()
    k_p, c_p = float(car.values["primary"]["k"]), float(car.values["primary"]["c"])

    def misfit(i: int, keep: float) -> float:
        s, force = y[names.index(f"primary_{i}_dz")], y[names.index(f"primary_{i}_fz")]
        lin = k_p * s + keep * c_p * np.gradient(s, 1.0 / fs)
        return float(_nrmse(lin[None, 10:-10], force[None, 10:-10])[0])

    assert misfit(1, 0.4) < 0.05 < misfit(1, 1.0)
    assert misfit(2, 1.0) < 0.05 < misfit(2, 0.4)

    def eff(family: str, place: str, law: str = "x") -> dict:
        return {"family": family, "place": place, "law": law, "params": {}}

    both = cases["new_wide_stribeck_ESB2_gain_F2_C1_x"]
    right = [eff("friction", "ESB2"), eff("sensor", "F2_C1_x", "sensor_gain")]
    assert score_strict(both, {"effects": right})["both"]
    assert not score_strict(both, {"effects": right[:1]})["both"]
    assert not score_strict(both, {"effects": [right[0], eff("sensor", "F2_C1_x",
                                                             "sensor_delay")]})["both"]
