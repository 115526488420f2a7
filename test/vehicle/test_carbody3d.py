"""3D shell carbody ([002] Sec. 2): masses, rigid modes, mode names, [002]'s modes, CB."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from modal_twin.errors import ConfigError, ModelError
from modal_twin.models.carbody3d import CarbodyParams, build_carbody, default_zones
from modal_twin.models.carbody3d_file import load_carbody3d
from modal_twin.models.carbody_modes import name_modes, rigid_mode_mask
from modal_twin.models.carbody_reduction import reduce_carbody, reduced_modes
from modal_twin.models.craig_bampton import cb_check
from modal_twin.models.fe import solve_modes

P = CarbodyParams()


def _zone_areas(p: CarbodyParams) -> dict[str, float]:
    """Zone areas by hand from the drawing's dimensions (doors cut through the belt)."""
    L, W, H = p.length, p.width, p.height
    door = 4 * p.door_width * p.door_height
    belt = 2 * (L - 2 * p.door_width) * (p.belt[1] - p.belt[0])
    return {"underframe": L * W, "roof": L * W, "end_wall": 2 * W * H, "door": door,
            "window_belt": belt, "side_wall": 2 * L * H - door - belt}


@pytest.fixture(scope="module")
def empty():
    car = build_carbody(P.empty())
    return car, solve_modes(car.asm.K, car.asm.M, 14)


@pytest.fixture(scope="module")
def service():
    car = build_carbody(P)
    return car, solve_modes(car.asm.K, car.asm.M, 24)


def test_masses_match_the_zones_fittings_and_equipment(empty, service):
    areas = _zone_areas(P)
    shell = sum(z.rho * z.t * areas[n] for n, z in P.zones.items())
    assert empty[0].asm.total_mass() == pytest.approx(shell, rel=1e-9)
    fittings = sum(z.nsm * areas[n] for n, z in P.zones.items())
    equipment = sum(e.mass for e in P.equipment)
    car = service[0]
    assert car.asm.total_mass() == pytest.approx(shell + fittings + equipment, rel=1e-9)
    assert car.asm.total_mass() == pytest.approx(41.03e3, rel=0.02)  # [002] Sec. 2, no load
    # the car is symmetric about y = 0: no mass moment about x from y
    rbm = car.asm.rigid_body_mass()
    assert abs(rbm[2, 3]) < 1e-9 * rbm[0, 0]  # m * y_c = 0


def test_interface_nodes_sit_at_the_pivots_seats_and_hangers(service):
    car = service[0]
    xyz = {n: car.asm.xyz[i] for i, n in enumerate(car.asm.nodes)}
    for end, sx in (("front", 1.0), ("rear", -1.0)):
        assert xyz[car.pivots[end]] == pytest.approx([sx * 8.9, 0.0, 0.0], abs=1e-9)
        for side, sy in (("left", 1.0), ("right", -1.0)):
            seat = xyz[car.seats[f"{end}_{side}"]]
            assert seat == pytest.approx([sx * 8.9, sy * P.seat_half_spacing, 0.0], abs=1e-9)
    for e in P.equipment:
        pts = np.array([xyz[n] for n in car.hangers[e.name]])
        assert sorted(pts[:, 0]) == pytest.approx(
            [e.x - e.half_length] * 2 + [e.x + e.half_length] * 2, abs=1e-9)
    assert car.interface_dofs().size == 6 * len(car.interface_nodes())


def test_carbody_without_equipment_bodies_keeps_the_hanger_nodes(service):
    car = build_carbody(replace(P, equipment_bodies=False))
    full = service[0]
    assert car.hangers == full.hangers and not car.equipment_nodes
    eq = sum(e.mass for e in P.equipment)
    assert car.asm.total_mass() == pytest.approx(full.asm.total_mass() - eq, rel=1e-9)
    assert car.interface_nodes() == full.interface_nodes()


def test_free_free_rigid_modes_found_by_projection(empty, service):
    for car, sol in (empty, service):
        rigid = rigid_mode_mask(car, sol.Phi)
        assert rigid[:6].all() and not rigid[6:].any()
        assert sol.f_hz[:6].max() < 1e-2 and sol.f_hz[6] > 5.0


def _shape(car, fn) -> np.ndarray:
    """Free-DOF vector of a field (ux, uy, uz) = fn(x, y', z') on every node."""
    asm = car.asm
    yz0 = car.ring_yz.mean(axis=0)
    full = np.zeros(6 * len(asm.nodes))
    for i, (x, y, z) in enumerate(asm.xyz):
        full[6 * i:6 * i + 3] = fn(x, y - yz0[0], z - yz0[1])
    assert asm.n_dof == full.size  # the empty shell has no constraints: free = full
    return full


