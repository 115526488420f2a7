"""The 3D car through the node graph (issue 23, item 7): launched, recorded, replayed.

Both carbodies: the rigid one (``vehicle3d_ride.yaml``) and the Craig-Bampton shell
(``vehicle3d_shell_ride.yaml``, ``carbody.model: shell``; the rig and twin nodes build the
reduction while they start, before they say ready).

Known answer: the rig (``config/rigs/vehicle3d_nominal.yaml``, ``vehicle3d_shell_nominal``)
is the twin's own car with sensor noise of known RMS on the floor accelerations (0.005
m/s^2) and the suspension forces (50 N) and none on the track inputs and the strokes. The
twin of the same file leaves exactly that noise: per channel, residual RMS = NRMSE x
RMS(measured) equals the noise RMS (within the sampling spread of an RMS over ~1600
samples, 1 / sqrt(2 n) ~ 2 %), and a stroke's residual is zero to round-off. Replayed into
a twin node (``residual --live``), the figures are the offline ones to round-off (as the
building's, README "replay").
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

pytestmark = [pytest.mark.ros, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[2]
CARS = {"vehicle3d_ride": ROOT / "config" / "vehicles" / "trailer_car_3d.yaml",
        "vehicle3d_shell_ride": ROOT / "config" / "vehicles" / "trailer_car_3d_shell.yaml"}
NOISE = {"acceleration": 0.005, "force": 50.0}
LIVE_TOLERANCE_PP = 1e-9  # as test/diagnosis/test_imported_records.py


@pytest.fixture(scope="module", params=sorted(CARS))
def run_bag(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
            ) -> tuple[Path, Path]:
    """A shipped 3D-car scenario, 8 s of track at 200 Hz, launched and recorded; its car.

    The rig and twin nodes compile their kernels before they say ready, and the launcher
    starts the track only then (test_launch_cold_start.py), so a fresh checkout records
    the whole run too.
    """
    from modal_twin.launch import Launcher
    from modal_twin.scenario import load_scenario, with_parameters

    mp = pytest.MonkeyPatch()
    mp.delenv("ROS_DOMAIN_ID", raising=False)  # the launcher reserves its own
    try:
        sc = load_scenario(ROOT / "config" / "scenarios" / f"{request.param}.yaml")
        sc = with_parameters(replace(sc, duration_s=16.0), "excitation", duration_s=8.0)
        res = Launcher(sc, run_dir=tmp_path_factory.mktemp("v3d") / "run",
                       say=lambda s: None).run()
    finally:
        mp.undo()
    assert res.exit_code == 0, res.message
    assert res.bag is not None
    return res.bag, CARS[request.param]


def test_the_launched_3d_car_is_recorded_whole_and_its_twin_sees_only_the_noise(
        run_bag: tuple[Path, Path]) -> None:
    from modal_twin.demo import last_metrics
    from modal_twin.io.bag import read_blocks

    run_bag, _ = run_bag
    frames = read_blocks(run_bag, "/measurement/frames")
    assert sum(b.n_samples for b in frames) == 1601  # 8 s at 200 Hz, nothing lost
    names = frames[0].channel_names
    assert {"table_yat1", "table_dphit4", "floor_mid_y", "yaw_damper_1L_fx"} <= set(names)
    m = last_metrics(run_bag)  # the twin node running beside the rig, live
    assert m is not None and m.samples == 1601
    res = dict(zip(m.channel_names, np.asarray(m.residual_rms) / 100.0
                   * np.asarray(m.rms_measured), strict=True))
    for ch in ("floor_front_y", "floor_mid_z", "floor_rear_z"):
        assert res[ch] == pytest.approx(NOISE["acceleration"], rel=0.06)
    assert res["yaw_damper_1L_fx"] == pytest.approx(NOISE["force"], rel=0.06)


def test_the_replayed_3d_car_run_live_equals_offline_at_the_noise_floor(
        run_bag: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture,
        domain_id: int) -> None:
    from modal_twin.cli import main
    from modal_twin.io.bag import read_blocks
    from modal_twin.signal_block import concatenate_blocks

    run_bag, car = run_bag
    offline_json, live_json = tmp_path / "offline.json", tmp_path / "live.json"
    assert main(["residual", str(car), str(run_bag), "--json", str(offline_json)]) == 0
    out = capsys.readouterr().out
    offline = json.loads(offline_json.read_text())
    whole = concatenate_blocks(read_blocks(run_bag, "/measurement/frames"))
    rms = {c: float(np.sqrt(np.mean(whole.select([c]).data[0] ** 2))) for c in offline}
    accel = [c for c in offline if c.startswith("floor_")]
    forces = [c for c in offline if c.endswith(("_fx", "_fy", "_fz"))]
    strokes = [c for c in offline if c.endswith(("_dx", "_dy", "_dz"))]
    assert len(accel) == 6 and len(forces) == len(strokes) > 20
    # NRMSE x RMS(measured) = the residual's RMS = the noise's, channel by channel
    got = np.array([offline[c]["nrmse"] * rms[c] / NOISE["acceleration"] for c in accel])
    assert np.all(np.abs(got - 1.0) < 0.06), dict(zip(accel, got, strict=True))
    got_f = np.array([offline[c]["nrmse"] * rms[c] / NOISE["force"] for c in forces])
    assert np.median(np.abs(got_f - 1.0)) < 0.03 and np.all(np.abs(got_f - 1.0) < 0.08)
    assert max(offline[c]["nrmse"] for c in strokes) < 1e-9  # no noise there: no residual
    assert f"{car.stem}@nominal" in out
    assert main(["residual", str(car), str(run_bag), "--live", "--rate", "20",
                 "--run-dir", str(tmp_path / "live"), "--json", str(live_json)]) == 0
    out = capsys.readouterr().out
    assert "1601 of the record's 1601 samples (0..1600) compared -- the whole record" in out
    live = json.loads(live_json.read_text())
    assert set(live) == set(offline)
    worst = max(100 * abs(live[c][k] - offline[c][k]) for c in offline for k in ("nrmse", "eq8"))
    assert worst <= LIVE_TOLERANCE_PP
