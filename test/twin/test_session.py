"""The twin node's work without ROS: frames in, residual out, restarts, model versions."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from modal_twin.acquisition.continuity import Verdict
from modal_twin.errors import ModalTwinError
from modal_twin.excitation import signals
from modal_twin.models.building_factory import INPUTS_6DOF
from modal_twin.models.loading import load_model
from modal_twin.rig.truth import TruthRig
from modal_twin.signal_block import SignalBlock
from modal_twin.twin.session import TwinSession

ROOT = Path(__file__).resolve().parents[2]
BUILDING = str(ROOT / "config" / "structures" / "building.yaml")


def _frames(seconds: float, first: int = 0, block: int = 200) -> list[SignalBlock]:
    """Noise-free frames of the nominal building itself."""
    rig = TruthRig(load_model(BUILDING).plant(), 1e-3, seed=1,
                   noise_rms={"acceleration": 0.0, "displacement": 0.0, "force": 0.0})
    ag = signals.band_limited_random(6, seconds, 1000.0, f_min_hz=0.2, f_max_hz=20.0, rms=1.0,
                                     rng=np.random.default_rng(2))
    ag *= np.array([1.0, 1.0, 0.3, 0.0, 0.0, 0.0])[:, None]
    return [rig.process(SignalBlock(INPUTS_6DOF, 1000.0, first + k, ag[:, k:k + block],
                                    stamp_ns=10**18 + (first + k) * 10**6))
            for k in range(0, ag.shape[1], block)]


def test_the_model_beside_its_own_response_leaves_no_residual(tmp_path: Path) -> None:
    twin = TwinSession(BUILDING, 1000.0, 2.0, tmp_path)
    for b in _frames(3.0):
        v, step = twin.frame(b)
        assert v.verdict is Verdict.OK and step is not None
        meas = b.select(list(step.residual.channel_names)).data
        assert np.max(np.abs(step.residual.data)) <= 1e-6 * np.max(np.abs(meas)) + 1e-12
    # a replay from the start is a new run: the structure starts from rest again
    old = twin.runner
    v, step = twin.frame(_frames(0.2)[0])
    assert v.verdict is Verdict.RESTART and twin.runner is not old and step is not None
    assert np.max(np.abs(step.residual.data)) < 1e-6


def test_a_model_version_outside_the_allowed_folders_changes_nothing(tmp_path: Path) -> None:
    twin = TwinSession(BUILDING, 1000.0, 2.0, tmp_path / "models")
    before = (twin.plant, twin.version)
    with pytest.raises(ModalTwinError):
        twin.load_version("/etc/passwd", {}, "v9")
    assert (twin.plant, twin.version) == before
    # the model itself with a changed parameter: loaded, labelled
    assert twin.load_version("", {"kcol_1A": 0.9}, "v1") == "v1"
    assert twin.plant is not before[0]


def test_a_whole_stream_window_spans_every_sample_and_counts_what_it_lost(
        tmp_path: Path) -> None:
    frames = _frames(2.0)  # 10 blocks of 200 samples, samples 0..1999
    twin = TwinSession(BUILDING, 1000.0, 0.0, tmp_path)  # window 0: the whole stream
    for b in frames:
        twin.frame(b)
    m = twin.runner.metrics()
    assert m is not None and m.samples == 2000
    assert twin.runner.window_range() == (0, 1999)
    assert "samples 0..1999: 2000 compared, 0 missing; blocks dropped 0" in twin.coverage()
    # a lost block is a gap, a repeated one is dropped: both counted, the span stays exact
    twin = TwinSession(BUILDING, 1000.0, 0.0, tmp_path)
    for b in [*frames[:3], *frames[4:6], frames[5], *frames[6:]]:
        twin.frame(b)
    assert twin.runner.window_range() == (0, 1999)
    line = twin.coverage()
    assert "1800 compared, 200 missing; blocks dropped 1 ({'repeat': 1}), gaps 1" in line
    # a sliding window spans its last samples
    twin = TwinSession(BUILDING, 1000.0, 0.5, tmp_path)
    for b in frames:
        twin.frame(b)
    assert twin.runner.window_range() == (1500, 1999)