def test_mode_names_of_known_shapes(empty):
    car = empty[0]
    L = P.length
    shapes = {
        "vertical bending 1": lambda x, y, z: (0.0, 0.0, np.cos(2 * np.pi * x / L)),
        "lateral bending 2": lambda x, y, z: (0.0, np.sin(3 * np.pi * x / L), 0.0),
        "torsion 1": lambda x, y, z: (0.0, -z * np.sin(np.pi * x / L),
                                      y * np.sin(np.pi * x / L)),
        "diamond 1": lambda x, y, z: (0.0, z * np.cos(np.pi * x / L),
                                      y * np.cos(np.pi * x / L)),
        "breathing 1": lambda x, y, z: (0.0, y * np.cos(np.pi * x / L),
                                        -z * np.cos(np.pi * x / L)),
        "rigid": lambda x, y, z: (0.0, 1.0, 0.0),
    }
    Phi = np.column_stack([_shape(car, f) for f in shapes.values()])
    got = [m.label for m in name_modes(car, np.arange(1.0, 7.0), Phi)]
    assert got == list(shapes)


def test_modes_like_002(empty, service):
    """Tuned defaults (module docstring): not a prediction, a calibration kept in place."""
    e_modes = [m for m in name_modes(empty[0], empty[1].f_hz, empty[1].Phi) if m.kind != "rigid"]
    assert e_modes[0].kind == "diamond"
    assert e_modes[0].f_hz == pytest.approx(13.03, rel=0.05)  # [002] Sec. 2: empty shell
    s_modes = [m for m in name_modes(service[0], service[1].f_hz, service[1].Phi)
               if m.kind != "rigid"]
    assert s_modes[0].kind == "diamond"  # [002] Fig. 8: mode 1 is the diamond
    assert s_modes[0].f_hz == pytest.approx(8.73, rel=0.05)  # [002] Sec. 2: in service
    kinds = {m.kind for m in s_modes[:6]}
    assert {"diamond", "vertical bending", "lateral bending", "torsion"} <= kinds


def test_craig_bampton_keeps_rigid_mass_and_frequencies():
    car = build_carbody(replace(P, n_length=16))
    f_cut = 60.0  # measured: the worst mode below 30 Hz (diamond 2) is off by 0.97 %
    cb = reduce_carbody(car, f_cut_hz=f_cut)
    assert cb.n_boundary == 6 * len(car.interface_nodes())
    chk = cb_check(cb, car.asm.M, car.asm.K, rb=car.asm.rigid_body_modes(),
                   f_compare_hz=f_cut / 2)
    assert chk.rb_mass_rel_err < 1e-9
    assert chk.kbq_rel < 1e-9
    assert chk.f_full_hz.size > 20
    assert chk.max_f_rel_err <= 0.01
    f, _, rigid = reduced_modes(car, cb)
    assert rigid.sum() == 6 and rigid[:6].all()
    assert f[6] == pytest.approx(chk.f_full_hz[6], rel=0.01)


def test_bad_parameters_are_refused():
    with pytest.raises(ModelError, match="pivot_spacing"):
        build_carbody(replace(P, pivot_spacing=30.0))
    zones = default_zones()
    del zones["door"]
    with pytest.raises(ModelError, match="zones"):
        build_carbody(replace(P, zones=zones))
    with pytest.raises(ModelError, match="n_width"):
        build_carbody(replace(P, n_width=1))


ROOT = Path(__file__).resolve().parents[2]


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "modal_twin.cli", *args], capture_output=True,
                          text=True, timeout=300, cwd=ROOT)


def test_model_info_names_the_empty_shells_modes() -> None:
    out = _cli("model", "info", "config/carbodies/trailer_car_shell_empty.yaml", "--json",
               "--show", "4")
    assert out.returncode == 0, out.stderr
    d = json.loads(out.stdout)
    assert d["n_rigid"] == 6 and not d["in_service"]
    assert [m["kind"] for m in d["modes"]] == ["diamond", "vertical bending", "torsion",
                                               "lateral bending"]
    assert d["modes"][0]["f_hz"] == pytest.approx(13.03, rel=0.05)


def test_carbody_file_overrides_and_bad_files(tmp_path: Path) -> None:
    good = tmp_path / "car.yaml"
    good.write_text("carbody3d:\n  in_service: false\n  mesh: {n_length: 12}\n"
                    "  zones: {roof: {E: 6.0e10, t: 0.01}}\n")
    name, p, n_modes = load_carbody3d(good)
    assert name == "car" and not p.in_service and p.n_length == 12 and n_modes == 30
    assert (p.zones["roof"].E, p.zones["roof"].t) == (6.0e10, 0.01)
    assert p.zones["underframe"] == P.zones["underframe"]
    for text, match in (("carbody3d: {zones: {attic: {E: 1}}}", "unknown keys"),
                        ("carbody3d: {zones: {roof: {E: fast}}}", "zones.roof.E"),
                        ("carbody3d: {mesh: {n_width: 1}}", "mesh.n_width"),
                        ("carbody3d: {in_service: 2}", "in_service")):
        good.write_text(text)
        with pytest.raises(ConfigError, match=match):
            load_carbody3d(good)
    out = _cli("model", "info", str(good))
    assert out.returncode == 2
    assert "Traceback" not in out.stderr and "in_service" in out.stderr
    good.write_text("carbody3d: {zones: {roof: {t: -1.0}}}")
    out = _cli("model", "info", str(good))
    assert out.returncode == 2 and "Traceback" not in out.stderr
    assert "thicknesses > 0" in out.stderr
