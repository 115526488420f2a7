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


# Roles from the header's location words (modal_twin.io.channel_map.roles_from_locations):
# snippets in the vocabulary of CSMIP bridge and building headers and USGS SMC <loclbl=>.
from modal_twin.io.channel_map import roles_from_locations  # noqa: E402


def _roles(rows: list[tuple[str, str, float]]) -> list[str]:
    locs, oris, peaks = zip(*rows, strict=True)
    return [r for r, _ in roles_from_locations(list(locs), list(oris), list(peaks))]


def test_base_words_are_inputs_and_structure_words_outputs() -> None:
    rows = [("Free Field", "Long", 1.0), ("Basement, east side", "351", 1.0),
            ("Ground floor", "81", 1.0), ("Pier 2 footing", "Tran", 1.0),
            ("Roof, SW corner", "171", 1.0), ("4th floor, east core", "171", 1.0),
            ("Deck: Middle of West Span", "Up", 1.0), ("Bent 4: North Column, Top", "Long", 1.0)]
    assert _roles(rows) == ["input"] * 4 + ["output"] * 4


def test_a_location_without_words_or_with_both_cannot_be_told() -> None:
    calls = roles_from_locations(["Bent 3", "Basement roof", ""], ["Long"] * 3, [1.0] * 3)
    assert [r for r, _ in calls] == ["", "", ""]
    assert "no base or structure word in 'Bent 3'" in calls[0][1]
    assert "both base 'Basement' and structure 'roof'" in calls[1][1]


def test_one_input_per_support_and_direction() -> None:
    # two column bases of bent 4: the one under a column-top sensor is the drift pair's
    # lower end, the other (even with the smaller peak) stays the support's input
    rows = [("Bent 4: North Column, Grnd Level", "Long", 9.0),
            ("Bent 4: North Column, Top", "Long", 1.0),
            ("Bent 4: South Column, Grnd Level", "Long", 2.0),
            ("Bent 4: South Column, Grnd Level", "Tran", 2.0),
            ("Pier 7 footing, east", "Tran", 1.0), ("Pier 7 footing, west", "Tran", 3.0)]
    assert _roles(rows) == ["reference", "output", "input", "input", "reference", "input"]


def test_deck_vertical_over_a_support_and_a_partial_vertical_input() -> None:
    rows = [("Abutment 1", "Up", 1.0), ("Abutment 1", "Long", 1.0),
            ("Bent 3: South Column, Grnd Level", "Long", 1.0),
            ("Deck Level near Abut 1", "Up", 1.0), ("Bent 4: Deck Level", "Up", 1.0),
            ("Midspan between Bents 3&4: Deck", "Up", 1.0)]
    assert _roles(rows) == ["reference", "input", "input", "reference", "reference", "output"]
    # vertical base motion at two supports is a full input; a building's basement has no
    # named support and keeps every sensor
    rows2 = [("On Ground: Near East Abutment", "Up", 1.0),
             ("On Ground: Near West Abutment", "Up", 1.0),
             ("Basement, east side", "UP", 1.0), ("Basement, west core", "UP", 1.0)]
    assert _roles(rows2) == ["input"] * 4
