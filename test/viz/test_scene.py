"""meshcat scene: geometry from the building file, segment poses, static HTML rendered."""

from __future__ import annotations

import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from modal_twin.errors import LaunchError, ShapeError
from modal_twin.viz import scene as sc

ROOT = Path(__file__).resolve().parents[2]
BUILDING = ROOT / "config" / "structures" / "building.yaml"


def _rotate(q: list[float], v: np.ndarray) -> np.ndarray:
    x, y, z, w = q
    u = np.array([x, y, z])
    return v + 2.0 * np.cross(u, np.cross(u, v) + w * v)


@pytest.mark.parametrize("d", [[1, 0, 0], [-1, 0, 0], [0, 0, 1], [0.3, -0.4, 0.866]])
def test_segment_pose_maps_unit_segment_onto_the_element(d: list[float]) -> None:
    p1 = np.array([1.0, 2.0, 3.0])
    p2 = p1 + 2.5 * np.asarray(d) / np.linalg.norm(d)
    pos, quat, scale = sc._segment_pose(p1, p2)
    end = np.asarray(pos) + _rotate(quat, np.array([scale[0], 0.0, 0.0]))
    assert end == pytest.approx(p2, abs=1e-12)
    assert np.linalg.norm(quat) == pytest.approx(1.0)


@pytest.fixture(scope="module")
def building() -> tuple[sc.StructureGeometry, sc.SceneModes]:
    return sc.building_geometry(BUILDING), sc.building_modes(BUILDING, 3)


def test_building_geometry(building: tuple[sc.StructureGeometry, sc.SceneModes]) -> None:
    geom, modes = building
    assert geom.node_xyz.shape == (65, 3)
    assert len(geom.sensors) == 14 and set(geom.devices) == {"RB1", "RB2", "ESB1", "ESB2",
                                                              "SDP1", "SDP2"}
    lengths = np.linalg.norm(np.diff(geom.node_xyz[geom.edges], axis=1)[:, 0], axis=1)
    assert geom.edges.shape[0] > 60 and np.all(lengths > 0)
    assert modes.shapes.shape == (3, 65, 3)
    assert modes.f_hz == pytest.approx(np.sort(modes.f_hz)) and modes.f_hz[0] > 0.3
    # first mode of the base-isolated building: every node moves (isolation mode, with
    # some lateral-torsional coupling), none stands still
    horiz = np.linalg.norm(modes.shapes[0][:, :2], axis=1)
    assert horiz.min() > 0.4 * horiz.max()


def test_commands_and_bad_shapes(building: tuple[sc.StructureGeometry, sc.SceneModes]
                                 ) -> None:
    geom, modes = building
    cmds = sc.scene_commands(geom, modes, blamed={"ESB1": "friction"}, n_frames=8)
    lowered = [c.lower() for c in cmds]
    anim = lowered[-1]
    assert anim["type"] == "set_animation"
    assert len(anim["animations"]) == 3 * geom.edges.shape[0]
    keys = anim["animations"][0]["clip"]["tracks"][0]["keys"]
    assert len(keys) == 9  # frames 0..8: one closed period
    paths = {c["path"] for c in lowered}
    assert "/modal_twin/structure/blamed/ESB1" in paths
    assert "/modal_twin/structure/devices/ESB1" not in paths
    bad = sc.SceneModes(modes.f_hz, modes.zeta, modes.shapes[:, :10])
    with pytest.raises(ShapeError, match=r"modes.shapes: expected \(3, 65, 3\)"):
        sc.scene_commands(geom, bad)


