"""A user's own record: channels named as the user likes, two of six inputs measured, a
channel map with roles; imported with ``modal-twin import``, read by role, diagnosed.

Known answer: the shipped S1 truth (stick-slip friction at ESB1, mu_s 0.06, mu_k 0.04 of
the carried weight) with only the two horizontal ground accelerations (az = 0 and no
rotations): the diagnosis of the imported record names friction at ESB1 with the kinetic
force of the truth (within the accuracy a 12 s record gives).
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from modal_twin.cli import main
from modal_twin.errors import ConfigError
from modal_twin.excitation import signals
from modal_twin.models.building_factory import INPUTS_6DOF
from modal_twin.models.loading import load_model
from modal_twin.models.rig_file import load_rig
from modal_twin.rig.truth import TruthRig
from modal_twin.signal_block import SignalBlock

ROOT = Path(__file__).resolve().parents[2]
BUILDING = ROOT / "config" / "structures" / "building.yaml"
FS = 1000.0
RENAMED = {"table_ax": "ground_x", "table_ay": "ground_y", "R_P1_x": "roof_corner_x"}


def _own_npz(path: Path, kind: str, seed: int, level: float, *, hidden: bool = True) -> Path:
    """The S1 truth (or the nominal model) driven in x and y only, saved with the user's
    names (NPZ with units)."""
    rig_file = load_rig(ROOT / "config" / "rigs" / "s1_stick_slip.yaml")
    plant = load_model(BUILDING).plant(rig_file.effects if hidden else ())
    truth = TruthRig(plant, 1 / FS, noise_rms=rig_file.noise_rms, seed=seed)
    rng = np.random.default_rng(seed)
    if kind == "random":
        ag = signals.band_limited_random(6, 12.0, FS, f_min_hz=0.2, f_max_hz=20.0, rms=1.0,
                                         rng=rng)
    else:
        ag = np.vstack([signals.earthquake_like(12.0, FS, pga=1.0, rng=rng)[0]
                        for _ in range(6)])
    ag *= level * np.array([1.0, 1.0, 0.0, 0.0, 0.0, 0.0])[:, None]
    raw = truth.process(SignalBlock(INPUTS_6DOF, FS, 0, ag))
    keep = [n for n in raw.channel_names if n not in
            ("table_az", "table_arx", "table_ary", "table_arz")]
    specs = {c.name: c for c in plant.channels}
    units = ["m/s^2" if n.startswith("table_") else specs[n].unit for n in keep]
    np.savez(path, data=raw.select(keep).data, fs_hz=FS,
             names=np.array([RENAMED.get(n, n) for n in keep]), units=np.array(units))
    return path


@pytest.fixture(scope="module")
def bags(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("own")
    roles = d / "map.yaml"
    roles.write_text(
        "channels:\n"
        "  - {name: ground_x, role: input, quantity: acceleration, direction: x}\n"
        "  - {name: ground_y, role: input, quantity: acceleration, direction: y}\n"
        "  - {name: roof_corner_x, role: output, quantity: acceleration, location: R_P1,"
        " direction: x}\n")
    out = {}
    for key, kind, seed, level in (("train", "random", 1, 1.0), ("test", "quake", 2, 3.5),
                                   ("nominal", "random", 3, 1.0)):
        npz = _own_npz(d / f"{key}.npz", kind, seed, level, hidden=key != "nominal")
        assert main(["import", str(npz), "--map", str(roles), "--out", str(d / key)]) == 0
        out[key] = d / key
    return out


def test_roles_name_the_inputs_and_the_renamed_response(bags: dict[str, Path]) -> None:
    from modal_twin.io.records import record_from_bag

    plant = load_model(BUILDING).plant()
    rec = record_from_bag(bags["train"], plant=plant)
    assert rec.input_names == ("ax", "ay")  # two of the six table inputs, by role
    assert "R_P1_x" in rec.channel_names and "roof_corner_x" not in rec.channel_names
    assert "ground_x" not in rec.channel_names
    # the unmeasured inputs are zero: the model's response to this record is finite
    from modal_twin.diagnosis.fitting import simulate_record

    assert np.all(np.isfinite(simulate_record(plant, rec)))


def test_an_input_the_model_lacks_is_one_clear_error(tmp_path: Path) -> None:
    from modal_twin.channels import ChannelSpec
    from modal_twin.diagnosis.record import record_from_blocks

    blk = SignalBlock(("temp", "R_P1_x"), FS, 0, np.ones((2, 10)))
    spec = [ChannelSpec("temp", "pressure", role="input", direction="x")]
    with pytest.raises(ConfigError, match=r"'temp' \(role input.*drives none of the model"):
        record_from_blocks([blk], source="t", channels=spec,
                           plant=load_model(BUILDING).plant())


def test_diagnosis_of_the_imported_record_finds_the_friction(bags: dict[str, Path]) -> None:
    from modal_twin.diagnosis.pipeline import diagnose
    from modal_twin.io.records import record_from_bag

    factory = load_model(BUILDING)
    plant = factory.plant()
    train = record_from_bag(bags["train"], plant=plant)
    test = record_from_bag(bags["test"], plant=plant)
    d = diagnose(factory, train, test, n_fit=1)
    assert d.found and d.found[0].family == "friction" and d.found[0].place == "ESB1"
    p = d.found[0].effect.params
    weight = factory.weight("ESB1")
    fk = p["Fk"] if "Fk" in p else p.get("mu_k", 0.0) * weight
    # 12 s records: the stick-slip fit lands within ~10 % (the demo's longer records pin it
    # to 0.2 %); what this test checks is that the user's record reaches the diagnosis
    assert fk == pytest.approx(0.04 * weight, rel=0.15)
    assert d.after[1].median_nrmse < d.before[1].median_nrmse / 5.0


def _median_over_noise(out: str) -> float:
    line = next(ln for ln in out.splitlines() if ln.startswith("median: NRMSE"))
    return float(line.split("(x")[1].split(")")[0])


def test_the_twin_residual_of_an_imported_record(bags: dict[str, Path],
                                                 capsys: pytest.CaptureFixture) -> None:
    # the nominal model beside its own response: at the noise floor
    assert main(["residual", str(BUILDING), str(bags["nominal"])]) == 0
    out = capsys.readouterr().out
    assert "inputs ax, ay; 66 channels compared" in out
    assert _median_over_noise(out) < 1.3
    # beside the S1 truth it lacks the friction: far above it, worst at ESB1
    assert main(["residual", str(BUILDING), str(bags["test"]), "--top", "3"]) == 0
    out = capsys.readouterr().out
    assert _median_over_noise(out) > 20.0
    assert "ESB1_f" in out.splitlines()[2]  # the worst channel is ESB1's force


LIVE_TOLERANCE_PP = 1e-9
"""|live - offline| per channel, percentage points of NRMSE and of Eq. (8): the twin node
runs the offline simulator block by block and scores the whole record with running sums,
so the two agree to round-off (the README states this tolerance)."""


def _live_against_offline(bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture,
                          name: str, rate: str = "4") -> tuple[str, float]:
    """Run ``residual`` offline and ``--live``; the live output and max |live - offline|."""
    import json

    table, live_table = tmp_path / f"{name}_offline.json", tmp_path / f"{name}_live.json"
    assert main(["residual", str(BUILDING), str(bag), "--json", str(table)]) == 0
    offline = json.loads(table.read_text())
    capsys.readouterr()
    assert main(["residual", str(BUILDING), str(bag), "--live", "--rate", rate,
                 "--run-dir", str(tmp_path / name), "--top", "3",
                 "--json", str(live_table)]) == 0
    out = capsys.readouterr().out
    live = json.loads(live_table.read_text())
    assert set(live) == set(offline) and "R_P1_x" in live  # roof_corner_x by its place
    worst = max(100 * abs(live[c][k] - offline[c][k]) for c in offline for k in ("nrmse", "eq8"))
    return out, worst


def test_a_twin_node_on_the_replayed_imported_record(bags: dict[str, Path], tmp_path: Path,
                                                     capsys: pytest.CaptureFixture) -> None:
    """Live: the bag replayed (its latched channel map carries the roles) into a twin node.

    Known answer: the node runs the same model on the same two measured inputs as the
    offline simulation, every block in order, scored over the whole record, so its
    per-channel NRMSE and Eq. (8) are the offline ones to round-off.
    """
    out, worst = _live_against_offline(bags["test"], tmp_path, capsys, "live")
    assert "samples 0..11999: 12000 of the record's 12000 samples" in out
    assert "the whole record" in out
    rows = out.splitlines()
    head = next(i for i, ln in enumerate(rows) if ln.startswith("channel"))
    assert rows[head + 1].startswith("ESB1_f")  # the worst channel printed first
    assert "twin node: inputs ground_x -> ax, ground_y -> ay; 66 channels compared" in out
    assert worst <= LIVE_TOLERANCE_PP
    from modal_twin.commands.residual import last_metrics
    from modal_twin.io.convert import metrics_span

    m = last_metrics(tmp_path / "live" / "bag")  # the run's record ends on the whole record
    assert metrics_span(m) == (0, 11999) and m.samples == 12000
    log = (tmp_path / "live" / "logs" / "twin.log").read_text()
    assert "ground_x -> ax, ground_y -> ay" in log and "held at zero: az, arx, ary, arz" in log


def reblocked(bag: Path, out: Path, block_s: float) -> Path:
    """The imported record of ``bag`` written again in blocks of ``block_s`` seconds."""
    from modal_twin.io.bag import read_blocks
    from modal_twin.io.channel_map import read_channel_map
    from modal_twin.io.imported import write_imported
    from modal_twin.signal_block import concatenate_blocks

    whole = concatenate_blocks(read_blocks(bag, "/measurement/frames"))
    return write_imported(out, whole, read_channel_map(bag), block_s=block_s)


@pytest.fixture
def busy_loops() -> Iterator[list[subprocess.Popen[bytes]]]:
    """Two CPU-burning processes (the machine under load), ended after the test."""
    procs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(2)]
    try:
        yield procs
    finally:
        for proc in procs:
            proc.kill()
            proc.wait()


def test_the_live_twin_beside_busy_loops_gives_the_offline_figures(
        bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture,
        busy_loops: list[subprocess.Popen[bytes]]) -> None:
    """Under load, in 240 blocks replayed as fast as the twin answers (rate 100, up to
    100 blocks ahead of its answers): the same figures.

    Known answer: the offline residual of the same bag, to round-off; the twin's log says
    that no block was dropped and no sample is missing.
    """
    bag = reblocked(bags["test"], tmp_path / "small", 0.05)  # 240 blocks: pacing at work
    out, worst = _live_against_offline(bag, tmp_path, capsys, "busy", rate="100")
    assert all(proc.poll() is None for proc in busy_loops)  # they burned throughout
    assert "12000 of the record's 12000 samples (0..11999) compared -- the whole record" in out
    assert worst <= LIVE_TOLERANCE_PP
    # the twin's own count and the replay's, as the command prints them
    assert ("twin node: samples 0..11999: 12000 compared, 0 missing; blocks dropped 0, gaps 0, "
            "trimmed 0, restarts 0; replay: 240 of 240 blocks answered on /twin/residual") in out


def test_a_live_twin_that_refuses_the_record_is_said_not_hidden(
        bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """A model none of the record's inputs drives (the trailer car): the twin refuses every
    frame; the replay waits for answers, says the consumer stalled, and the command exits 1
    naming the twin's refusal instead of printing figures."""
    car = ROOT / "config" / "vehicles" / "trailer_car.yaml"
    assert main(["residual", str(car), str(bags["test"]), "--live",
                 "--run-dir", str(tmp_path / "refused")]) == 1
    err = capsys.readouterr().err
    assert "no metrics from the twin for the record's samples 0..11999 (12000)" in err
    assert "drives none of the model's inputs" in err
    replay_log = (tmp_path / "refused" / "logs" / "replay.log").read_text()
    assert "0 of 12 blocks answered on /twin/residual (the consumer stalled)" in replay_log
