"""The trailer car as a 3D scene: wireframe, and the map from its coordinates to heights."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from modal_twin.cli import main
from modal_twin.models.loading import load_model
from modal_twin.models.vehicle import assemble_vehicle
from modal_twin.models.vehicle_spec import load_vehicle
from modal_twin.viz.vehicle_scene import AXLE_M, vehicle_scene

ROOT = Path(__file__).resolve().parents[2]
CAR = ROOT / "config" / "vehicles" / "trailer_car.yaml"


@pytest.fixture(scope="module")
def car() -> tuple[object, object]:
    vm = assemble_vehicle(load_vehicle(CAR))
    return vm, vehicle_scene(vm)


def test_wireframe_of_the_car(car: tuple) -> None:
    vm, vs = car
    n_nodes = len(vm.carbody.node_x)
    n_eq = len(vm.spec.equipment)
    assert vs.geom.node_xyz.shape == (2 * n_nodes + 2 * (3 + 2) + n_eq, 3)
    assert np.all(vs.geom.node_xyz[:, 0] == 0.0)  # the vertical plane, seen from the side
    wheels = np.flatnonzero(np.isclose(vs.geom.node_xyz[:, 2], AXLE_M))
    assert len(wheels) == 4
    y = np.sort(vs.geom.node_xyz[wheels, 1])
    pf, pr = vm.spec.pivot_x
    a = 0.5 * vm.spec.wheelbase
    np.testing.assert_allclose(y, np.sort([pf - a, pf + a, pr - a, pr + a]))
    plant_places = {c.location for c in load_model(CAR).plant().channels}
    assert set(vs.geom.sensors) <= plant_places  # the plant's floor sensors, by place
    assert {"secondary_front", "secondary_rear", *(e.name for e in vm.spec.equipment)} <= \
        set(vs.geom.devices)


def test_lift_map_closed_forms(car: tuple) -> None:
    vm, vs = car
    dz = vs.lift @ vm.rigid_lift()  # every wheelset lifted 1 m: the whole car rises 1 m
    z = vs.geom.node_xyz[:, 2]
    np.testing.assert_allclose(dz[~np.isclose(z, AXLE_M)], 1.0, atol=1e-9)
    np.testing.assert_allclose(dz[np.isclose(z, AXLE_M)], 0.0)  # the wheels follow the track
    n_cb = vm.carbody.cb.T.shape[1]
    pitch = np.zeros(vm.M.shape[0])
    pitch[n_cb + 1] = 1.0  # front bogie pitch of 1 rad: its frame ends move +-a
    moved = vs.lift @ pitch
    a = 0.5 * vm.spec.wheelbase
    assert sorted(np.round(moved[np.abs(moved) > 0], 12)) == [-a, a]
    modes = vs.modes(vm, 6)
    assert modes.shapes.shape == (6, vs.geom.node_xyz.shape[0], 3)
    np.testing.assert_allclose(modes.f_hz, vm.f_hz[:6])
    assert np.all(modes.shapes[:, :, :2] == 0.0) and np.all(modes.zeta > 0)


def test_view_of_the_vehicle(tmp_path: Path, capsys: pytest.CaptureFixture, chromium) -> None:
    page = tmp_path / "car.html"
    assert main(["-q", "view", str(CAR), "--html", str(page)]) == 0
    assert "trailer_car" in page.read_text()
    dom, console = chromium(page)
    assert "data-scene-commands" in dom
    assert not [c for c in console if "Uncaught" in c or "rror" in c]
    assert main(["view", str(CAR), "--modes", str(page)]) == 2
    assert "a vehicle shows its model modes" in capsys.readouterr().err


def _car_bag(out: Path, effects: list) -> Path:
    from modal_twin.io.imported import write_imported
    from modal_twin.models.sensors import table_channels
    from modal_twin.models.track import random_profile, wheelset_inputs
    from modal_twin.rig.truth import TruthRig
    from modal_twin.signal_block import SignalBlock

    factory = load_model(CAR)
    fs, seconds, v = 200.0, 12.0, 300.0 / 3.6
    u = wheelset_inputs(random_profile(v * seconds + 40.0, rng=4), factory.spec.axle_x, v, fs,
                        seconds)
    plant = factory.plant(effects)
    blk = TruthRig(plant, 1 / fs).process(SignalBlock(plant.input_names, fs, 0, u))
    return write_imported(out, blk, [*table_channels(plant), *plant.channels])


def test_view_bag_of_the_vehicle(tmp_path: Path) -> None:
    """Known answers: the nominal car beside its own response agrees everywhere; with the
    underframe box EQ1 on elastic mounts (the S2 truth) the rigid twin fails most where the
    box hangs (the accelerations there, in the carbody-bending band)."""
    from modal_twin.models.effects import EffectSpec

    nominal = _car_bag(tmp_path / "nominal", [])
    page = tmp_path / "nominal.html"
    assert main(["-q", "view", str(CAR), "--bag", str(nominal), "--html", str(page)]) == 0
    text = page.read_text()
    worst = float(text.split("worst: ")[1].split("</div>")[0].split(",")[0].split()[-2])
    assert worst < 1e-3
    mount = _car_bag(tmp_path / "mount", [EffectSpec("EQ1", "elastic_mount",
                                                     {"f_hz": 10.0, "zeta": 0.05})])
    page = tmp_path / "mount.html"
    assert main(["-q", "view", str(CAR), "--bag", str(mount), "--html", str(page)]) == 0
    first = page.read_text().split("worst: ")[1].split("</div>")[0].split(",")[0].split()
    assert first[0] in ("floor_eq1", "floor_mid") and float(first[-2]) > 30.0  # EQ1 hangs there
