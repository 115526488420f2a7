"""``modal-twin view`` of a 3D-car record (issue 23, item 7): the shell car's deflection on
the record's track, in a page whose line sets are drawn once and moved by its script.

Known answers: the page holds ``n_frames`` frames of every node, taken every ``dt_s`` from
``t0_s`` (its frame data says so and its caption agrees); an axle end and a bogie-frame
corner are rigid-body points of their bodies, so at every frame their drawn displacement,
divided by the page's drawing scale, equals ``u + theta x r`` of the body's coordinates at
that time -- taken here from an independent run of the car: the twin's second-order plant
(:class:`~modal_twin.models.vehicle3d_factory.Vehicle3DFactory`, Maxwell dampers as extra
coordinates) in first-order form through ``scipy.signal.lsim`` (zero-order hold), not the
view's own first-order car and propagator.
"""

from __future__ import annotations

import base64
import json
import re
from pathlib import Path

import numpy as np
import pytest
import scipy.signal

from modal_twin.cli import main
from modal_twin.models.loading import load_model
from modal_twin.models.track3d import random_track_3d, track_inputs_3d
from modal_twin.models.vehicle3d_spec import DEFAULT_VEHICLE3D_YAML
from modal_twin.rig.truth import TruthRig
from modal_twin.signal_block import SignalBlock

FS = 200.0
COARSE = "mesh: {n_length: 10, n_width: 2, n_height: 2}"


def _frames(page: str) -> dict:
    m = re.search(r'<script type="application/json" id="modal-twin-frames">(.*?)</script>',
                  page, re.S)
    assert m is not None
    doc = json.loads(m.group(1))
    nf, nn = doc["n_frames"], doc["n_nodes"]
    doc["pos"] = [np.frombuffer(base64.b64decode(c["positions"]), "<f4").reshape(nf, nn, 3)
                  for c in doc["copies"]]
    doc["edges_arr"] = np.frombuffer(base64.b64decode(doc["edges"]), "<i4").reshape(-1, 2)
    return doc


@pytest.fixture(scope="module")
def shell_car(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, np.ndarray]:
    """A coarse shell-carbody car file and a bag of its noise-free record (6 s)."""
    from modal_twin.io.imported import write_imported

    d = tmp_path_factory.mktemp("car3d")
    text = DEFAULT_VEHICLE3D_YAML.read_text()
    text = text.replace("mesh: {n_length: 30, n_width: 4, n_height: 4}", COARSE)
    text = text.replace("  model: rigid ", "  model: shell ")
    car = d / "car3d.yaml"
    car.write_text(text)
    factory = load_model(car)
    plant = factory.plant()
    v, seconds = factory.spec.speed, 6.0
    u = track_inputs_3d(random_track_3d(v * seconds + 60.0, rng=5), factory.spec.axle_x, v,
                        FS, seconds, start_m=30.0)
    rig = TruthRig(plant, 1.0 / FS, seed=1)
    raw = rig.process(SignalBlock(plant.input_names, FS, 0, u, stamp_ns=10**18))
    write_imported(d / "bag", raw, list(rig.channels))
    return car, d / "bag", u


def _independent_q(car: Path, u: np.ndarray) -> np.ndarray:
    """Vehicle coordinates over the record: the twin's plant, first-order, by lsim (ZOH)."""
    sysm = load_model(car).plant().system
    M, C, K, G = sysm.M, sysm.C, sysm.K, sysm.Gamma
    n = M.shape[0]
    Mi = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Mi @ K, -Mi @ C]])
    B = np.vstack([np.zeros((n, G.shape[1])), -Mi @ G])  # M x'' + C x' + K x = -Gamma w
    t = np.arange(u.shape[1]) / FS
    _, _, x = scipy.signal.lsim((A, B, np.eye(2 * n), np.zeros((2 * n, G.shape[1]))),
                                u.T, t, interp=False)
    return np.asarray(x[:, :n].T)


def test_view_of_a_3d_car_record_draws_its_deflection(shell_car, tmp_path: Path) -> None:
    from modal_twin.models.vehicle3d import build_vehicle3d
    from modal_twin.models.vehicle3d_spec import load_vehicle3d

    car, bag, u = shell_car
    page = tmp_path / "record.html"
    assert main(["-q", "view", str(car), "--bag", str(bag), "--window", "2.0",
                 "--html", str(page)]) == 0
    text = page.read_text()
    doc = _frames(text)
    # 2 s at 200 Hz (400 samples) cut for 96 frames: every 400 // 96 = 4th sample, 100
    # frames, played in real time
    assert doc["n_frames"] == 100 and doc["dt_s"] == pytest.approx(4 / FS)
    assert len(doc["pos"]) == 1 and doc["fps"] == pytest.approx(FS / 4)
    assert f"({doc['n_frames']} frames)" in text
    k0 = round(doc["t0_s"] * FS)
    assert k0 >= 0 and k0 + 4 * 99 < u.shape[1]
    veh = build_vehicle3d(load_vehicle3d(car))
    assert doc["n_nodes"] == veh.carbody.source.car.asm.xyz.shape[0] + 2 * 6 + 4 * 2
    q = _independent_q(car, u)
    from modal_twin.viz.vehicle3d_scene import vehicle3d_scene

    geom = vehicle3d_scene(veh).geom
    np.testing.assert_array_equal(doc["edges_arr"], geom.edges)
    rest = geom.node_xyz
    # positions of frame k = rest + scale x displacement (float32)
    disp = (doc["pos"][0] - rest[None].astype(np.float32)) / doc["scale"]  # m
    idx = k0 + 4 * np.arange(100)
    nc = veh.carbody.n
    # the front axle's left end (the second-to-last eight nodes: axle ends, front first)
    n_fe = rest.shape[0] - 20
    left = n_fe + 12 + 1
    assert rest[left, 1] == pytest.approx(0.75) and rest[left, 0] == pytest.approx(
        veh.spec.axle_x[0])
    y1, yaw1 = q[nc + 12, idx], q[nc + 13, idx]
    want = np.c_[-0.75 * yaw1, y1, 0 * y1]  # u + theta x r, r = (0, 0.75, 0)
    peak = np.abs(want).max()
    np.testing.assert_allclose(disp[:, left], want, atol=1e-4 * peak)
    # the front bogie frame's first corner (+a, +b) at its centre height
    corner = n_fe
    r = rest[corner] - [veh.spec.pivot_x[0], 0.0, veh.spec.v("bogie", "cg_height")]
    b = q[nc:nc + 6, idx]  # x, y, z, roll, pitch, yaw of bogie 1
    want_b = b[:3].T + np.cross(b[3:].T, r)
    np.testing.assert_allclose(disp[:, corner], want_b, atol=1e-4 * np.abs(want_b).max())


def test_the_pages_script_moves_the_line_sets(shell_car, tmp_path: Path, chromium) -> None:
    """Two carbody modes of the coarse car: the page draws each moving copy once and its
    script finds both line sets and moves them (the page marks it), without console
    errors."""
    car, _, _ = shell_car
    page = tmp_path / "modes.html"
    assert main(["-q", "view", str(car), "--carbody-mode", "vertical bending 1",
                 "--carbody-mode", "diamond 1", "--html", str(page)]) == 0
    doc = _frames(page.read_text())
    assert len(doc["copies"]) == 2 and doc["n_frames"] == 25 and doc["scale"] is None
    dom, console = chromium(page)
    assert 'data-vertex-copies="2"' in dom
    assert not [c for c in console if "Uncaught" in c]