def test_static_html_renders_the_structure(building: tuple[sc.StructureGeometry,
                                                           sc.SceneModes],
                                           tmp_path: Path, chromium) -> None:
    from matplotlib.image import imread

    geom, modes = building
    cmds = sc.scene_commands(geom, modes, blamed={"ESB1": "friction"})
    page = tmp_path / "scene.html"
    page.write_text(sc.static_html(cmds, caption=sc.overlay_html(geom, modes)))
    dom, console = chromium(page)
    assert f'data-scene-commands="{len(cmds)}"' in dom
    assert not [c for c in console if "Uncaught" in c or "rror" in c]
    shot = tmp_path / "scene.png"
    chromium(page, screenshot=shot)
    img = imread(shot)[..., :3]
    # dark grey wireframe of the structure and orange mode copies on the blue background
    grey = (np.ptp(img, axis=-1) < 0.08) & (img.max(axis=-1) < 0.45)
    orange = (img[..., 0] > 0.75) & (img[..., 1] < 0.55) & (img[..., 2] < 0.45)
    assert grey.sum() > 200 and orange.sum() > 200


def test_scene_needs_no_ngrok() -> None:
    code = ("import sys; from modal_twin.viz import scene as sc; "
            f"g = sc.building_geometry({str(BUILDING)!r}); "
            "sc.static_html(sc.scene_commands(g)); print('pyngrok' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "False"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_server_local_by_pid_and_port_in_use(tmp_path: Path) -> None:
    import meshcat.commands as mc
    import meshcat.geometry as mg

    from modal_twin.viz.meshcat_server import MeshcatServer, get_scene_html, send_commands

    pid_file = tmp_path / "meshcat.pid"
    web, zmq_port = _free_port(), _free_port()
    with MeshcatServer(zmq_port=zmq_port, web_port=web, pid_file=pid_file,
                       timeout_s=120.0) as srv:
        pid = srv.proc.pid
        assert pid_file.read_text().strip() == str(pid)
        listening = Path("/proc/net/tcp").read_text()
        assert f"0100007F:{web:04X}" in listening  # 127.0.0.1, not 0.0.0.0
        assert f"00000000:{web:04X}" not in listening
        send_commands(srv.zmq_url, [mc.SetObject(mg.Box([1, 1, 1]),
                                                 path=mc.Path(("modal_twin", "box")))])
        assert "handle_command_bytearray" in get_scene_html(srv.zmq_url)
        with pytest.raises(LaunchError, match=f"port {web} on 127.0.0.1 is in use"):
            MeshcatServer(zmq_port=_free_port(), web_port=web, pid_file=tmp_path / "other.pid",
                          timeout_s=120.0).start()
    assert not pid_file.exists()
    assert not Path(f"/proc/{pid}").exists() or "zombie" in Path(
        f"/proc/{pid}/status").read_text()


def test_mode_copies_are_labelled(building: tuple[sc.StructureGeometry, sc.SceneModes]
                                  ) -> None:
    """Each animated copy carries a text label with its number, f and zeta, above it."""
    geom, modes = building
    lowered = [c.lower() for c in sc.scene_commands(geom, modes, n_frames=4)]
    labels = {c["path"]: c for c in lowered if c["path"].endswith("/label")
              and c["type"] == "set_object"}
    assert sorted(labels) == [f"/modal_twin/mode_{k}/label" for k in (1, 2, 3)]
    for k in range(3):
        obj = labels[f"/modal_twin/mode_{k + 1}/label"]["object"]
        (tex,) = obj["textures"]
        assert tex["type"] == "_text"
        assert tex["text"] == (f"mode {k + 1}: {modes.f_hz[k]:.3g} Hz, \u03b6 "
                               f"{100 * modes.zeta[k]:.2g} %")
        assert obj["materials"][0]["map"] == tex["uuid"]
    moves = [c for c in lowered if c["path"] == "/modal_twin/mode_1/label"
             and c["type"] == "set_transform"]
    z_label = np.asarray(moves[0]["matrix"]).reshape(4, 4, order="F")[2, 3]
    assert z_label > geom.node_xyz[:, 2].max()  # above the copy
    # a motion (a record beside the twins) has no modes to label
    motion = sc.SceneMotion(np.zeros((2, 3, *geom.node_xyz.shape)), 24.0, (0xFF0000, 0x00FF00))
    assert not [c for c in sc.scene_commands(geom, motion=motion)
                if c.lower()["path"].endswith("/label")]
