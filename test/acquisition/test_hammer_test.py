"""The acquisition's impact mode on a simulated roving-hammer test of a two-mass system.

Known answer: the accelerance matrix in closed form, ``-w^2 (K - w^2 M + i w C)^-1``; the
FRF matrix the mode writes (UFF 58, read back with pyuff) matches it within 1 % over
2-40 Hz, and a bounced hit is rejected, counted and said.
"""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from scipy import signal

from modal_twin.acquisition.hammer_test import HammerTest
from modal_twin.channels import ChannelSpec
from modal_twin.errors import OptionError, SignalError
from modal_twin.excitation.signals import hammer_pulse
from modal_twin.io.impact_files import write_hammer_result
from modal_twin.signal_block import SignalBlock

FS = 1000.0
M = np.diag([2.0, 1.0])
KK = np.array([[9e3, -3e3], [-3e3, 3e3]])
CC = 0.002 * KK + 0.5 * M  # Rayleigh: a closed form with a full damping matrix
CHANNELS = (ChannelSpec("F1", "force", node="1", direction="x", role="input"),
            ChannelSpec("F2", "force", node="2", direction="x", role="input"),
            ChannelSpec("a1", "acceleration", node="1", direction="x", role="output"),
            ChannelSpec("a2", "acceleration", node="2", direction="x", role="output"))


def accelerance(f_hz: np.ndarray) -> np.ndarray:
    w = 2 * np.pi * f_hz
    return np.stack([-wk**2 * np.linalg.inv(KK - wk**2 * M + 1j * wk * CC) for wk in w],
                    axis=-1)


def simulate(bounce_hit: int | None) -> np.ndarray:
    """Force and acceleration rows (F1, F2, a1, a2): 3 hits at mass 1, then 3 at mass 2."""
    spacing, n_hits = 8.0, 3
    nt = round(2 * n_hits * spacing * FS)
    forces = np.zeros((2, nt))
    for i in range(2):
        for h in range(n_hits):
            at = 0.2 + (i * n_hits + h) * spacing
            kw = {"tip_stiffness_n_m": 2e4, "hammer_mass_kg": 0.3}
            forces[i] += hammer_pulse(nt, FS, peak_n=80.0, at_s=at, **kw)
            if bounce_hit == i * n_hits + h:
                forces[i] += hammer_pulse(nt, FS, peak_n=30.0, at_s=at + 0.04, **kw)
    a = np.block([[np.zeros((2, 2)), np.eye(2)],
                  [-np.linalg.solve(M, KK), -np.linalg.solve(M, CC)]])
    b = np.vstack([np.zeros((2, 2)), np.linalg.inv(M)])
    t = np.arange(nt) / FS
    _, acc, _ = signal.lsim(signal.StateSpace(a, b, a[2:], b[2:]), forces.T, t)
    return np.vstack([forces, acc.T])


def stream(test: HammerTest, x: np.ndarray, frame: int = 250) -> None:
    names = tuple(c.name for c in CHANNELS)
    for s in range(0, x.shape[1], frame):
        test.add(SignalBlock(names, FS, s, x[:, s:s + frame]))


def test_the_impact_mode_writes_the_closed_form_frf_matrix_and_rejects_a_bounce(tmp_path
                                                                                ) -> None:
    import pyuff

    test = HammerTest(CHANNELS, block_s=6.0)
    stream(test, simulate(bounce_hit=4))  # the second hit at mass 2 bounces
    res = test.finish()
    assert res.n_accepted == 5 and res.n_rejected == 1
    assert [p.n_averages for p in res.per_point] == [3, 2]
    lines = res.lines()
    assert lines[0].startswith("impact: 5 hits averaged, 1 rejected")
    assert any("rejected" in ln and "double hit" in ln for ln in lines[1:])
    frf, hits = write_hammer_result(tmp_path / "impact", res)
    sets = pyuff.UFF(str(frf)).read_sets()
    assert len(sets) == 4
    assert {(s["ordinate_spec_data_type"], s["orddenom_spec_data_type"]) for s in sets} == {
        (12, 13)}  # acceleration over excitation force
    f = np.asarray(sets[0]["x"])
    band = (f > 2.0) & (f < 40.0)
    ref = accelerance(f[band])
    for s in sets:  # each FRF at its own response / reference node
        o, i = int(s["rsp_node"]) - 1, int(s["ref_node"]) - 1
        h = np.asarray(s["data"])[band]
        assert float(np.max(np.abs(h - ref[o, i]) / np.abs(ref[o, i]))) < 0.01
    summary = yaml.safe_load(hits.read_text())
    assert summary["hits_rejected"] == 1 and summary["hits_averaged"] == 5
    bad = [h for p in summary["points"] for h in p["hits"] if not h["accepted"]]
    assert len(bad) == 1 and "double hit" in bad[0]["reason"]


