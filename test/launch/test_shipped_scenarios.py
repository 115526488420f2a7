"""Every shipped scenario is consistent: its excitation builds, its rig and twin models load,
and the rig measures the channels the twin predicts (no ROS: the nodes' own loaders)."""

from __future__ import annotations

from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import pytest

from modal_twin.excitation.drive import ExcitationConfig, make_drive
from modal_twin.models.loading import load_model
from modal_twin.models.rig_file import load_rig
from modal_twin.paths import resolve_config
from modal_twin.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = sorted((ROOT / "config" / "scenarios").glob("*.yaml"))


@pytest.mark.parametrize("path", SCENARIOS, ids=[p.stem for p in SCENARIOS])
def test_shipped_scenario_is_consistent(path: Path) -> None:
    sc = load_scenario(path)
    nodes = {n.name: n.parameters for n in sc.nodes}
    inputs: tuple[str, ...] = ()
    if "excitation" in nodes:
        names = {f.name for f in fields(ExcitationConfig)}
        kw = {k: tuple(v) if isinstance(v, list) else v
              for k, v in nodes["excitation"].items() if k in names}
        cfg = ExcitationConfig(**kw)
        drive = make_drive(replace(cfg, duration_s=1.0))
        assert drive.shape[0] == len(cfg.channels)
        assert np.all(np.isfinite(drive))
        inputs = cfg.channels
    rig_plant = None
    if "rig" in nodes:
        rig = load_rig(resolve_config(nodes["rig"]["rig_file"]))
        rig_plant = load_model(rig.structure, theta=rig.theta or None).plant(rig.effects)
        if inputs:
            assert set(rig_plant.input_names) <= set(inputs), path.name
    if "twin" in nodes:
        twin = load_model(resolve_config(nodes["twin"]["model_file"])).plant()
        if rig_plant is not None:
            assert twin.channel_names == rig_plant.channel_names
            assert twin.input_names == rig_plant.input_names
