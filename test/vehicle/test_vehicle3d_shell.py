"""The 3D car with the Craig-Bampton shell carbody (issue 23, items 4 and 7).

Known answers: the coupled car's rigid-body mass is the shell's plus the bogies' and
wheelsets' (and a rigid translation strains no suspension); the carbody's free-free
flexible frequencies in the car are the standalone CB carbody's and the full shell's; with
stiff secondary and primary vertical springs the car's flexible carbody modes tend to those
of the shell supported vertically at its seats (a full FE solution with those DOFs fixed);
the hunting critical speed with the flexible carbody is within a few % of the one with a
rigid carbody of the same mass properties (flexibility above 8 Hz hardly touches a 6-7 Hz
kinematic mode); the floor's vertical PSD peaks at the first vertical bending of the
coupled car at every speed of a sweep, by spectral theory and in a simulated run.

One shell reduction (default mesh, 6.8k DOFs) serves the module: the vehicles built from
variants of the spec reuse its carbody.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp

from modal_twin.cli import main
from modal_twin.errors import ConfigError, OptionError
from modal_twin.models.carbody_interface import rigid_carbody
from modal_twin.models.carbody_reduction import reduced_modes
from modal_twin.models.carbody_shell import ShellCarbody, shell_carbody
from modal_twin.models.fe import solve_modes
from modal_twin.models.hunting import critical_speed
from modal_twin.models.vehicle3d import build_vehicle3d
from modal_twin.models.vehicle3d_ride import carbody_modes, floor_psd_theory, ride_run
from modal_twin.models.vehicle3d_spec import load_vehicle3d

SPEEDS = np.arange(100.0, 250.1, 10.0)


@pytest.fixture(scope="module")
def spec():
    return load_vehicle3d().with_carbody("shell")


@pytest.fixture(scope="module")
def car(spec):
    return build_vehicle3d(spec)


@pytest.fixture(scope="module")
def shell(car) -> ShellCarbody:
    assert isinstance(car.carbody.source, ShellCarbody)
    return car.carbody.source


def _rigid_twin(spec, shell: ShellCarbody, car):
    """A rigid carbody of the shell's mass, centre of gravity and inertia (no products)."""
    m = shell.rigid_mass[0, 0]
    G = shell.cg + np.array([0.0, 0.0, shell.z0])
    inertia = np.diag(shell.rigid_mass)[3:]
    seats = {s: p for s, (p, _) in car.carbody.seats.items()}
    pts = {s: p for s, (p, _) in car.carbody.points.items()}
    return rigid_carbody(m, inertia, G, seats, pts, name="rigid twin of the shell")


def test_file_selects_the_carbody_model(tmp_path):
    base = load_vehicle3d()
    assert base.carbody_model == "rigid" and build_vehicle3d(base).carbody.n == 6
    assert base.shell.f_keep_hz == 40.0 and base.shell.params.n_length == 30
    text = Path(base.source).read_text()
    bad = tmp_path / "v.yaml"
    bad.write_text(text.replace("model: rigid", "model: beam"))
    with pytest.raises(ConfigError, match=r"carbody.model: expected one of \['rigid', 'shell'\], "
                       r"got 'beam' \(the beam carbody is the vertical-plane vehicle"):
        load_vehicle3d(bad)
    bad.write_text(text.replace("f_keep_hz: 40.0", "f_keep: 40.0"))
    with pytest.raises(ConfigError, match=r"carbody_shell: unknown keys \['f_keep'\]"):
        load_vehicle3d(bad)
    ok = tmp_path / "w.yaml"
    ok.write_text(text.replace("model: rigid", "model: shell").replace(
        "mesh: {n_length: 30, n_width: 4, n_height: 4}", "mesh: {n_length: 12}"))
    s = load_vehicle3d(ok)
    assert s.carbody_model == "shell" and s.shell.params.n_length == 12


def test_rigid_body_mass_of_the_coupled_car(spec, car, shell):
    """Rigid translations: mass = shell + 2 bogies (+ 4 wheelsets in y); no secondary strain."""
    fe = shell.car.asm
    nc = car.carbody.n
    Mr = shell.cb.Mr
    # rigid-body vectors in the car's carbody coordinates: M-projection on the basis
    Rr = np.zeros((Mr.shape[0], 6))
    Rr[: shell.cb.n_boundary] = fe.rigid_body_modes()[shell.cb.boundary_dofs]
    B = shell.basis
    Rq = np.linalg.solve(B.T @ Mr @ B, B.T @ Mr @ Rr)
    m_rb = Rq.T @ car.M[:nc, :nc] @ Rq
    m_full = fe.rigid_body_mass()
    assert np.linalg.norm(m_rb - m_full) / np.linalg.norm(m_full) < 1e-6  # <= 1 % asked
    m_bogie, m_ws = spec.v("bogie", "mass"), spec.v("wheelset", "mass")
    for axis in (0, 1):  # x and y: wheelsets follow in y only (x is held)
        q = np.zeros(car.n_dof)
        q[:nc] = Rq[:, axis]
        for b in (1, 2):
            q[car.dof(f"bogie{b}_{'xy'[axis]}")] = 1.0
        if axis == 1:
            for a in range(1, 5):
                q[car.dof(f"ws{a}_y")] = 1.0
        expect = fe.total_mass() + 2 * m_bogie + (4 * m_ws if axis == 1 else 0.0)
        assert q @ car.M @ q == pytest.approx(expect, rel=1e-6)
        f = car.K @ q  # x: the primary springs hold the bogies (wheelsets' x is held)
        scale = 1e-6 * np.linalg.norm(car.K, 2)
        assert np.linalg.norm(f[:nc]) < scale  # the secondary suspension is not strained
        if axis == 1:
            assert np.linalg.norm(f) < scale
    assert fe.total_mass() == pytest.approx(41.03e3, rel=0.02)  # [002] Sec. 2, in service


