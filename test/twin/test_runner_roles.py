"""The twin on a user's record: channels routed by their roles, unmeasured inputs at zero.

Known answer: the record is the nominal model's own response (no noise), renamed and
reduced the way an imported file would be, so the twin's residual must vanish wherever
it routes correctly, and it cannot vanish if one channel is routed wrong.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from modal_twin.channels import ChannelSpec
from modal_twin.errors import ConfigError, SignalError
from modal_twin.excitation import signals
from modal_twin.models.building_factory import INPUTS_6DOF
from modal_twin.models.loading import load_model
from modal_twin.models.sensors import route_channels
from modal_twin.rig.truth import TruthRig
from modal_twin.signal_block import SignalBlock
from modal_twin.twin.runner import TwinRunner
from modal_twin.twin.session import TwinSession

ROOT = Path(__file__).resolve().parents[2]
BUILDING = ROOT / "config" / "structures" / "building.yaml"
FS = 1000.0
# imported names for three of the model's sensors (place, direction, quantity say which)
SENSORS = {"acc_01": ("F1_C1", "x"), "acc_02": ("R_P2", "y"), "acc_03": ("F2_C2", "x")}


def truth_frames(seconds: float = 4.0) -> list[SignalBlock]:
    """The nominal building driven along x and y only, in 100-sample frames."""
    rng = np.random.default_rng(3)
    ag = signals.band_limited_random(6, seconds, FS, f_min_hz=0.2, f_max_hz=20.0, rms=1.0,
                                     rng=rng) * np.array([1.0, 0.7, 0, 0, 0, 0])[:, None]
    truth = TruthRig(load_model(BUILDING).plant(), 1.0 / FS)
    n = ag.shape[1]
    return [truth.process(SignalBlock(INPUTS_6DOF, FS, k, ag[:, k:k + 100]))
            for k in range(0, n, 100)]


def imported(frame: SignalBlock) -> SignalBlock:
    """The frame as a user's file would hold it: own names, two inputs, a reference."""
    names = ("base_NS", "base_EW", *SENSORS, "temperature")
    src = ("table_ax", "table_ay", *(f"{p}_{d}" for p, d in SENSORS.values()))
    data = np.vstack([frame.select(list(src)).data,  # + a reference the twin leaves out
                      np.full((1, frame.n_samples), 21.5)])
    return SignalBlock(names, frame.fs_hz, frame.first_index, data, frame.stamp_ns, "file")


def channel_map() -> list[ChannelSpec]:
    return [ChannelSpec("base_NS", "acceleration", "base", "x", role="input"),
            ChannelSpec("base_EW", "acceleration", "base", "y", role="input"),
            *(ChannelSpec(n, "acceleration", p, d, role="output")
              for n, (p, d) in SENSORS.items()),
            ChannelSpec("temperature", "temperature", "", "", role="reference")]


def test_imported_record_routed_by_roles_gives_zero_residual() -> None:
    plant = load_model(BUILDING).plant()
    twin = TwinRunner(plant, FS, window_s=4.0, channels=channel_map())
    steps = [twin.step(imported(f)) for f in truth_frames()]
    assert steps[0].first and not steps[1].first
    assert twin.route.inputs == (("base_NS", "ax"), ("base_EW", "ay"))
    assert twin.zero_inputs == ("az", "arx", "ary", "arz")
    assert twin.compare == ["F1_C1_x", "R_P2_y", "F2_C2_x"]  # the model's names
    assert steps[-1].prediction.channel_names == ("F1_C1_x", "R_P2_y", "F2_C2_x")
    m = twin.metrics()
    assert m is not None
    assert np.all(m.rms_measured > 1e-3)
    assert np.nanmax(m.residual_pct) < 1e-6  # the same model on the same inputs
    line = twin.describe_route()
    assert "base_NS -> ax" in line and "held at zero: az, arx, ary, arz" in line


def test_a_wrong_role_shows_in_the_residual() -> None:
    """Routing matters: with the two inputs swapped, the residual is large."""
    swapped = [replace_dir(c) for c in channel_map()]
    twin = TwinRunner(load_model(BUILDING).plant(), FS, window_s=4.0, channels=swapped)
    for f in truth_frames(2.0):
        twin.step(imported(f))
    m = twin.metrics()
    assert m is not None and np.nanmin(m.residual_pct) > 20.0


def replace_dir(c: ChannelSpec) -> ChannelSpec:
    from dataclasses import replace

    swap = {"base_NS": "y", "base_EW": "x"}
    return replace(c, direction=swap.get(c.name, c.direction))


def test_table_names_still_route_and_a_subset_of_them_is_enough() -> None:
    frames = truth_frames(2.0)
    keep = ["table_ax", "table_ay", "F1_C1_x", "F3_C3_y"]
    twin = TwinRunner(load_model(BUILDING).plant(), FS, window_s=2.0)
    for f in frames:
        twin.step(f.select(keep))
    assert twin.zero_inputs == ("az", "arx", "ary", "arz")
    m = twin.metrics()
    assert m is not None and np.nanmax(m.residual_pct) < 1e-6


def test_session_takes_a_channel_map_and_restarts_only_when_it_changes(tmp_path: Path) -> None:
    session = TwinSession(str(BUILDING), FS, 2.0, tmp_path)
    assert session.set_channels(channel_map())
    assert not session.set_channels(channel_map())  # the same latched map again
    for f in truth_frames(1.0):
        _, step = session.frame(imported(f))
    assert step is not None and step.prediction.channel_names[0] == "F1_C1_x"


def test_bad_routes_are_refused_with_the_channel_named() -> None:
    plant = load_model(BUILDING).plant()
    names = ("force_1", "acc_01")
    bad = [ChannelSpec("force_1", "force", "", "x", role="input"),
           ChannelSpec("acc_01", "acceleration", "F1_C1", "x", role="output")]
    with pytest.raises(ConfigError, match=r"'force_1' .*drives none of the model's inputs"):
        route_channels(names, bad, plant.input_names, plant.channels)
    two = [ChannelSpec("a", "acceleration", "", "x", role="input"),
           ChannelSpec("b", "acceleration", "", "x", role="input")]
    with pytest.raises(ConfigError, match="'a' and 'b' both drive the model input 'ax'"):
        route_channels(("a", "b"), two, plant.input_names, plant.channels)
    twin = TwinRunner(plant, FS, channels=[ChannelSpec("acc_01", "acceleration", "F1_C1", "x",
                                                       role="output")])
    with pytest.raises(SignalError, match="no channel that drives the model's inputs"):
        twin.step(SignalBlock(("acc_01",), FS, 0, np.zeros((1, 10))))
