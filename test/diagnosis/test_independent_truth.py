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
