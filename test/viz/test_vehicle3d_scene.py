"""The 3D car with the shell carbody as a 3D scene: the mesh, the bodies, a named mode.

Known answers: one scene node per shell FE node plus four frame corners and two air-spring
ends per bogie and two axle ends per wheelset; a rigid translation of the carbody moves
every shell node (slaves of rigid links too) by the same vector; a bogie yaw moves the
frame's corners by ``theta x r``; the coupled car's first vertical bending moves the floor
centre line vertically with two nodes (ends in phase, middle against them), as a free-free
beam's first bending (nodes at 0.224 L from the ends for a uniform beam).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from modal_twin.cli import main
from modal_twin.errors import ModelError, OptionError
from modal_twin.models.carbody_shell import ShellCarbody
from modal_twin.models.vehicle3d import build_vehicle3d
from modal_twin.models.vehicle3d_spec import DEFAULT_VEHICLE3D_YAML, load_vehicle3d
from modal_twin.viz.vehicle3d_scene import FRAME_HALF_WIDTH_M, vehicle3d_scene

COARSE = "mesh: {n_length: 10, n_width: 2, n_height: 2}"


@pytest.fixture(scope="module")
def car():
    spec = load_vehicle3d().with_carbody("shell")
    p = replace(spec.shell.params, n_length=10, n_width=2, n_height=2)
    veh = build_vehicle3d(replace(spec, shell=replace(spec.shell, params=p)))
    return veh, vehicle3d_scene(veh)


def test_scene_nodes_and_lines(car) -> None:
    veh, vs = car
    src = veh.carbody.source
    assert isinstance(src, ShellCarbody)
    n_fe = len(src.car.asm.nodes)
    assert vs.n_shell_nodes == n_fe
    assert vs.geom.node_xyz.shape == (n_fe + 2 * (4 + 2) + 4 * 2, 3)
    np.testing.assert_allclose(vs.geom.node_xyz[:n_fe], src.car.asm.xyz + np.array([0, 0, src.z0]))
    e = vs.geom.edges
    assert e.min() >= 0 and e.max() < vs.geom.node_xyz.shape[0] and np.all(e[:, 0] < e[:, 1])
    ring = src.car.ring
    n_ring_lines = ring.shape[0] * ring.shape[1] + (ring.shape[0] - 1) * ring.shape[1]
    assert e.shape[0] > n_ring_lines  # the ring's sides plus end walls, bolsters, hangers
    lengths = np.linalg.norm(np.diff(vs.geom.node_xyz[e], axis=1)[:, 0], axis=1)
    assert lengths.max() < 4.5  # element sides, hanger frames (4.0 m diagonals): no long line
    wheels = vs.geom.node_xyz[-8:]
    np.testing.assert_allclose(np.sort(np.unique(wheels[:, 0])), np.sort(veh.spec.axle_x))
    assert set(vs.geom.sensors) == {p.label for p in veh.spec.floor_points}


def test_rigid_motions_move_the_nodes_as_rigid_bodies(car) -> None:
    veh, vs = car
    nc, n_fe = veh.carbody.n, vs.n_shell_nodes
    # carbody coordinates of a unit vertical translation (least squares on the shell's uz)
    target = np.zeros((n_fe, 3))
    target[:, 2] = 1.0
    A = vs.move[:n_fe, :, :nc].reshape(3 * n_fe, nc)
    q, *_ = np.linalg.lstsq(A, target.ravel(), rcond=None)
    # within 1e-6 of the unit motion: the carbody's modes come from shift-invert Lanczos,
    # whose rigid-body vectors leave a residual of ~1.6e-8 here (a coordinate set that
    # missed the translation would leave O(1))
    np.testing.assert_allclose(A @ q, target.ravel(), atol=1e-6)
    x = np.zeros(veh.n_dof)
    theta = 1e-3
    x[veh.dof("bogie1_yaw")] = theta
    d = vs.move @ x
    corners = vs.geom.node_xyz[n_fe:n_fe + 4]
    r = corners - [veh.spec.pivot_x[0], 0.0, veh.spec.v("bogie", "cg_height")]
    np.testing.assert_allclose(d[n_fe:n_fe + 4], theta * np.c_[-r[:, 1], r[:, 0], 0 * r[:, 0]],
                               atol=1e-15)
    assert np.allclose(np.abs(r[:, 1]), FRAME_HALF_WIDTH_M)
    assert not d[:n_fe].any() and not d[n_fe + 6:].any()  # only that bogie moves


def test_first_vertical_bending_has_two_nodes(car) -> None:
    veh, vs = car
    m = vs.modes(veh, veh.spec.speed, labels=["vertical bending 1"])
    assert m.shapes.shape == (1, vs.geom.node_xyz.shape[0], 3)
    assert m.labels[0].startswith("vertical bending 1: ") and 8.0 < m.f_hz[0] < 13.0
    src = veh.carbody.source
    ring, yz = src.car.ring, src.car.ring_yz
    k = int(np.argmin(np.hypot(yz[:, 0], yz[:, 1])))  # the floor's centre line
    idx = [int(np.flatnonzero([n == node for n in src.car.asm.nodes])[0]) for node in ring[:, k]]
    x = vs.geom.node_xyz[idx, 0]
    uz, uy = m.shapes[0, idx, 2], m.shapes[0, idx, 1]
    assert np.abs(uy).max() < 0.2 * np.abs(uz).max()  # a vertical mode
    # the rigid part (bounce, pitch) of the coupled mode removed: the bending shape's nodes
    flex = uz - np.polyval(np.polyfit(x, uz, 1), x)
    i = np.flatnonzero(np.diff(np.sign(flex)) != 0)
    assert i.size == 2
    xc = x[i] - flex[i] * (x[i + 1] - x[i]) / (flex[i + 1] - flex[i])  # linear in between
    # measured 0.190 and 0.774 on this mesh (a uniform beam: 0.224, 0.776)
    np.testing.assert_allclose((xc - x.min()) / (x.max() - x.min()), [0.224, 0.776],
                               atol=0.06)
    assert np.sign(flex[0]) == np.sign(flex[-1]) != np.sign(flex[len(flex) // 2])
    with pytest.raises(OptionError, match="carbody mode 'wobble': expected one of"):
        vs.modes(veh, veh.spec.speed, labels=["wobble"])
    default = vs.modes(veh, veh.spec.speed, n_modes=3)
    assert default.shapes.shape[0] == 3 and np.all(np.diff(default.f_hz) >= 0)


def test_rigid_carbody_has_no_mesh_to_draw() -> None:
    with pytest.raises(ModelError, match="expected the shell carbody"):
        vehicle3d_scene(build_vehicle3d(load_vehicle3d()))


def test_view_of_the_3d_car(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    text = DEFAULT_VEHICLE3D_YAML.read_text()
    vfile = tmp_path / "car3d.yaml"
    vfile.write_text(text.replace("mesh: {n_length: 30, n_width: 4, n_height: 4}", COARSE))
    page = tmp_path / "car.html"
    assert main(["-q", "view", str(vfile), "--carbody-mode", "vertical bending 1",
                 "--carbody-mode", "diamond 1", "--html", str(page)]) == 0
    html = page.read_text()
    assert "vertical bending 1: " in html and "diamond 1: " in html
    assert main(["view", str(vfile), "--carbody-mode", "wobble", "--html",
                 str(tmp_path / "x.html")]) == 2
    err = capsys.readouterr().err
    assert "carbody mode 'wobble'" in err and err.count("\n") == 1
    assert main(["view", str(vfile), "--modes", str(vfile), "--html",
                 str(tmp_path / "y.html")]) == 2
    assert "a 3D vehicle shows its carbody modes" in capsys.readouterr().err
    # a record's deflection (test_vehicle3d_record_view.py) needs a bag: one line otherwise
    assert main(["view", str(vfile), "--bag", str(vfile), "--html",
                 str(tmp_path / "y.html")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "a rosbag2 bag is a folder" in err


def test_a_box_on_elastic_hangers_moves_with_its_own_coordinates() -> None:
    """EQ1 on elastic hangers (six coordinates of its own, out of the shell): the file's
    inertia is that of a uniform 2.0 x 1.6 x 0.8 m box of 3 t, so those are the drawn
    sides; on the car run over a random track, the mean of the box's eight corners moves
    as the box's translation coordinates, each corner as ``u + theta x r``, and each drawn
    vertical hanger's stroke (carbody point minus the box's point under it) is the model's
    own hanger elongation ``g' q``."""
    from modal_twin.models.track3d import random_track_3d, track_inputs_3d
    from modal_twin.models.vehicle3d import box_centre, suspension_elements
    from modal_twin.viz.vehicle3d_scene import box_half_sizes, record_deflection

    spec = load_vehicle3d().with_carbody("shell").with_equipment("EQ1", hanger="elastic")
    p = replace(spec.shell.params, n_length=10, n_width=2, n_height=2)
    veh = build_vehicle3d(replace(spec, shell=replace(spec.shell, params=p)))
    vs = vehicle3d_scene(veh)
    box = veh.spec.hung_equipment[0]
    np.testing.assert_allclose(2 * box_half_sizes(box), [2.0, 1.6, 0.8], rtol=1e-12)
    n0 = vs.n_shell_nodes + 2 * (4 + 2) + 4 * 2  # shell, bogies, wheelsets, then the box
    assert vs.geom.node_xyz.shape[0] == n0 + 8 + 4 * 2
    corners = vs.geom.node_xyz[n0:n0 + 8]
    E = box_centre(veh.spec, box)
    np.testing.assert_allclose(corners.mean(axis=0), E, atol=1e-12)
    edges = {tuple(e) for e in vs.geom.edges.tolist()}
    assert sum((a, b) in edges for a in range(n0, n0 + 8) for b in range(a + 1, n0 + 8)) == 12
    fs, v = 200.0, veh.spec.speed
    w = track_inputs_3d(random_track_3d(v * 3.0 + 60.0, rng=3), veh.spec.axle_x, v, fs, 3.0)
    rd = record_deflection(vs, veh, w, fs, window_s=1.0, n_frames=20)
    q = veh.simulate(w, fs, v, dofs=veh.dof_names).dofs
    k = np.round((rd.t0_s + rd.dt_s * np.arange(rd.frames.shape[0])) * fs).astype(int)
    col = veh.dof("EQ1_x")
    u, theta = q[col:col + 3, k].T, q[col + 3:col + 6, k].T  # (frames, 3)
    assert np.abs(u).max() > 1e-5  # the box moves (m)
    drawn = rd.frames[:, n0:n0 + 8]  # (frames, 8, 3)
    np.testing.assert_allclose(drawn.mean(axis=1), u, rtol=1e-9, atol=1e-12)
    for c in range(8):
        r = corners[c] - E
        np.testing.assert_allclose(drawn[:, c], u + np.cross(theta, r), rtol=1e-9, atol=1e-12)
    g = {e.name: e.g for e in suspension_elements(veh.spec, veh.carbody)}
    for j in range(4):
        bracket, point = n0 + 8 + 2 * j, n0 + 9 + 2 * j
        stroke = rd.frames[:, point, 2] - rd.frames[:, bracket, 2]
        model = g[f"EQ1_hanger{j + 1}_z"] @ q[:, k]
        assert np.abs(model).max() > 1e-6
        np.testing.assert_allclose(stroke, model, rtol=1e-7, atol=1e-12)
