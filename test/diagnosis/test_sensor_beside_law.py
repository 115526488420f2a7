"""A sensor candidate is not screened on the channels a device law was fitted through.

Known answer: RB1's x force read 10 % low (gain 0.9) in an otherwise exact record of the
building. With nothing at RB1 in the model, the screening names a gain on ``RB1_fx``; with
a device law at RB1 (found in an earlier round), RB1's drift and force channels are not
screened (the law was fitted through them: a gain there trades off with its stiffness),
while an accelerometer elsewhere still is.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from modal_twin.diagnosis.effect_kind import Round
from modal_twin.diagnosis.fitting import simulate_record
from modal_twin.diagnosis.record import Record
from modal_twin.diagnosis.sensors import SENSOR
from modal_twin.excitation import signals
from modal_twin.models.building_factory import INPUTS_6DOF, BuildingFactory
from modal_twin.models.effects import EffectSpec
from modal_twin.models.loading import with_effects

BUILDING = Path(__file__).resolve().parents[2] / "config" / "structures" / "building.yaml"
FS = 200.0


def _record(factory: BuildingFactory, gains: dict[str, float]) -> Record:
    rng = np.random.default_rng(5)
    ag = signals.band_limited_random(6, 8.0, FS, f_min_hz=0.3, f_max_hz=20.0, rms=1.0,
                                     rng=rng) * np.array([1.0, 1.0, 0.3, 0, 0, 0])[:, None]
    plant = factory.plant()
    names = tuple(plant.channel_names)
    blank = Record(FS, INPUTS_6DOF, ag, names, np.zeros((len(names), ag.shape[1])), "t")
    data = simulate_record(plant, blank)
    for ch, g in gains.items():
        data[names.index(ch)] *= g
    return Record(FS, INPUTS_6DOF, ag, names, data, "faulty")


def _screened_channels(factory: BuildingFactory, rec: Record, significant: tuple[str, ...]
                       ) -> set[str]:
    rnd = Round(factory, [rec, rec], factory.plant(), [np.full(len(rec.channel_names), 1e-4)] * 2,
                significant, [], lambda s: None)
    return {c.channel for c in SENSOR.screen(rnd)}


def test_no_sensor_candidate_on_the_channels_a_law_was_fitted_through() -> None:
    factory = BuildingFactory(BUILDING, n_modes=12)
    accel = next(c for c in factory.plant().channel_names if c.startswith("F2_") and
                 c.endswith("_x"))
    rec = _record(factory, {"RB1_fx": 0.9, accel: 1.2})
    sig = ("RB1_fx", accel)
    assert _screened_channels(factory, rec, sig) >= {"RB1_fx", accel}
    held = with_effects(factory, [EffectSpec("RB1", "bouc_wen", {})])
    got = _screened_channels(held, rec, sig)
    assert "RB1_fx" not in got
    assert accel in got
