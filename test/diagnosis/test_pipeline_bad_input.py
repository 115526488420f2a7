"""The diagnosis refuses or skips bad input with reasons, never crashes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from modal_twin.diagnosis.fitting import fit_effect, simulate_record
from modal_twin.diagnosis.pipeline import diagnose
from modal_twin.diagnosis.record import Record
from modal_twin.errors import OptionError, ShapeError, SignalError
from modal_twin.models.building_factory import INPUTS_6DOF, BuildingFactory

BUILDING = Path(__file__).resolve().parents[2] / "config" / "structures" / "building.yaml"


@pytest.fixture(scope="module")
def factory() -> BuildingFactory:
    return BuildingFactory(BUILDING)


def record(n: int, channels: tuple[str, ...], fs: float = 1000.0, seed: int = 0) -> Record:
    rng = np.random.default_rng(seed)
    return Record(fs, INPUTS_6DOF, 0.1 * rng.standard_normal((6, n)), channels,
                  rng.standard_normal((len(channels), n)), f"r{seed}")


def test_record_checks() -> None:
    with pytest.raises(ShapeError, match=r"inputs: expected \(6, 100\)"):
        Record(1000.0, INPUTS_6DOF, np.zeros((6, 99)), ("a",), np.zeros((1, 100)))
    data = np.zeros((1, 100))
    data[0, 5] = np.nan
    with pytest.raises(SignalError, match="non-finite samples in data"):
        Record(1000.0, INPUTS_6DOF, np.zeros((6, 100)), ("a",), data)
    with pytest.raises(SignalError, match="too short"):
        Record(1000.0, INPUTS_6DOF, np.zeros((6, 1)), ("a",), np.zeros((1, 1)))
    with pytest.raises(SignalError, match=r"lacks channels \['zz'\]"):
        record(100, ("a",)).channels(["zz"])


def test_unknown_channels_are_skipped_with_reasons(factory: BuildingFactory) -> None:
    ch = ("F0_C1_x", "F0_C1_y", "not_in_model")
    d = diagnose(factory, record(4000, ch, seed=1), record(4000, ch, seed=2), n_fit=1)
    assert any("not_in_model" in s and "not in the model" in s for s in d.skipped)
    # white noise is all noise floor: the model cannot be judged to fail on it
    assert not d.significant and "nothing significant" in d.summary
    assert d.where.nmse_pct.shape == (2,)


def test_too_little_data_is_refused(factory: BuildingFactory) -> None:
    ch = ("F0_C1_x",)
    with pytest.raises(SignalError, match="too short"):
        diagnose(factory, record(300, ch, seed=1), record(300, ch, seed=2))


def test_candidate_errors(factory: BuildingFactory) -> None:
    ch = ("ESB1_dx", "ESB1_dy", "ESB1_fx", "ESB1_fy")
    rec = record(2000, ch)
    with pytest.raises(OptionError, match="unknown component 'ESB7'"):
        fit_effect(factory, "ESB7", "cubic", {"k3": 1.0}, rec, rec)
    with pytest.raises(OptionError, match="no fit transform for law 'magic'"):
        fit_effect(factory, "ESB1", "magic", {}, rec, rec)
    # none of the model's inputs measured: refused, naming both lists (a subset is fine:
    # the unmeasured inputs are zero)
    no_inputs = Record(1000.0, ("wind",), np.zeros((1, 2000)), ch, rec.data)
    with pytest.raises(OptionError, match=r"none of the model's inputs .* is measured"):
        fit_effect(factory, "ESB1", "cubic", {"k3": 1e6}, no_inputs, no_inputs)
    one_input = Record(1000.0, ("ax",), np.zeros((1, 2000)), ch, rec.data)
    assert np.all(simulate_record(factory.plant(), one_input) == 0.0)  # at rest
