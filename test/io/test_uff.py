from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import pyuff

from modal_twin.errors import ConfigError, SignalError
from modal_twin.io.uff import (
    rate_from_increment,
    read_uff,
    read_uff55,
    write_uff55,
    write_uff58_frf,
)


def _time_set(node: int, direction: int, data: np.ndarray, dt: float, unit: str,
              **kw: object) -> dict:
    s = pyuff.prepare_58(
        binary=0, id1=f"pt{node}", id2="NONE", id3="NONE", id4="NONE", id5="NONE",
        func_type=1, ver_num=0, load_case_id=0, rsp_ent_name=f"{node}+Z", rsp_node=node,
        rsp_dir=direction, ref_ent_name="NONE", ref_node=0, ref_dir=0, ord_data_type=4,
        num_pts=data.size, abscissa_spacing=1, abscissa_min=0.0, abscissa_inc=dt,
        z_axis_value=0.0, abscissa_spec_data_type=17, abscissa_len_unit_exp=0,
        abscissa_force_unit_exp=0, abscissa_temp_unit_exp=0, abscissa_axis_units_lab="s",
        ordinate_spec_data_type=12, ordinate_len_unit_exp=0, ordinate_force_unit_exp=0,
        ordinate_temp_unit_exp=0, ordinate_axis_units_lab=unit, orddenom_spec_data_type=0,
        orddenom_len_unit_exp=0, orddenom_force_unit_exp=0, orddenom_temp_unit_exp=0,
        orddenom_axis_units_lab="NONE", z_axis_spec_data_type=0, z_axis_len_unit_exp=0,
        z_axis_force_unit_exp=0, z_axis_temp_unit_exp=0, z_axis_axis_units_lab="NONE",
        data=data, x=np.arange(data.size) * dt)
    s.update(kw)
    return s