def test_free_free_frequencies_match_the_cb_carbody_and_the_full_shell(car, shell):
    cbody = car.carbody
    f_car = np.sqrt(np.clip(sla.eigh(cbody.K, cbody.M, eigvals_only=True), 0, None)) / (
        2 * np.pi)
    f_cb, _, rigid_cb = reduced_modes(shell.car, shell.cb)
    flex_cb = f_cb[~rigid_cb]
    kept = flex_cb[flex_cb < 40.0]
    assert kept.size > 20
    assert np.sum(f_car < 1e-3) == 6  # six rigid modes, stiffness exactly orthogonal
    f_flex = np.sort(f_car[f_car > 1e-3])[: kept.size]
    assert np.max(np.abs(f_flex / kept - 1.0)) < 1e-6  # the kept modes are the CB modes
    full = solve_modes(shell.car.asm.K, shell.car.asm.M, 18).f_hz[6:]
    assert np.max(np.abs(f_flex[:12] / full - 1.0)) < 0.01  # and the full shell's


def test_stiff_suspension_tends_to_the_carbody_supported_at_its_seats(spec, car, shell):
    """Secondary and primary kz -> inf: the carbody's modes -> shell with seats' uz fixed."""
    asm = shell.car.asm
    fixed = [asm.dof_index(n, "uz") for n in shell.car.seats.values()]
    free = np.setdiff1d(np.arange(asm.n_dof), fixed)
    K = sp.csr_array(asm.K)[free][:, free]
    M = sp.csr_array(asm.M)[free][:, free]
    ref = solve_modes(K, M, 10).f_hz
    ref = ref[ref > 5.0][:4]  # the three free rigid motions (x, y, yaw) left out

    def carbody_freqs(kz: float) -> np.ndarray:
        s = spec.with_values(secondary={"kz": kz}, primary={"kz": kz},
                             vertical_damper={"c": 0.0}, yaw_damper={"c": 0.0},
                             lateral_damper={"c": 0.0}, anti_roll_bar={"k_roll": 0.0},
                             traction_rod={"kx": 0.0})
        v = build_vehicle3d(s, car.carbody)
        w2, X = sla.eigh(v.K, v.M)
        nc = v.carbody.n
        share = np.einsum("ij,ik,kj->j", X[:nc], v.M[:nc, :nc], X[:nc])
        f = np.sqrt(np.clip(w2, 0, None)) / (2 * np.pi)
        return f[(share > 0.5) & (f > 5.0)][:4]

    err = {kz: np.max(np.abs(carbody_freqs(kz) / ref - 1.0)) for kz in (1e7, 1e9, 1e11)}
    assert err[1e7] > err[1e9] > err[1e11]
    assert err[1e11] < 0.01


def test_hunting_with_the_flexible_carbody_is_near_the_rigid_one(spec, car, shell):
    """A stated expectation: carbody flexibility (>= 8.5 Hz) moves V_c by a few % at most."""
    rigid = build_vehicle3d(spec, _rigid_twin(spec, shell, car))
    h_flex = critical_speed(car, SPEEDS)
    h_rigid = critical_speed(rigid, SPEEDS)
    assert np.isfinite(h_flex.v_critical) and np.isfinite(h_rigid.v_critical)
    assert h_flex.v_critical == pytest.approx(h_rigid.v_critical, rel=0.04)
    assert h_flex.f_critical_hz == pytest.approx(h_rigid.f_critical_hz, rel=0.04)
    # the time domain agrees: a disturbed wheelset settles at 0.9 Vc and hunts at 1.1 Vc,
    # growing at the unstable eigenvalue's rate
    fs, T = 400.0, 20.0
    s0 = np.zeros(car.n_state)
    s0[car.dof("ws1_y")] = 1e-3
    for frac in (0.9, 1.1):
        V = frac * h_flex.v_critical
        r = car.simulate(np.zeros((24, round(T * fs) + 1)), fs, V, s0=s0, dofs=("ws1_y",))
        y, t = r.dofs[0], r.t
        rms = [np.std(y[(t >= t0) & (t < t0 + 1.0)]) for t0 in (10.0, 18.0)]
        slope = np.log(rms[1] / rms[0]) / 8.0
        if frac < 1:
            assert slope < 0
        else:
            assert slope == pytest.approx(np.max(car.kinematic_modes(V).real), rel=0.05)


