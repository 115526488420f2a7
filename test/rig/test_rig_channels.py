"""A rig file's ``channels``: the truth measures only the structure's channels it names.

Known answer: with ``channels: ["floor_*"]`` the worn-yaw-damper rig of the 3D car
(``config/rigs/vehicle3d_worn_yaw_damper.yaml``) gives the 24 table inputs and the six floor
accelerations, and each floor row equals the row of the same channel from a rig measuring
everything (same truth, no noise) to the bit; the acquisition's channel map is the same
list; a pattern that matches nothing is one ConfigError naming it.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from modal_twin.errors import ConfigError
from modal_twin.models.loading import load_model
from modal_twin.models.rig_file import load_rig
from modal_twin.models.sensors import rig_channels
from modal_twin.rig.truth import TruthRig
from modal_twin.signal_block import SignalBlock

RIG = Path(__file__).resolve().parents[2] / "config" / "rigs" / "vehicle3d_worn_yaw_damper.yaml"


def test_the_rig_measures_the_channels_its_file_names() -> None:
    rig = load_rig(RIG)
    assert rig.channels == ("floor_*",) and rig.theta == {"c_yaw_damper_1L": 75000.0}
    plant = load_model(rig.structure, theta=rig.theta).plant()
    some = TruthRig(plant, 1 / 200.0, channels=rig.channels)
    every = TruthRig(plant, 1 / 200.0)
    floor = [c.name for c in plant.channels if c.name.startswith("floor_")]
    assert len(floor) == 6
    assert some.names == tuple(f"table_{n}" for n in plant.input_names) + tuple(floor)
    assert [c.name for c in rig_channels(rig)] == list(some.names)
    u = np.random.default_rng(1).standard_normal((len(plant.input_names), 40)) * 1e-3
    a = some.process(SignalBlock(plant.input_names, 200.0, 0, u))
    b = every.process(SignalBlock(plant.input_names, 200.0, 0, u))
    np.testing.assert_array_equal(a.data, b.select(list(a.channel_names)).data)


def test_a_pattern_that_matches_nothing_is_refused() -> None:
    rig = replace(load_rig(RIG), channels=("floor_*", "roof_*"))
    with pytest.raises(ConfigError, match="'roof_\\*' matches none of"):
        rig_channels(rig)