def test_uff58_time_data_in_si(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    a, b = rng.standard_normal(64), rng.standard_normal(64)
    p = tmp_path / "t.uff"
    pyuff.UFF(str(p)).write_sets([_time_set(3, 3, a, 1 / 256, "m/s2"),
                                  _time_set(3, -1, b, 1 / 256, "g")], mode="overwrite")
    u = read_uff(p)
    (s1, fs1, t0, x1), (s2, _, _, x2) = u.time
    assert (s1.name, s1.quantity, s1.direction, s1.node) == ("3+Z", "acceleration", "z", "3")
    assert s2.name.startswith("3+Z#")  # the same node name twice: made unique
    assert s2.direction == "-x"
    assert fs1 == pytest.approx(256.0)
    assert t0 == 0.0
    np.testing.assert_allclose(x1, a, rtol=1e-6)
    np.testing.assert_allclose(x2, b * 9.80665, rtol=1e-6)


def test_a_rate_survives_the_six_digits_of_the_increment(tmp_path: Path) -> None:
    # E13.5 keeps 2.44141e-04 of 1/4096 s: the rate is 4096 Hz, not 4095.99 Hz
    assert rate_from_increment(float(f"{1 / 4096:.5e}")) == 4096.0
    assert rate_from_increment(float(f"{1 / 2500:.5e}")) == 2500.0
    # a rate that is not a whole number of hertz and is written exactly stays as it is
    assert rate_from_increment(1 / 333.3) == pytest.approx(333.3, rel=1e-12)
    # through a file (ASCII 58): 4096 Hz written, 4096 Hz read
    x = np.random.default_rng(2).standard_normal(32)
    p = tmp_path / "r.uff"
    pyuff.UFF(str(p)).write_sets([_time_set(1, 3, x, 1 / 4096, "m/s2")], mode="overwrite")
    assert read_uff(p).time[0][1] == 4096.0


def test_uff55_round_trip_through_pyuff(tmp_path: Path) -> None:
    f, z = np.array([1.5, 4.25]), np.array([0.02, 0.05])
    S = np.array([[1.0, 0.3 + 0.1j], [-0.5, 1.0], [0.25 - 0.05j, -0.75]])
    p = write_uff55(tmp_path / "m.uff", f, z, S, nodes=[1, 1, 2], dirs=[1, 2, -3])
    raw = pyuff.UFF(str(p)).read_sets()
    assert [int(r["mode_n"]) for r in raw] == [1, 2]
    lam = raw[1]["eig"]
    assert abs(lam) / (2 * np.pi) == pytest.approx(4.25, rel=1e-5)
    assert raw[0]["r2"][0] == pytest.approx(-0.5, rel=1e-5)
    assert raw[0]["r3"][1] == pytest.approx(-(0.25 - 0.05j), rel=1e-5)  # -z: sign flipped
    d = read_uff55(p)
    np.testing.assert_allclose(d["f_hz"], f, rtol=1e-5)
    np.testing.assert_allclose(d["zeta"], z, rtol=1e-4)
    assert d["shapes"].shape == (6, 2)
    assert [(n, dr) for _, n, dr in d["channels"]] == [(1, "x"), (1, "y"), (2, "-z")]
    np.testing.assert_allclose(d["channel_shapes"], S, rtol=1e-5)
    with pytest.raises(ConfigError, match="expected UFF dataset 55"):
        read_uff55(write_uff58_frf(tmp_path / "f.uff", np.arange(4.0), np.ones((1, 1, 4)),
                                   [(1, 3)], [(2, 3)]))


def test_a_modes_file_is_not_said_skipped(tmp_path: Path,
                                         caplog: pytest.LogCaptureFixture) -> None:
    """``import`` of a UFF 55 reads its modes (read_uff55); read_uff must not log that the
    55 sets were skipped (it printed 'dataset types [55] skipped (not read)' beside
    'wrote modes_m.json'); a type nobody reads still is."""
    p = write_uff55(tmp_path / "m.uff", np.array([2.0]), np.array([0.01]),
                    np.ones((1, 1), complex), nodes=[1], dirs=[3])
    with caplog.at_level("INFO", logger="modal_twin.io.uff"):
        assert read_uff(p).skipped == (55,)
    assert "skipped" not in caplog.text
    with p.open("a") as fh:  # a 164 (units) is read; a 2412 (elements) is not
        fh.write("    -1\n  2412\n         1        11         2         1         7"
                 "         2\n         0         1         1\n         1         2\n"
                 "    -1\n")
    caplog.clear()
    with caplog.at_level("INFO", logger="modal_twin.io.uff"):
        read_uff(p)
    assert "dataset types [2412] skipped" in caplog.text


def test_uff58_frfs_name_their_channels_for_other_tools(tmp_path: Path) -> None:
    """``export frf`` of a strong-motion record wrote nodes 1..N and nothing saying which
    channel each is; the names now stand in id lines 3 / 4, read back by pyuff."""
    f = np.linspace(0.0, 10.0, 11)
    H = np.ones((2, 1, 11), complex)
    long = "x" * 100
    p = write_uff58_frf(tmp_path / "f.uff", f, H, [(8, 1), (9, 2)], [(1, 1)],
                        ["acceleration"] * 2, ["acceleration"],
                        names=(["58658.ch12", long], ["58658.ch02"]))
    raw = pyuff.UFF(str(p)).read_sets()
    assert [(r["id3"], r["id4"]) for r in raw] == [
        ("rsp 58658.ch12", "ref 58658.ch02"), (("rsp " + long)[:80], "ref 58658.ch02")]
    assert [(int(r["rsp_node"]), int(r["ref_node"])) for r in raw] == [(8, 1), (9, 1)]
    with pytest.raises(SignalError, match="2 outputs / 1 inputs, 1 / 1 names"):
        write_uff58_frf(tmp_path / "g.uff", f, H, [(8, 1), (9, 2)], [(1, 1)],
                        names=(["a"], ["b"]))


def test_uff58_frf_round_trip_through_pyuff(tmp_path: Path) -> None:
    fr = np.linspace(0.0, 10.0, 11)
    H = np.exp(1j * fr)[None, None, :] * np.array([[[1.0], [2.0]]])
    p = write_uff58_frf(tmp_path / "h.uff", fr, H, [(5, 2)], [(1, 1), (1, 3)])
    raw = pyuff.UFF(str(p)).read_sets()
    assert [(r["func_type"], r["rsp_node"], r["rsp_dir"], r["ref_dir"]) for r in raw] == [
        (4, 5, 2, 1), (4, 5, 2, 3)]
    np.testing.assert_allclose(raw[1]["data"], H[0, 1], rtol=1e-5)
    np.testing.assert_allclose(raw[0]["x"], fr, atol=1e-9)
    u = read_uff(p)
    assert [s["func_type"] for s in u.spectra] == [4, 4]
    assert u.time == ()
    # records 9 / 10: an accelerance by default, acceleration (12) over excitation force (13)
    assert [(r["ordinate_spec_data_type"], r["orddenom_spec_data_type"]) for r in raw] == [
        (12, 13), (12, 13)]
    assert [(r["ordinate_axis_units_lab"].strip(), r["orddenom_axis_units_lab"].strip())
            for r in raw] == [("m/s2", "N"), ("m/s2", "N")]
    assert [r["abscissa_spec_data_type"] for r in raw] == [18, 18]  # frequency


def test_uff58_frf_data_types_follow_the_channels(tmp_path: Path) -> None:
    """A base-driven record's FRF is acceleration over ground acceleration (12 / 12); a
    velocity over force mobility 11 / 13; a quantity without a code 0 (unknown)."""
    fr = np.linspace(1.0, 4.0, 4)
    H = np.ones((2, 2, 4), dtype=complex)
    p = write_uff58_frf(tmp_path / "b.uff", fr, H, [(1, 1), (2, 1)], [(3, 1), (4, 3)],
                        ["acceleration", "velocity"], ["acceleration", "force"])
    raw = pyuff.UFF(str(p)).read_sets()
    assert [(r["rsp_node"], r["ref_node"], r["ordinate_spec_data_type"],
             r["orddenom_spec_data_type"]) for r in raw] == [
        (1, 3, 12, 12), (1, 4, 12, 13), (2, 3, 11, 12), (2, 4, 11, 13)]
    q = write_uff58_frf(tmp_path / "u.uff", fr, H[:1, :1], [(1, 1)], [(3, 1)],
                        ["strain gauge"], ["force"])
    one = pyuff.UFF(str(q)).read_sets()  # one set: a dict
    assert (one["ordinate_spec_data_type"], one["orddenom_spec_data_type"]) == (0, 13)
    with pytest.raises(SignalError, match="2 outputs / 2 inputs, 1 / 2 quantities"):
        write_uff58_frf(tmp_path / "x.uff", fr, H, [(1, 1), (2, 1)], [(3, 1), (4, 3)],
                        ["acceleration"], ["force", "force"])


def test_not_uff(tmp_path: Path) -> None:
    p = tmp_path / "x.uff"
    p.write_text("hello\n")
    with pytest.raises(ConfigError, match=r"x\.uff"):
        read_uff(p)


def test_uff58_roles_from_data_type_and_reference_node(tmp_path: Path) -> None:
    from modal_twin.cli import main
    from modal_twin.exit_codes import ExitCode

    x = np.random.default_rng(2).standard_normal(64)
    sets = [_time_set(5, 3, x, 1 / 256, "N", ordinate_spec_data_type=13),  # hammer force
            _time_set(3, 3, x, 1 / 256, "m/s2", ref_node=7, ref_dir=2),  # response ref 7+y
            _time_set(7, 2, x, 1 / 256, "V", ordinate_spec_data_type=0),  # at that reference
            _time_set(8, 1, x, 1 / 256, "C", ordinate_spec_data_type=5)]  # a temperature
    p = tmp_path / "r.uff"
    pyuff.UFF(str(p)).write_sets(sets, mode="overwrite")
    u = read_uff(p)
    assert [c.role for c, *_ in u.time] == ["input", "output", "input", "reference"]
    assert "reference node / direction of dataset 1" in dict(u.time[2][0].meta)["role_from"]
    q = tmp_path / "q.uff"  # an untyped channel nobody references: cannot tell
    pyuff.UFF(str(q)).write_sets([sets[0], _time_set(9, 1, x, 1 / 256, "V",
                                                     ordinate_spec_data_type=0)],
                                 mode="overwrite")
    assert [c.role for c, *_ in read_uff(q).time] == ["input", ""]
    assert main(["import", str(q), "--out", str(tmp_path / "b")]) == ExitCode.USAGE
    assert not (tmp_path / "b").exists()


def test_many_channels_print_one_line_per_role_and_reason(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    from modal_twin.cli import main

    x = np.random.default_rng(3).standard_normal(32)
    sets = [_time_set(n, 3, x, 1 / 256, "m/s2") for n in range(1, 71)]
    sets.append(_time_set(99, 2, x, 1 / 256, "N", ordinate_spec_data_type=13))
    p = tmp_path / "many.uff"
    pyuff.UFF(str(p)).write_sets(sets, mode="overwrite")
    assert main(["import", str(p), "--out", str(tmp_path / "b")]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split() == ["70", "channels", "(1+Z,", "2+Z,", "3+Z,", "...)", "output",
                                "many.uff", "dataset", "n:", "UFF", "58", "data", "type", "12",
                                "(acceleration):", "a", "response"]
    assert lines[1].split()[:4] == ["1", "channel", "(99+Z)", "input"]
    assert "roles {'output': 70, 'input': 1}" in lines[2]


def test_uff55_keeps_geometry_names_nodes_and_directions(tmp_path: Path) -> None:
    """What :func:`write_uff55` writes (modes, channel names, UFF node numbers, signed
    directions, nodes and trace lines) is read back equal, by pyuff and by read_modes."""
    from modal_twin.io.modes_file import read_modes

    f, z = np.array([2.5, 7.75, 11.0]), np.array([0.015, 0.03, 0.002])
    rng = np.random.default_rng(3)
    S = rng.standard_normal((4, 3)) + 1j * rng.standard_normal((4, 3))
    names, nodes, dirs = ["deck E", "deck_W", "pier.2", "top"], [101, 102, 205, 101], [3, 3, -1, 2]
    geo = {"nodes": {"101": [0.0, 0.0, 5.0], "102": [10.0, 0.0, 5.0], "205": [5.0, 0.0, 0.0],
                     "7": [5.0, 3.0, 0.0]},
           "trace_lines": [{"number": 1, "id": "deck", "nodes": [101, 102, 0, 205, 7]}]}
    p = write_uff55(tmp_path / "m.uff", f, z, S, nodes, dirs, names=names, geometry=geo)
    raw = pyuff.UFF(str(p)).read_sets()
    assert [int(r["type"]) for r in raw] == [15, 82, 55, 55, 55]
    assert list(raw[0]["node_nums"]) == [7, 101, 102, 205]
    np.testing.assert_allclose(raw[0]["x"], [5.0, 0.0, 10.0, 5.0])
    d = read_uff55(p)
    np.testing.assert_allclose(d["f_hz"], f, rtol=1e-5)
    np.testing.assert_allclose(d["zeta"], z, rtol=1e-4)
    assert d["channels"] == [("deck_E", 101, "z"), ("deck_W", 102, "z"), ("pier.2", 205, "-x"),
                             ("top", 101, "y")]  # a space in a name becomes "_"
    np.testing.assert_allclose(d["channel_shapes"], S, rtol=1e-4)
    assert d["geometry"]["nodes"]["102"] == [10.0, 0.0, 5.0]
    assert d["geometry"]["trace_lines"][0]["nodes"] == [101, 102, 0, 205, 7]
    m = read_modes(p)
    assert [(x["channel"], x["node"], x["direction"]) for x in m.dofs] == d["channels"]
    np.testing.assert_allclose(m.shapes, S, rtol=1e-4)
    assert m.geometry is not None and set(m.geometry["nodes"]) == set(geo["nodes"])


def test_uff55_id_lines_hold_as_many_names_as_fit(tmp_path: Path) -> None:
    n = 40  # 40 entries of ~14 characters do not fit in 3 x 80: the rest get N<node><dir>
    S = np.arange(1.0, n + 1)[:, None]
    p = write_uff55(tmp_path / "m.uff", np.array([3.0]), np.array([0.01]), S,
                    list(range(1, n + 1)), [1] * n, names=[f"chan_{k:04d}" for k in range(n)])
    d = read_uff55(p)
    names = [c[0] for c in d["channels"]]
    kept = [x for x in names if x.startswith("chan_")]
    assert 10 < len(kept) < n
    assert names[len(kept):] == [f"N{k}x" for k in range(len(kept) + 1, n + 1)]
    np.testing.assert_allclose(d["channel_shapes"][:, 0], np.arange(1.0, n + 1), rtol=1e-6)


def test_frf_file_carries_the_channels_positions_as_uff_15(tmp_path: Path) -> None:
    """Channels with positions: frf.uff starts with UFF 164 (SI) and 15 at those positions."""
    from modal_twin.channels import ChannelSpec
    from modal_twin.io.impact_files import channel_geometry

    chans = [ChannelSpec("a7z", "acceleration", node="7", direction="z",
                         position_m=(1.5, -0.25, 2.0)),
             ChannelSpec("f3x", "force", node="3", direction="x", position_m=(0.0, 0.5, 0.0)),
             ChannelSpec("a9x", "acceleration", node="9", direction="x")]  # no position
    geo = channel_geometry(chans)
    assert geo is not None and geo["nodes"] == {"7": [1.5, -0.25, 2.0], "3": [0.0, 0.5, 0.0]}
    assert channel_geometry(chans[2:]) is None
    f = np.linspace(1.0, 10.0, 10)
    p = write_uff58_frf(tmp_path / "frf.uff", f, np.ones((1, 1, 10), complex), [(7, 3)],
                        [(3, 1)], geometry=geo)
    back = read_uff(p).geometry
    assert back["nodes"] == {"3": [0.0, 0.5, 0.0], "7": [1.5, -0.25, 2.0]}
    assert int(back["units"]["units_code"]) == 1 and back["trace_lines"] == []
    assert [int(t) for t in pyuff.UFF(str(p)).get_set_types()] == [164, 15, 58]