def test_model_names_the_coupled_carbody_modes(car):
    modes = carbody_modes(car, 300.0 / 3.6)
    rigid = [m.label for m in modes if m.f_hz < 3.0]
    assert sorted(rigid) == sorted(["sway", "yaw", "bounce", "roll", "pitch", "surge"])
    flex = [m for m in modes if m.f_hz > 5.0]
    assert flex[0].label == "diamond 1" and flex[0].f_hz == pytest.approx(8.5, rel=0.05)
    kinds = {m.label.split(" with ")[0] for m in flex[:8]}
    assert {"vertical bending 1", "lateral bending 1", "diamond 1"} <= kinds


def test_floor_psd_peaks_at_the_first_vertical_bending_over_a_speed_sweep(spec, car, shell):
    """[002] Sec. 5 carbody shaking: the vertical-bending resonance in the mid-floor PSD."""
    rigid = build_vehicle3d(spec, _rigid_twin(spec, shell, car))
    f = np.arange(7.0, 14.0, 0.04)
    names = car.floor_outputs(*car.state_space(80.0))[2]
    i_mid = names.index("floor_mid_z")
    for kmh in (200.0, 250.0, 300.0, 350.0):
        V = kmh / 3.6
        vb = next(m for m in carbody_modes(car, V) if m.label == "vertical bending 1")
        S = floor_psd_theory(car, V, f)[i_mid]
        S_rigid = floor_psd_theory(rigid, V, f)[i_mid]
        near = np.abs(f - vb.f_hz) < 0.6
        k = int(np.argmax(np.where(near, S, 0.0)))
        assert 0 < k < f.size - 1 and S[k] > S[k - 1] and S[k] > S[k + 1]  # a local peak
        assert abs(f[k] - vb.f_hz) < 0.2  # within 2 %: the track spectrum tilts the peak
        assert S[k] > 10.0 * S_rigid[k]  # the rigid carbody has no such resonance
    run = ride_run(car, 300.0, duration_s=60.0, fs_hz=400.0, seed=3)
    vb = next(m for m in run.modes if m.label == "vertical bending 1")
    peaks = run.psd.peaks_hz[run.channels.index("floor_mid_z")]
    assert np.min(np.abs(peaks - vb.f_hz)) < 0.3


def test_ride_and_model_info_take_the_shell_car(spec, car, shell, capsys):
    """``--carbody shell`` (the reduction above is reused: same parameters, same process)."""
    assert main(["ride", "--carbody", "shell", "--speed", "300", "--duration", "10",
                 "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    labels = [m["label"] for m in doc["runs"][0]["carbody_modes"]]
    assert "diamond 1" in labels and "vertical bending 1" in labels and "bounce" in labels
    assert doc["critical_speed_kmh"] == pytest.approx(561.0, rel=0.01)  # as the sweep above
    assert main(["model", "info", spec.source, "--carbody", "shell", "--json",
                 "--show", "9"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["carbody"].startswith("shell") and info["n_carbody_coordinates"] == car.carbody.n
    mass = shell.car.asm.total_mass() + 2 * spec.v("bogie", "mass") + 4 * spec.v("wheelset",
                                                                                "mass")
    assert info["total_mass_kg"] == pytest.approx(mass, rel=1e-9)
    assert [m["label"] for m in info["carbody_modes"]][6:8] == ["diamond 1",
                                                                 "vertical bending 1"]
    assert main(["ride", "--carbody", "shell", "--bending-hz", "8.7"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("modal-twin ride: --bending-hz") and err.count("\n") == 1


def test_cb_coordinates_and_the_modal_basis_give_the_same_car(spec, car, shell):
    """``f_keep_hz=None`` couples the CB coordinates themselves (283): same low modes."""
    pts = {p.label: (p.x, p.y) for p in spec.floor_points}
    full = shell_carbody(shell.car, shell.cb, points=pts, z0=shell.z0, f_keep_hz=None)
    assert full.n == shell.cb.n_boundary + shell.cb.n_modes > 3 * car.carbody.n
    big = build_vehicle3d(spec, full)
    V = 300.0 / 3.6
    a = [m.f_hz for m in carbody_modes(car, V) if m.f_hz < 20.0]
    b = [m.f_hz for m in carbody_modes(big, V) if m.f_hz < 20.0]
    assert len(a) == len(b) and np.max(np.abs(np.array(a) / np.array(b) - 1.0)) < 2e-3
    with pytest.raises(OptionError, match="zeta: expected a finite value in"):
        shell_carbody(shell.car, shell.cb, points=pts, z0=1.0, zeta=-0.1)
    with pytest.raises(OptionError, match="f_keep_hz: expected a finite value > 0"):
        shell_carbody(shell.car, shell.cb, points=pts, z0=1.0, f_keep_hz=0.0)
