"""``modal-twin campaign``: two bags in, a table, a JSON and a plot of the tracks out."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from modal_twin.io.bag import BagWriter
from modal_twin.io.convert import block_to_rosbags
from modal_twin.io.typestore import typestore
from modal_twin.signal_block import SignalBlock

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_campaign import CH, FS, modal_response  # noqa: E402

TOPIC, SB = "/measurement/frames", "modal_twin_msgs/msg/SignalBlock"


def write_bag(path: Path, y: np.ndarray, t0_s: float) -> None:
    """``y`` as 10 s blocks on /measurement/frames, clock starting at ``t0_s``."""
    st = typestore()
    n = int(10 * FS)
    with BagWriter(path, {TOPIC: SB}) as w:
        for k in range(y.shape[1] // n):
            stamp = int((t0_s + k * 10) * 1e9)
            blk = SignalBlock(CH, FS, k * n, y[:, k * n:(k + 1) * n], stamp_ns=stamp)
            w.write(TOPIC, stamp, st.serialize_cdr(block_to_rosbags(blk, st), SB))


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "modal_twin.cli", "campaign", *args],
                          capture_output=True, text=True, timeout=300, cwd=ROOT)


def test_campaign_over_two_bags(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    n = int(400 * FS)
    write_bag(tmp_path / "day1", modal_response((1.5, 4.0), n, rng), 1000.0)
    write_bag(tmp_path / "day2", modal_response((1.41, 4.0), n, rng), 90000.0)
    out = _cli(str(tmp_path / "day2"), str(tmp_path / "day1"), "--window", "200",
               "--f-range", "0.5,10", "--jobs", "1", "--out", str(tmp_path / "out"))
    assert out.returncode == 0, out.stderr
    assert "4 windows (0 failed), 2 mode tracks" in out.stdout
    with (tmp_path / "out" / "campaign.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 8
    track0 = [r for r in rows if r["track"] == "0"]
    assert [float(r["t_start_s"]) for r in track0] == [1000.0, 1200.0, 90000.0, 90200.0]
    f = np.array([float(r["f_hz"]) for r in track0])
    np.testing.assert_allclose(f, [1.5, 1.5, 1.41, 1.41], rtol=0.01)
    doc = json.loads((tmp_path / "out" / "campaign.json").read_text())
    assert doc["n_windows"] == 4
    assert doc["channels"] == list(CH)
    assert (tmp_path / "out" / "campaign.png").stat().st_size > 10_000
    # report of the campaign folder: the plot and each track's range over the events
    from modal_twin.cli import main

    assert main(["report", str(tmp_path / "out"), "--out", str(tmp_path / "c.html")]) == 0
    page = (tmp_path / "c.html").read_text()
    assert "<h2>Monitoring campaign</h2>" in page and 'alt="campaign"' in page
    row = page.split("<tr><td>0</td>")[1].split("</tr>")[0]
    cells = [c.split("<")[0] for c in row.split("<td>")[1:]]
    assert cells[0] == "4"
    np.testing.assert_allclose([float(cells[1]), float(cells[2])], [1.41, 1.5], rtol=0.01)
    again = ("--window", "400", "--f-range", "0.5,10", "--jobs", "1", "--out",
             str(tmp_path / "out"))
    kept = _cli(str(tmp_path / "day1"), *again)  # the outputs exist: refused, kept
    assert kept.returncode == 2
    assert kept.stderr.strip().endswith("campaign.csv exists; give --force to overwrite it")
    assert json.loads((tmp_path / "out" / "campaign.json").read_text())["n_windows"] == 4
    forced = _cli(str(tmp_path / "day1"), *again, "--force")
    assert forced.returncode == 0, forced.stderr
    assert json.loads((tmp_path / "out" / "campaign.json").read_text())["n_windows"] == 1
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [
        "campaign.csv", "campaign.json", "campaign.png"]  # no temporary left


def test_campaign_bad_input_is_one_line_and_exit_2(tmp_path: Path) -> None:
    rng = np.random.default_rng(4)
    write_bag(tmp_path / "short", modal_response((1.5, 4.0), int(20 * FS), rng), 0.0)
    out = _cli(str(tmp_path / "short"), "--window", "100", "--jobs", "1")
    assert out.returncode == 2
    assert out.stderr.strip().splitlines() == [
        f"modal-twin campaign: window_s: expected at most the record's 20 s "
        f"({tmp_path / 'short'}), got 100.0"]
    out = _cli(str(tmp_path / "short"), "--orders", "8:40")
    assert out.returncode == 2
    assert "--orders: expected 3 numbers" in out.stderr
    out = _cli(str(tmp_path / "short"), "--jobs", "0")
    assert out.returncode == 2
    assert "executor: expected None, 'auto', 'serial', N >= 1" in out.stderr


def test_campaign_windows_stay_within_the_runs_of_a_damaged_bag(tmp_path: Path) -> None:
    """One malformed 10 s frame (200-210 s) of 40: windows of 90 s in each run, at their
    true times (1000 + 0, 90 and 1000 + 210, 300 s), none across the gap."""
    rng = np.random.default_rng(4)
    n = int(400 * FS)
    write_bag(tmp_path / "good", modal_response((1.5, 4.0), n, rng), 1000.0)
    from modal_twin.io.bag import read_raw

    with BagWriter(tmp_path / "bad", {TOPIC: SB}) as w:
        for k, (t, _, ts, raw) in enumerate(read_raw(tmp_path / "good")):
            w.write(t, ts, raw[:50] if k == 20 else raw)
    out = _cli(str(tmp_path / "bad"), "--window", "90", "--f-range", "0.5,10", "--jobs", "1",
               "--out", str(tmp_path / "out"))
    assert out.returncode == 0, out.stderr
    assert "skipped 1 of 40 messages" in out.stderr and "windows taken within each" in out.stderr
    doc = json.loads((tmp_path / "out" / "campaign.json").read_text())
    assert doc["n_windows"] == 4
    with (tmp_path / "out" / "campaign.csv").open() as fh:
        starts = sorted({float(r["t_start_s"]) for r in csv.DictReader(fh)})
    assert starts == [1000.0, 1090.0, 1210.0, 1300.0]


def test_campaign_puts_imported_events_at_their_real_times(shared_dir: Path,
                                                           tmp_path: Path) -> None:
    """Two Hayward events seven months apart: each at its header's UTC start, not at 0."""
    from datetime import UTC, datetime

    bags = []
    for event in ("2021-04-26", "2021-11-17"):
        z = shared_dir / "realdata" / "earthquakes" / f"csmip58658_hayward_bridge_{event}.zip"
        if not z.is_file():
            pytest.skip(f"{z} absent")
        bags.append(tmp_path / event)
        imp = subprocess.run([sys.executable, "-m", "modal_twin.cli", "import", str(z),
                              "--out", str(bags[-1])], capture_output=True, text=True,
                             timeout=300, cwd=ROOT)
        assert imp.returncode == 0, imp.stderr
    out = _cli(*map(str, reversed(bags)), "--window", "60", "--jobs", "1", "--out",
               str(tmp_path / "out"))
    assert out.returncode == 0, out.stderr
    # the V2 start lines: 4/26/21, 17:09:54.0 and 11/17/21, 19:43:20.0 UTC (GPS)
    starts = [datetime(2021, 4, 26, 17, 9, 54, tzinfo=UTC),
              datetime(2021, 11, 17, 19, 43, 20, tzinfo=UTC)]
    with (tmp_path / "out" / "campaign.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert sorted({float(r["t_start_s"]) for r in rows}) == [t.timestamp() for t in starts]
    assert sorted({r["t_start_utc"] for r in rows}) == [t.isoformat() for t in starts]
    doc = json.loads((tmp_path / "out" / "campaign.json").read_text())
    assert doc["n_windows"] == 2 and not doc["failed_windows"]
    assert "2021-04-26 17:09 to 2021-04-26 17:09 UTC" in out.stdout
    assert "2021-11-17 19:43 to 2021-11-17 19:43 UTC" in out.stdout


def test_campaign_takes_the_maps_outputs_and_a_short_record_whole(tmp_path: Path) -> None:
    """An imported 120 s record with a ground input and a reference beside its four
    outputs, no ``--window``: one window of the whole record (not a refusal of the default
    600 s), its outputs the map's role ``output`` (the input and the reference left out,
    said), the two modes of the truth (1.5 and 4 Hz) found."""
    from modal_twin.channels import ChannelSpec
    from modal_twin.io.imported import write_imported

    rng = np.random.default_rng(5)
    n = int(120 * FS)
    y = modal_response((1.5, 4.0), n, rng)
    names = ("ground", *CH, "deck_z")
    data = np.vstack([rng.standard_normal(n), y, 100.0 * rng.standard_normal(n)])
    roles = {"ground": "input", "deck_z": "reference"}
    chans = [ChannelSpec(c, "acceleration", role=roles.get(c, "output")) for c in names]
    write_imported(tmp_path / "rec", SignalBlock(names, FS, 0, data, stamp_ns=10**12), chans)
    out = _cli(str(tmp_path / "rec"), "--f-range", "0.5,10", "--jobs", "1", "--out",
               str(tmp_path / "out"))
    assert out.returncode == 0, out.stderr
    assert "outputs 4 of 6 channels, role 'output'" in out.stderr
    assert "(2 others left out: input, reference)" in out.stderr
    assert "one window of the whole record, 120 s" in out.stderr
    doc = json.loads((tmp_path / "out" / "campaign.json").read_text())
    assert doc["channels"] == list(CH)
    assert doc["n_windows"] == 1 and not doc["failed_windows"]
    f = sorted(float(r["f_hz"]) for r in doc["modes"])
    np.testing.assert_allclose(f, [1.5, 4.0], rtol=0.01)


def test_campaign_window_gives_the_modes_identify_gives(shared_dir: Path,
                                                       tmp_path: Path) -> None:
    """Hayward 2021-04-26 as one window: the modes ``identify`` reports on the record
    (the same call: outputs of role output, orders from the record), to 1e-9."""
    from modal_twin.identification.record import IdentifyOptions, identify_record
    from modal_twin.io.imported import read_imported

    z = shared_dir / "realdata" / "earthquakes" / "csmip58658_hayward_bridge_2021-04-26.zip"
    if not z.is_file():
        pytest.skip(f"{z} absent")
    bag = tmp_path / "h0426"
    imp = subprocess.run([sys.executable, "-m", "modal_twin.cli", "import", str(z), "--out",
                          str(bag)], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert imp.returncode == 0, imp.stderr
    out = _cli(str(bag), "--jobs", "1", "--out", str(tmp_path / "out"))
    assert out.returncode == 0, out.stderr
    doc = json.loads((tmp_path / "out" / "campaign.json").read_text())
    block, chans = read_imported(bag)
    want = identify_record(block, chans, IdentifyOptions()).modes.f_hz
    assert want.size >= 8
    np.testing.assert_allclose(sorted(float(r["f_hz"]) for r in doc["modes"]), np.sort(want),
                               rtol=1e-9)