def test_a_gap_in_the_stream_keeps_hit_times_and_a_long_one_is_refused() -> None:
    x = simulate(bounce_hit=None)
    names = tuple(c.name for c in CHANNELS)
    test = HammerTest(CHANNELS, block_s=6.0)
    test.add(SignalBlock(names, FS, 0, x[:, :1000]))
    test.add(SignalBlock(names, FS, 1100, x[:, 1100:2000]))  # 100 samples lost
    assert test.gaps == 1 and test.n_samples == 2000
    with pytest.raises(SignalError, match="expected 2000"):
        test.add(SignalBlock(names, FS, 9000, x[:, 9000:9100]))


def test_a_map_without_force_or_a_point_without_good_hits_is_said() -> None:
    with pytest.raises(OptionError, match="0 force"):
        HammerTest(CHANNELS[2:], block_s=6.0)
    with pytest.raises(SignalError, match="no frame"):
        HammerTest(CHANNELS, block_s=6.0).finish()


def _impact_cli(tmp_path, bags: list, *extra: str):
    from modal_twin.cli import main

    out = tmp_path / "frf"
    assert main(["impact", *map(str, bags), "--block-s", "6", "--out", str(out), *extra]) == 0
    return out


def _check_matrix(frf_file, points: int) -> None:
    import pyuff

    sets = pyuff.UFF(str(frf_file)).read_sets()
    assert len(sets) == 2 * points
    f = np.asarray(sets[0]["x"])
    band = (f > 2.0) & (f < 40.0)
    ref = accelerance(f[band])
    for s in sets:
        o, i = int(s["rsp_node"]) - 1, int(s["ref_node"]) - 1
        h = np.asarray(s["data"])[band]
        assert float(np.max(np.abs(h - ref[o, i]) / np.abs(ref[o, i]))) < 0.01


def test_uff_time_records_written_by_the_project_import_as_hits(tmp_path, capsys) -> None:
    from modal_twin.cli import main
    from modal_twin.io.uff import read_uff, write_uff58_time

    path = write_uff58_time(tmp_path / "hammer.uff", CHANNELS, FS, simulate(bounce_hit=1))
    back = read_uff(path)  # name, node, direction, quantity and role come back
    assert [(c.name, c.node, c.direction, c.quantity, c.role) for c, *_ in back.time] == [
        (c.name, c.node, c.direction, c.quantity, c.role) for c in CHANNELS]
    assert main(["import", str(path), "--out", str(tmp_path / "bag")]) == 0
    out = _impact_cli(tmp_path, [tmp_path / "bag"])
    text = capsys.readouterr().out
    assert "impact: 5 hits averaged, 1 rejected" in text and "double hit" in text
    _check_matrix(out / "frf.uff", points=2)


def test_a_hand_built_uff_per_hit_point_imports_as_hits(tmp_path, capsys) -> None:
    """As a test system exports it: one file per hit point, accelerations in g, the
    responses naming the hammer's node as their reference (the driving point's accelerometer
    then reads as ``input`` on import; the impact processing takes it as a response)."""
    import pyuff

    from modal_twin.cli import main

    x = simulate(bounce_hit=None)
    half = x.shape[1] // 2
    bags = []
    for point in (1, 2):
        part = x[:, (point - 1) * half:point * half]
        rows = [("hammer", 13, "N", point, part[point - 1], 0)]
        rows += [(f"acc{n}", 12, "g", n, part[1 + n] / 9.80665, point) for n in (1, 2)]
        sets = [pyuff.prepare_58(
            binary=0, id1=name, id2="NONE", id3="NONE", id4="NONE", id5="NONE", func_type=1,
            ver_num=0, load_case_id=0, rsp_ent_name=name, rsp_node=node, rsp_dir=3,
            ref_ent_name="NONE", ref_node=ref, ref_dir=3 if ref else 0, ord_data_type=4,
            num_pts=data.size, abscissa_spacing=1, abscissa_min=0.0, abscissa_inc=1 / FS,
            z_axis_value=0.0, abscissa_spec_data_type=17, abscissa_len_unit_exp=0,
            abscissa_force_unit_exp=0, abscissa_temp_unit_exp=0, abscissa_axis_units_lab="s",
            ordinate_spec_data_type=dtype, ordinate_len_unit_exp=0, ordinate_force_unit_exp=0,
            ordinate_temp_unit_exp=0, ordinate_axis_units_lab=unit, orddenom_spec_data_type=0,
            orddenom_len_unit_exp=0, orddenom_force_unit_exp=0, orddenom_temp_unit_exp=0,
            orddenom_axis_units_lab="NONE", z_axis_spec_data_type=0, z_axis_len_unit_exp=0,
            z_axis_force_unit_exp=0, z_axis_temp_unit_exp=0, z_axis_axis_units_lab="NONE",
            data=data, x=np.arange(data.size) / FS, return_full_dict=True)
            for name, dtype, unit, node, data, ref in rows]
        f = tmp_path / f"point{point}.uff"
        pyuff.UFF(str(f)).write_sets(sets, mode="overwrite")
        bags.append(tmp_path / f"bag{point}")
        assert main(["import", str(f), "--out", str(bags[-1])]) == 0
    out = _impact_cli(tmp_path, bags)
    text = capsys.readouterr().out
    assert "forces ['hammer'], responses ['acc1', 'acc2']" in text
    assert "impact: 6 hits averaged, 0 rejected" in text
    _check_matrix(out / "frf.uff", points=2)


