from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from modal_twin.diagnosis.live import live_diagnosis
from modal_twin.errors import SignalError
from modal_twin.excitation import signals
from modal_twin.models.building_factory import INPUTS_6DOF, BuildingFactory
from modal_twin.models.effects import EffectSpec
from modal_twin.rig.truth import TruthRig
from modal_twin.signal_block import SignalBlock
from modal_twin.twin.runner import TwinRunner

BUILDING = Path(__file__).resolve().parents[2] / "config" / "structures" / "building.yaml"


def stream(effects: list[EffectSpec]) -> tuple[list[SignalBlock], list[SignalBlock], dict]:
    f = BuildingFactory(BUILDING)
    rig = TruthRig(f.plant(effects), 1e-3, noise_rms={"acceleration": 0.002}, seed=1)
    twin = TwinRunner(f.plant(), 1000.0)
    rng = np.random.default_rng(1)
    ag = signals.band_limited_random(6, 10.0, 1000.0, f_min_hz=0.2, f_max_hz=20.0, rms=1.0,
                                     rng=rng) * np.array([1.2, 1.2, 0.3, 0, 0, 0])[:, None]
    frames, residuals = [], []
    for k in range(0, ag.shape[1], 500):
        fr = rig.process(SignalBlock(INPUTS_6DOF, 1000.0, k, ag[:, k:k + 500]))
        frames.append(fr)
        residuals.append(twin.step(fr).residual)
    return frames, residuals, {c.name: c for c in f.plant().channels}


def test_live_where_finds_the_place_and_says_when_nothing_is_wrong() -> None:
    frames, res, ch = stream([EffectSpec("ESB1", "stick_slip", {"mu_s": 0.06, "mu_k": 0.04})])
    d = live_diagnosis(frames, res[3:], ch)  # residual starts later: only the overlap counts
    assert d.significant
    assert d.where.worst("location", 1)[0].key == "ESB1"
    assert d.where.nmse_pct.shape == (66,)
    frames, res, ch = stream([])
    quiet = live_diagnosis(frames, res, ch)
    assert not quiet.significant
    assert "nothing significant" in quiet.summary
    with pytest.raises(SignalError, match="no frames or no twin residual"):
        live_diagnosis(frames, [], ch)
