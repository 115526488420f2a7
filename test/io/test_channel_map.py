from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from modal_twin.channels import (
    ChannelSpec,
    channel_map_from_dict,
    channel_map_to_dict,
    channels_with_role,
    default_role,
    direction_vector,
)
from modal_twin.errors import BagError, ConfigError
from modal_twin.io.channel_map import apply_map, map_keys, read_channel_map, write_channel_map
from modal_twin.io.imported import atomic_dir, read_imported, write_imported
from modal_twin.signal_block import SignalBlock


def test_default_roles_keep_the_naming_rules() -> None:
    assert default_role("table_ax") == "input"
    assert default_role("ESB1_dx") == "device_drift"
    assert default_role("ESB1_fy") == "device_force"
    assert default_role("F3_C1_x") == "output"
    old = ChannelSpec("table_ay", "acceleration", "table", "y")  # positional, no role
    assert old.effective_role == "input"
    assert old.with_role("reference").effective_role == "reference"
    chans = [old, ChannelSpec("F1_x", "acceleration")]
    assert [c.name for c in channels_with_role(chans, "output")] == ["F1_x"]
    with pytest.raises(ConfigError, match="role expected one of"):
        ChannelSpec("a", "acceleration", role="sensor")
    with pytest.raises(ConfigError, match="role: expected one of"):
        channels_with_role(chans, "outputs")


def test_direction_vectors() -> None:
    assert direction_vector("x") == (1.0, 0.0, 0.0)
    assert direction_vector("-z") == (-0.0, -0.0, -1.0)
    np.testing.assert_allclose(direction_vector("3,4,0"), (0.6, 0.8, 0.0))
    assert direction_vector("torsion") is None


def test_map_dict_round_trip_and_bad_maps() -> None:
    c = ChannelSpec("a1", "force", "deck", "y", 2.0, (1.0, 2.0, 3.0), "input", "12",
                    meta=(("filter_hz", [0.1, 40.0]),))
    d = channel_map_to_dict([c], fs_hz=100.0)
    assert d["channels"][0]["unit"] == "N"
    (back,) = channel_map_from_dict(json.loads(json.dumps(d)))
    assert back == c
    assert dict(back.meta) == {"filter_hz": [0.1, 40.0]}
    with pytest.raises(ConfigError, match="'channels' list"):
        channel_map_from_dict({"chans": []}, "m.yaml")
    with pytest.raises(ConfigError, match=r"unknown keys \['gain'\]"):
        channel_map_from_dict({"channels": [{"name": "a", "gain": 2}]}, "m.yaml")


def test_user_map_overrides_only_what_it_states(tmp_path: Path) -> None:
    data = [ChannelSpec("g1", "acceleration", "ground", "x", role="input"),
            ChannelSpec("d1", "acceleration", "deck", "x", role="output")]
    p = tmp_path / "map.yaml"
    p.write_text("channels:\n  - {name: g1, role: reference}\n  - {name: d1, node: '7'}\n")
    out = apply_map(data, read_channel_map(p), map_keys(p), str(p))
    assert [(c.role, c.node, c.location) for c in out] == [("reference", "", "ground"),
                                                            ("output", "7", "deck")]
    p.write_text("channels:\n  - {name: nope, role: input}\n")
    with pytest.raises(ConfigError, match=r"does not fit the data: channels \['nope'\]"):
        apply_map(data, read_channel_map(p), map_keys(p), str(p))
    with pytest.raises(ConfigError, match="channel map not found"):
        read_channel_map(tmp_path / "missing.json")


def test_imported_bag_round_trip_and_atomic_writes(tmp_path: Path) -> None:
    x = np.arange(6.0).reshape(2, 3) * 0.5
    block = SignalBlock(("u", "y"), 4.0, 0, x, source="t.csv")
    chans = [ChannelSpec("u", "acceleration", role="input"),
             ChannelSpec("y", "displacement", meta=(("azimuth_deg", float("nan")),))]
    bag = write_imported(tmp_path / "bag", block, chans, extra_files={"geo.json": {"a": 1}},
                         block_s=0.5)
    back, bc = read_imported(bag)
    np.testing.assert_array_equal(back.data, x)
    assert [c.effective_role for c in bc] == ["input", "output"]
    assert json.loads((bag / "geo.json").read_text()) == {"a": 1}
    assert "NaN" not in (bag / "channel_map.json").read_text()  # strict JSON
    assert write_channel_map(tmp_path / "m.json", chans).is_file()
    with pytest.raises(BagError, match="exists already"):
        write_imported(bag, block, chans)
    def half_written() -> None:
        with atomic_dir(tmp_path / "half") as w:
            w.mkdir()
            (w / "part").write_text("x")
            msg = "boom"
            raise RuntimeError(msg)

    with pytest.raises(RuntimeError, match="boom"):
        half_written()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bag", "m.json"]