def test_a_device_load_cell_is_no_hammer() -> None:
    from modal_twin.acquisition.hammer_test import hammer_channels

    cell = ChannelSpec("RB1_fx", "force", role="device_force")
    forces, resp = hammer_channels([*CHANNELS, cell])
    assert [c.name for c in forces] == ["F1", "F2"]
    assert [c.name for c in resp] == ["a1", "a2"]


@pytest.mark.parametrize(("extra", "said"), [
    (("--block-s", "60"), "--block-s 60.0: expected at most the record's 48 s"),
    (("--block-s", "inf"), "--block-s and --tau-s: expected > 0, got inf"),
    (("--block-s", "6", "--force-range", "-3"), "--force-range: expected a range > 0 N"),
    (("--block-s", "6", "--force-range", "nan"), "--force-range: expected a range > 0 N"),
])
def test_impact_options_outside_the_record_are_one_line_and_nothing_written(
        tmp_path, capsys, extra: tuple[str, ...], said: str) -> None:
    """A block longer than the 48 s record (it read as 'no force above the trigger'), an
    infinite block (an OverflowError), a negative range (every hit an 'overload at -3 N')
    and a NaN range (no overload check at all, exit 0): each one line naming the limit,
    exit 2, no output."""
    from modal_twin.cli import main
    from modal_twin.io.uff import write_uff58_time

    path = write_uff58_time(tmp_path / "hammer.uff", CHANNELS, FS, simulate(bounce_hit=None))
    assert main(["import", str(path), "--out", str(tmp_path / "bag")]) == 0
    capsys.readouterr()
    out = tmp_path / "frf"
    assert main(["impact", str(tmp_path / "bag"), "--out", str(out), *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and said in err, err
    assert not out.exists() or not any(out.iterdir())


def test_report_shows_the_frf_matrix_of_an_impact_folder(tmp_path, capsys) -> None:
    """``report`` on the folder ``impact`` wrote (frf.uff, hits.yaml, no modes): it said
    'nothing to report'; now the FRF section holds every response over every reference,
    equal to the closed-form accelerance within 1 % over 2-40 Hz."""
    from modal_twin.cli import main
    from modal_twin.commands.report_record import load_record_folder
    from modal_twin.io.uff import write_uff58_time

    path = write_uff58_time(tmp_path / "hammer.uff", CHANNELS, FS, simulate(bounce_hit=1))
    assert main(["import", str(path), "--out", str(tmp_path / "bag")]) == 0
    out = _impact_cli(tmp_path, [tmp_path / "bag"])
    data, missing = load_record_folder(out)
    assert data is not None, missing
    f, rows, names, model = data.frf
    assert names == ["1x/1x", "2x/1x", "1x/2x", "2x/2x"] and model is None
    band = (f > 2.0) & (f < 40.0)
    ref = accelerance(f[band])
    for k, (o, i) in enumerate([(0, 0), (1, 0), (0, 1), (1, 1)]):
        err = np.abs(rows[k, band] - ref[o, i]) / np.abs(ref[o, i])
        assert float(np.max(err)) < 0.01
    capsys.readouterr()
    assert main(["report", str(out), "--out", str(tmp_path / "r.html")]) == 0
    page = (tmp_path / "r.html").read_text()
    assert '<section id="frf">' in page and "FRF: frf.uff, 2 responses x 2 references" in page


@pytest.mark.parametrize(("param", "value", "said"), [
    ("impact_force_range_n", -3.0, "impact_force_range_n: expected >= 0 (0: none), got -3.0"),
    ("impact_force_range_n", float("nan"), "impact_force_range_n: expected >= 0"),
    ("impact_tau_s", -0.5, "impact_tau_s: expected >= 0 (0: none), got -0.5"),
    ("impact_block_s", float("inf"), "impact_block_s: expected a block > 0 s, got inf"),
    ("impact_block_s", 0.0, "impact_block_s: expected a block > 0 s, got 0.0"),
])
def test_the_nodes_impact_parameters_are_checked_at_start(param: str, value: float,
                                                           said: str) -> None:
    """A negative range made every hit an 'overload at -3 N' at the end of the test, a NaN
    one no overload check; now the node refuses them when its parameters are read."""
    pytest.importorskip("rclpy")
    from modal_twin.acquisition.node import AcquisitionConfig

    with pytest.raises(OptionError, match=said.replace("(", r"\(").replace(")", r"\)")):
        AcquisitionConfig(mode="impact", **{param: value})
    AcquisitionConfig(mode="impact", impact_force_range_n=300.0, impact_tau_s=0.5)


def _launched_run(tmp_path, capsys):
    """A folder as ``launch --run-dir`` leaves a hammer test: bag/ (the hits), params/,
    impact/ (frf.uff, hits.yaml); the bag here is imported, not launched (seconds, not a
    minute)."""
    from modal_twin.cli import main
    from modal_twin.io.uff import write_uff58_time

    run = tmp_path / "run"
    path = write_uff58_time(tmp_path / "hammer.uff", CHANNELS, FS, simulate(bounce_hit=1))
    assert main(["import", str(path), "--out", str(run / "bag")]) == 0
    (run / "params").mkdir()
    (run / "params" / "acquisition.yaml").write_text("acquisition:\n  mode: impact\n")
    assert main(["impact", str(run / "bag"), "--block-s", "6", "--out",
                 str(run / "impact")]) == 0
    capsys.readouterr()
    return run


def _exact_f_hz() -> np.ndarray:
    from scipy import linalg

    return np.sqrt(linalg.eigh(KK, M, eigvals_only=True)) / (2 * np.pi)


def test_report_on_a_launched_structure_run_shows_its_record_and_frfs(tmp_path, capsys) -> None:
    """``report RUN_DIR`` on a launched hammer-test run (bag/, params/, impact/) said
    'nothing to report: no run (*/bag, ...)'; now the page holds impact/'s FRF matrix and
    the hit verdicts, and the record identified: the two modes of the closed form to 1 %."""
    from modal_twin.cli import main
    from modal_twin.commands.report_record import load_launched_run

    run = _launched_run(tmp_path, capsys)
    data, missing = load_launched_run(run)
    assert data is not None, missing
    np.testing.assert_allclose(data.modes["f_id_hz"], _exact_f_hz(), rtol=0.01)
    assert data.stabilization is not None
    assert data.frf[2] == ["1x/1x", "2x/1x", "1x/2x", "2x/2x"]  # impact/'s, not the H1
    assert not any(n.startswith("FRF: H1") for n in data.notes)
    assert main(["report", str(run)]) == 0
    page = (run / "report.html").read_text()
    assert "impact/: FRF: frf.uff, 2 responses x 2 references" in page
    assert "impact/: impact: 5 hits averaged, 1 rejected" in page
    assert '<section id="frf">' in page and "identification:" in page


def test_report_on_a_launched_run_takes_a_result_folders_modes(tmp_path, capsys) -> None:
    """With ``identify impact/frf.uff --out RUN/modes`` beside, its modes are the page's (the
    record is then not identified again, and said)."""
    from modal_twin.cli import main
    from modal_twin.commands.report_record import load_launched_run

    run = _launched_run(tmp_path, capsys)
    assert main(["identify", str(run / "impact" / "frf.uff"), "--f-max", "40", "--out",
                 str(run / "modes")]) == 0
    data, missing = load_launched_run(run)
    assert data is not None, missing
    np.testing.assert_allclose(data.modes["f_id_hz"], _exact_f_hz(), rtol=0.01)
    assert data.stabilization is None
    assert "the record bag/ not identified: the modes are a result folder's" in data.notes
    assert any(n.startswith("modes/: modes: modes.json (2 modes") for n in data.notes)


def test_report_on_a_launched_run_with_nothing_in_it_is_one_line(tmp_path, capsys) -> None:
    from modal_twin.cli import main

    run = tmp_path / "run"
    (run / "bag").mkdir(parents=True)
    (run / "params").mkdir()
    assert main(["report", str(run)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "nothing to report: a launched run" in err, err
    assert not (run / "report.html").exists()
