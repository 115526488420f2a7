"""Trailer-car model: masses, carbody bending, Craig-Bampton, suspension modes, static lift."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla
import yaml

from modal_twin.errors import ConfigError, ModelError, OptionError
from modal_twin.models.craig_bampton import cb_check
from modal_twin.models.fe import FEModel
from modal_twin.models.vehicle import (
    INPUT_NAMES,
    assemble_vehicle,
    build_carbody,
    build_vehicle,
    equipment_mounted,
    load_vehicle,
    rigid_mode_count,
    theta_names,
)
from modal_twin.models.vehicle_spec import DEFAULT_VEHICLE_YAML, SensorSpec, apply_theta
from modal_twin.twin.simulator import simulate


@pytest.fixture(scope="module")
def spec():
    return load_vehicle(DEFAULT_VEHICLE_YAML)


@pytest.fixture(scope="module")
def nominal(spec):
    return assemble_vehicle(spec)


def test_spec_reads_paper_numbers(spec):
    # Sec. 2 of [002]: 25.0 m, 17.8 m pivots, 2.5 m wheelbase, 41.03 t in service.
    assert (spec.length, spec.pivot_spacing, spec.wheelbase) == (25.0, 17.8, 2.5)
    assert spec.carbody_mass == pytest.approx(41030.0, rel=1e-12)
    assert spec.axle_x == pytest.approx((10.15, 7.65, -7.65, -10.15))
    assert spec.speed == pytest.approx(300.0 / 3.6)
    assert spec.equipment_named("EQ1").mount == "rigid"


def test_total_mass_is_exact(spec, nominal):
    # carbody 41.03 t + 2 bogie frames of 2.6 t = 46.23 t, as r' M r of a rigid lift
    assert nominal.mass() == pytest.approx(spec.total_mass, rel=1e-12)
    assert spec.total_mass == pytest.approx(46230.0, rel=1e-12)
    el = assemble_vehicle(equipment_mounted(spec, "EQ1", 10.0, 0.05))
    assert el.mass() == pytest.approx(spec.total_mass, rel=1e-12)


def test_free_free_first_bending_is_873_hz(spec):
    car = build_carbody(spec)
    f = car.f_free_hz
    assert f[:2] == pytest.approx([0.0, 0.0], abs=1e-2)  # bounce and pitch (round-off)
    assert f[2] == pytest.approx(8.73, rel=0.03)  # Sec. 2 of [002]: f_mode,1 = 8.73 Hz
    assert f[2] == pytest.approx(8.73, rel=1e-3)  # measured: 8.7300 Hz
    # uniform free-free beam check: 4.730^2 / (2 pi L^2) sqrt(EI / mu) without EQ1
    bare = replace(spec, equipment=())
    mu = spec.shell_line_mass + spec.fittings_line_mass
    f_cf = 4.730041**2 / (2 * math.pi * spec.length**2) * math.sqrt(spec.EI / mu)
    assert build_carbody(bare, cutoff_hz=40.0).f_free_hz[2] == pytest.approx(f_cf, rel=1e-3)


def _modal_damping(car):
    """Frequencies (Hz) and modal damping coefficients c_r = phi_r' C phi_r (1/s) of the
    Craig-Bampton carbody (mass-normalised modes)."""
    lam, P = sla.eigh(car.cb.Kr, car.cb.Mr)
    c = np.einsum("ir,ij,jr->r", P, car.C_cb, P)
    return np.sqrt(np.clip(lam, 0.0, None)) / (2 * math.pi), c


def test_refined_mesh_keeps_every_flexible_mode_damped(spec):
    # sensors between grid nodes add nodes (shortest element 0.18 m): the largest
    # eigenvalue grows 4x, and a rule "rigid below 1e-8 of it" classed the 8.7 Hz first
    # bending rigid and left it undamped (issue 20, item 8)
    pos = (2.1, 2.35, 4.05, 6.4, 6.62, -3.3, -3.12, -6.05)
    fine = replace(spec, sensors=spec.sensors + tuple(
        SensorSpec(f"s{i}", x) for i, x in enumerate(pos)))
    car0, car = build_carbody(spec), build_carbody(fine)
    asm = car.assembly
    assert asm.n_dof > car0.assembly.n_dof
    lam = sla.eigh(asm.K.toarray(), asm.M.toarray(), eigvals_only=True)
    assert lam[2] < 1e-8 * lam.max()  # the mesh of the issue
    assert rigid_mode_count(asm) == rigid_mode_count(car0.assembly) == 2  # bounce, pitch
    assert car.f_free_hz[2] == pytest.approx(8.73, rel=1e-3)
    for c_ in (car0, car):
        f, c = _modal_damping(c_)
        flex = f > 1.0
        assert np.count_nonzero(~flex) == 2 and f[flex][0] == pytest.approx(8.73, rel=2e-3)
        # every flexible mode below the cutoff keeps its modal damping 2 zeta omega
        zeta = c[flex] / (4 * math.pi * f[flex])
        low = f[flex] < 40.0
        np.testing.assert_allclose(zeta[low], spec.zeta_carbody, rtol=0.02)
        assert np.abs(c[~flex]).max() < 1e-9 * c[flex][0]  # the rigid ones: none


def test_rigid_mode_count_follows_the_supports():
    # a free-free vertical beam has 2 rigid-body modes; pinned at one node, 1 (rotation
    # about the pin); pinned at two, none; a rigid motion not in K's null space: none
    def beam(pins):
        fem = FEModel()
        for i in range(5):
            fem.add_node(i, (float(i), 0.0, 0.0))
            fem.fix(i, ("ux", "uy", "rx", "rz"))
        for i in range(4):
            fem.add_frame(i, i + 1, E=70e9, G=27e9, A=1.0, Iy=1e-3, Iz=1e-3, J=1e-3, rho=100.0)
        for j in pins:
            fem.fix(j, ("uz",))
        return fem.assemble()

    assert [rigid_mode_count(beam(p)) for p in ((), (1,), (0, 4))] == [2, 1, 0]


def test_craig_bampton_checks(spec):
    car = build_carbody(spec)
    asm = car.assembly
    chk = cb_check(car.cb, asm.M, asm.K, rb=asm.rigid_body_modes(), f_compare_hz=30.0)
    assert chk.rb_mass_rel_err < 1e-10
    assert chk.rb_mass_full[2, 2] == pytest.approx(spec.carbody_mass, rel=1e-12)
    assert chk.kbq_rel < 1e-10
    flex = np.isfinite(chk.f_rel_err)
    assert np.count_nonzero(flex) == 2  # 8.73 and 24.9 Hz below 30 Hz
    assert np.nanmax(chk.f_rel_err) < 5e-3  # measured 0.04 % and 0.15 %
    assert car.cb.n_boundary == 3  # two pivots and EQ1


def test_bounce_and_pitch_on_the_suspension(nominal):
    f, zeta, V = nominal.damped_modes()
    assert 0.8 < f[0] < 1.5 and 0.8 < f[1] < 1.5  # measured 0.950 and 1.221 Hz
    iz = [nominal.dof_names.index(n) for n in ("uz_+8.90", "uz_-8.90")]
    for j, same_sign in ((0, True), (1, False)):
        zr = V[iz[1], j] / V[iz[0], j]
        assert (zr.real > 0) == same_sign  # bounce: pivots in phase; pitch: opposed
    bend = [j for j in range(len(f)) if 7.5 < f[j] < 10.0 and zeta[j] < 0.1]
    assert len(bend) == 1
    assert f[bend[0]] == pytest.approx(8.72, rel=0.02)  # on its suspension: 8.723 Hz


def test_static_track_lift_raises_the_whole_vehicle(spec):
    plant = build_vehicle(spec)
    sys = plant.system
    z = 0.01
    u = np.zeros(len(INPUT_NAMES))
    u[:4] = z
    q = np.linalg.solve(sys.K, -sys.Gamma @ u)  # static: K q = -Gamma u
    floor = sys.C_out[:, 2 * sys.n:] @ q  # C_out acts on q''; same rows give uz
    assert floor == pytest.approx(np.full(len(floor), z), rel=1e-9)
    # and in time: a slow ramp to z and a hold; the floor settles at z
    fs = 200.0
    t = np.arange(int(8 * fs)) / fs
    ramp = np.clip(t / 2.0, 0, 1) * z
    U = np.zeros((8, t.size))
    U[:4] = ramp
    U[4:] = np.where(t < 2.0, z / 2.0, 0.0)
    res = simulate(sys, U, 1 / fs)
    disp = sys.C_out[:, 2 * sys.n:] @ res.q[:, -1]
    assert disp == pytest.approx(np.full(len(floor), z), rel=2e-3)


def test_elastic_mount_is_a_mode_near_its_frequency(spec):
    el = equipment_mounted(spec, "EQ1", 10.0, 0.05)
    # stiff carbody: the equipment sits on a rigid car; closed form of the 2-mass system
    vm = assemble_vehicle(el, theta={"EI_carbody": 1e3 * spec.EI})
    f, zeta, V = vm.damped_modes()
    ie = vm.dof_names.index("z_EQ1")
    frac = [3000.0 * abs(V[ie, j]) ** 2 / np.real(V[:, j].conj() @ vm.M @ V[:, j])
            for j in range(len(f))]
    j = int(np.argmax(frac))
    m = 3000.0
    M = spec.carbody_mass - m
    J = M * spec.length**2 / 12.0
    f_cf = 10.0 * math.sqrt(1.0 + m * (1.0 / M + 1.5**2 / J))  # 10.403 Hz
    assert f[j] == pytest.approx(f_cf, rel=5e-3)  # measured 10.402 Hz
    assert zeta[j] == pytest.approx(0.05 * f_cf / 10.0, rel=0.05)  # measured 5.33 %
    # nominal carbody: the mount couples with the 8.7 Hz bending (a vibration absorber)
    vm = assemble_vehicle(el)
    f, zeta, V = vm.damped_modes()
    ie = vm.dof_names.index("z_EQ1")
    frac = [3000.0 * abs(V[ie, j]) ** 2 / np.real(V[:, j].conj() @ vm.M @ V[:, j])
            for j in range(len(f))]
    j = int(np.argmax(frac))
    assert 9.0 < f[j] < 12.5  # measured 11.59 Hz
    assert 0.04 < zeta[j] < 0.06  # measured 4.99 %


def test_theta_changes_model(spec):
    assert "m_EQ1" in theta_names(spec) and "f_EQ1" not in theta_names(spec)
    el = equipment_mounted(spec, "EQ1", 10.0, 0.05)
    assert {"f_EQ1", "zeta_EQ1"} <= set(theta_names(el))
    s2 = apply_theta(el, {"m_EQ1": 2000.0, "f_EQ1": 9.0, "EI_carbody": 4e9})
    eq = s2.equipment_named("EQ1")
    assert (eq.mass, eq.f_mount_hz, s2.EI) == (2000.0, 9.0, 4e9)
    assert eq.k_mount == pytest.approx(2000.0 * (2 * math.pi * 9.0) ** 2)
    vm = assemble_vehicle(spec, theta={"m_EQ1": 2000.0})
    assert vm.mass() == pytest.approx(spec.total_mass - 1000.0, rel=1e-12)
    with pytest.raises(OptionError, match=r"theta: expected names from .*'EI_carbody'"):
        apply_theta(spec, {"f_EQ1": 9.0})
    with pytest.raises(ModelError, match=r"theta\['m_EQ1'\]: expected a finite value > 0"):
        apply_theta(spec, {"m_EQ1": -1.0})


def test_suspension_of_one_bogie(spec, nominal):
    from modal_twin.models.vehicle_spec import parameter_value

    # both bogies at a value = the car at that value (the same matrices, exactly)
    both = assemble_vehicle(spec, theta={"c_secondary_front": 1.2e4,
                                         "c_secondary_rear": 1.2e4})
    car = assemble_vehicle(spec, theta={"c_secondary": 1.2e4})
    np.testing.assert_allclose(both.C, car.C, rtol=1e-12, atol=1e-9)
    # one bogie: a two-DOF damper pair (pivot, bogie) changes by the difference, nothing else
    front = assemble_vehicle(spec, theta={"c_secondary_front": 1.2e4})
    d = front.D_sec[0]
    np.testing.assert_allclose(front.C - nominal.C, (1.2e4 - spec.c_secondary) * np.outer(d, d),
                               atol=1e-6)
    s2 = apply_theta(spec, {"k_primary": 3e6, "k_primary_rear": 1.5e6})
    assert parameter_value(s2, "k_primary_rear") == pytest.approx(1.5e6)
    assert parameter_value(s2, "k_primary_front") == pytest.approx(3e6)  # follows the car
    assert {"c_secondary_front", "k_primary_rear"} <= set(theta_names(spec))


def test_hardening_mount_is_a_power_spring_on_the_mount_drift(spec):
    el = equipment_mounted(spec, "EQ1", 10.0, 0.05, u_h=0.002, m=3.0)
    vm = assemble_vehicle(el)
    system = vm.to_reduced_system()
    (att,) = system.devices
    eq = el.equipment_named("EQ1")
    dev = att.device
    # f = k d (1 + (|d| / u_h)^2) + c d': the closed form along a drift history
    d = np.linspace(-0.004, 0.004, 81)
    r = dev.respond(d[None, :])
    np.testing.assert_allclose(r.f[0], eq.k_mount * d * (1.0 + (np.abs(d) / 0.002) ** 2),
                               rtol=1e-12)
    # the drift it sees is z_EQ1 - u_floor, and the linear part left K and C: the linear
    # model plus the device's tangent at rest is the linear elastic mount
    lin = assemble_vehicle(equipment_mounted(spec, "EQ1", 10.0, 0.05)).to_reduced_system()
    np.testing.assert_allclose(system.K + eq.k_mount * att.B.T @ att.B, lin.K, atol=1e-6)
    np.testing.assert_allclose(system.C + eq.c_mount * att.B.T @ att.B, lin.C, atol=1e-9)
    with pytest.raises(ModelError, match="u_h, m: expected"):
        equipment_mounted(spec, "EQ1", 10.0, 0.05, u_h=-1.0)


def test_plant_and_secondary_devices(spec, nominal):
    plant = build_vehicle(spec)
    assert plant.input_names == INPUT_NAMES
    assert plant.channel_names[2] == "floor_mid_z"
    assert plant.channels[2].quantity == "acceleration"
    assert plant.name == "trailer_car@nominal"
    assert plant.system.n == nominal.n_dof
    assert build_vehicle(equipment_mounted(spec, "EQ1", 10.0, 0.05)).name.endswith(
        "EQ1:elastic")
    pd = build_vehicle(spec, secondary_devices=True, n_modes=8)
    assert [a.device.name for a in pd.system.devices] == ["secondary_front", "secondary_rear"]
    # with the devices' springs back, K equals the modal stiffness
    k_back = pd.system.K + sum(spec.k_secondary * a.B.T @ a.B for a in pd.system.devices)
    np.testing.assert_allclose(k_back, np.diag(nominal.omega[:8] ** 2), rtol=1e-9,
                               atol=1e-9 * nominal.omega[7] ** 2)
    n = nominal.n_dof  # the coordinates the file's cutoff keeps
    with pytest.raises(OptionError, match=rf"n_modes: expected an int in \[1, {n}\], got 0"):
        build_vehicle(spec, n_modes=0)


def test_singular_models_are_refused(spec):
    with pytest.raises(ModelError, match="coupled M is not positive definite"):
        assemble_vehicle(replace(spec, bogie_pitch_inertia=0.0))
    with pytest.raises(ModelError, match="coupled K is not positive definite"):
        assemble_vehicle(replace(spec, k_primary=0.0))


def test_equipment_mounted_errors(spec):
    with pytest.raises(OptionError, match=r"equipment: expected one of \['EQ1'\], got 'EQ9'"):
        equipment_mounted(spec, "EQ9", 10.0, 0.05)
    with pytest.raises(ModelError, match="f_hz: expected a finite value > 0, got -1"):
        equipment_mounted(spec, "EQ1", -1.0, 0.05)
    with pytest.raises(ModelError, match=r"zeta: expected a finite value >= 0, got -0\.1"):
        equipment_mounted(spec, "EQ1", 10.0, -0.1)


def _write(tmp_path: Path, change) -> Path:
    doc = yaml.safe_load(DEFAULT_VEHICLE_YAML.read_text())
    change(doc)
    p = tmp_path / "car.yaml"
    p.write_text(yaml.safe_dump(doc))
    return p


def _del(d, k):
    del d[k]


@pytest.mark.parametrize(("change", "error", "match"), [
    (lambda d: _del(d["bogie"], "mass"), ConfigError, r"bogie\.mass: missing"),
    (lambda d: d["primary"].update(k=-2e6), ModelError, r"primary\.k: expected a finite "
                                                        r"value > 0, got -2000000"),
    (lambda d: d["equipment"][0].update(mass=-5.0), ModelError,
     r"equipment\[0\] \(EQ1\)\.mass: expected a finite value > 0"),
    (lambda d: _del(d["equipment"][0], "mass"), ConfigError,
     r"equipment\[0\] \(EQ1\)\.mass: missing"),
    (lambda d: d["equipment"][0].update(mount="spring"), ConfigError,
     r"equipment\[0\] \(EQ1\)\.mount: expected one of \['rigid', 'elastic'\], got 'spring'"),
    (lambda d: d["secondary"].update(k="soft"), ConfigError,
     r"secondary\.k: expected a number, got 'soft'"),
    (lambda d: d["carbody"].update(n_elements=1.5), ConfigError,
     r"carbody\.n_elements: expected an int >= 2"),
    (lambda d: d.update(sensors=[]), ConfigError, r"sensors: expected lists"),
    (lambda d: d["equipment"].append(dict(d["equipment"][0])), ConfigError,
     r"equipment: expected unique names, got \['EQ1', 'EQ1'\]"),
    (lambda d: d["carbody"].update(pivot_spacing=30.0), ConfigError,
     r"carbody\.pivot_spacing: expected < length 25\.0"),
    (lambda d: d["sensors"][0].update(x=13.0), ConfigError,
     r"sensor front_pivot\.x: expected within \+-12\.5 m"),
    (lambda d: d["equipment"][0].update(x="mid"), ConfigError,
     r"equipment\[0\] \(EQ1\)\.x: expected a finite number"),
    (lambda d: d["equipment"].append(3), ConfigError, r"equipment\[1\]: expected a mapping"),
])
def test_bad_vehicle_files_name_the_entry(tmp_path, change, error, match):
    with pytest.raises(error, match=match):
        load_vehicle(_write(tmp_path, change))


def test_missing_file(tmp_path):
    with pytest.raises(ConfigError, match=r"no such vehicle file"):
        load_vehicle(tmp_path / "none.yaml")
