"""``modal-twin report`` of a launched 3D-car run (issue 23, item 7): the car's modes, the
ride indices and floor PSDs, or one line naming what is missing (exit 2).

The run folder is laid out as ``modal-twin launch`` writes it (``bag/``, ``params/twin.yaml``
naming the car) around a record of the 3D car made offline with no noise, so the model run
on the record's inputs is the record itself: Wz / Wy of model and record agree to the digit
and the floor-PSD error is zero; the modes are those ``model info`` lists.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from modal_twin.cli import main
from modal_twin.models.loading import load_model
from modal_twin.models.ride import sperling_index
from modal_twin.models.track3d import random_track_3d, track_inputs_3d
from modal_twin.rig.truth import TruthRig
from modal_twin.signal_block import SignalBlock

ROOT = Path(__file__).resolve().parents[2]
CAR3D = ROOT / "config" / "vehicles" / "trailer_car_3d.yaml"
FS = 200.0


def _run_folder(folder: Path, model_file: str, seconds: float = 12.0) -> SignalBlock:
    """A launch-like run folder: the 3D car's noise-free record and the twin's parameters."""
    from modal_twin.io.imported import write_imported

    factory = load_model(CAR3D)
    plant = factory.plant()
    v = factory.spec.speed
    u = track_inputs_3d(random_track_3d(v * seconds + 60.0, rng=8), factory.spec.axle_x, v,
                        FS, seconds, start_m=30.0)
    rig = TruthRig(plant, 1.0 / FS, seed=1)
    raw = rig.process(SignalBlock(plant.input_names, FS, 0, u, stamp_ns=10**18))
    write_imported(folder / "bag", raw, list(rig.channels))
    (folder / "params").mkdir()
    (folder / "params" / "twin.yaml").write_text(
        f"twin:\n  ros__parameters:\n    model_file: {model_file}\n    fs_hz: {FS}\n")
    return raw


def _rows(page: str, section: str) -> list[list[str]]:
    body = page.split(f'<section id="{section}">', 1)[1].split("</section>", 1)[0]
    return [re.findall(r"<td>(.*?)</td>", tr) for tr in re.findall(r"<tr>(.*?)</tr>", body)
            if "<td>" in tr]


def test_report_of_a_3d_car_run_shows_its_modes_and_ride(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    run = tmp_path / "run"
    run.mkdir()
    raw = _run_folder(run, str(CAR3D))
    assert main(["report", str(run)]) == 0
    page = (run / "report.html").read_text()
    capsys.readouterr()
    # the modes of model info, in order, with their types
    assert main(["model", "info", str(CAR3D), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    modes = _rows(page, "car")
    assert [r[1] for r in modes] == [f"carbody {m['label']}" for m in info["carbody_modes"]]
    assert [r[1] for r in modes][:3] == ["carbody sway", "carbody yaw", "carbody bounce"]
    np.testing.assert_allclose([float(r[2]) for r in modes],
                               [m["f_hz"] for m in info["carbody_modes"]], atol=5e-4)
    # ride: six floor channels; the record's index is Sperling's of its floor channel, and
    # the model (the same car, no noise) gives the same index and no PSD error
    ride = {r[0]: r for r in _rows(page, "ride")}
    assert sorted(ride) == sorted(f"floor_{p}_{a}" for p in ("front", "mid", "rear")
                                  for a in "zy")
    for name, r in ride.items():
        d = "vertical" if name.endswith("_z") else "lateral"
        w = sperling_index(raw.select([name]).data[0], FS, direction=d).W
        assert r[1] == d and float(r[2]) == pytest.approx(w, abs=6e-4)
        assert r[3] == r[2] and float(r[4]) == 0.0
    assert "floor acceleration PSD" in page and page.count("data:image/png") == 1


def test_report_of_a_3d_car_run_whose_car_is_gone_is_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    run = tmp_path / "run"
    run.mkdir()
    _run_folder(run, str(tmp_path / "gone_3d.yaml"), seconds=1.0)
    assert main(["report", str(run)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "gone_3d.yaml (params/twin.yaml model_file) is not there" in err
    assert not (run / "report.html").exists()
