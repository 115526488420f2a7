"""The 3D car with a worn yaw damper (issue 23, item 9): the diagnosis finds it from the floor.

Truth: the 3D trailer car (``config/vehicles/trailer_car_3d.yaml``, rigid carbody, 300
km/h) whose left yaw damper on the leading bogie keeps 30 % of its ``c``, run by the twin's
truth rig with 2 % accelerometer noise over two realisations of the German
low-interference track (vertical, alignment, cross level); channels: the floor
accelerations, vertical and lateral, only. The diagnosis of the nominal car must name
damping at that damper (``c_yaw_damper_1L``) near 30 % of nominal and nothing else. (The
benchmark's case ``new_veh3d_worn_yaw_damper_1L`` is the same effect on a truth written
apart from the library.)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from modal_twin.diagnosis.pipeline import diagnose
from modal_twin.diagnosis.record import Record, record_from_blocks
from modal_twin.models.loading import load_model
from modal_twin.models.track3d import random_track_3d, track_inputs_3d
from modal_twin.rig.truth import TruthRig
from modal_twin.signal_block import SignalBlock

ROOT = Path(__file__).resolve().parents[2]
VEHICLE3D = ROOT / "config" / "vehicles" / "trailer_car_3d.yaml"
FS = 200.0
T = 12.0
KEEP = 0.3


def _record(factory, truth_plant, seed: int) -> Record:
    spec = factory.spec
    v = spec.speed
    track = random_track_3d(v * T + 60.0, rng=seed)
    u = track_inputs_3d(track, spec.axle_x, v, FS, T, start_m=30.0)
    floor = [c for c in truth_plant.channel_names if c.startswith("floor_")]
    rig = TruthRig(truth_plant, 1 / FS, seed=seed)
    rec = record_from_blocks([rig.process(SignalBlock(truth_plant.input_names, FS, 0, u))],
                             source=f"track{seed}").with_channels(floor)
    rng = np.random.default_rng(seed + 100)
    noise = rng.standard_normal(rec.data.shape) * 0.02 * np.sqrt(
        np.mean(rec.data**2, axis=1, keepdims=True))
    return Record(rec.fs_hz, rec.input_names, rec.inputs, rec.channel_names,
                  rec.data + noise, rec.source)


@pytest.fixture(scope="module")
def found():
    factory = load_model(VEHICLE3D)
    c0 = factory.parameters()["c_yaw_damper_1L"]
    truth = factory.with_theta({"c_yaw_damper_1L": KEEP * c0}).plant()
    train, test = _record(factory, truth, 31), _record(factory, truth, 32)
    return c0, diagnose(factory, train, test)


def test_the_worn_yaw_damper_is_named_with_its_value(found) -> None:
    c0, d = found
    assert d.significant
    assert [f.effect.component for f in d.found] == ["c_yaw_damper_1L"]
    f = d.found[0]
    assert f.family == "damping"
    assert f.effect.params["c_yaw_damper_1L"] == pytest.approx(KEEP * c0, rel=0.05)
