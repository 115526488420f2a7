"""A damaged record gives its good part: bad messages skipped and counted, gaps kept as
gaps (never closed up), salvage reading on past a corrupt chunk."""

from __future__ import annotations

import logging
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from test_bag_integrity import _chunk_crcs

from modal_twin.io.bag import BagWriter, read_frames, read_raw, salvage, scan_mcap
from modal_twin.io.convert import block_to_rosbags
from modal_twin.io.imported import read_imported
from modal_twin.io.typestore import typestore
from modal_twin.signal_block import SignalBlock

SB = "modal_twin_msgs/msg/SignalBlock"
CM = "modal_twin_msgs/msg/ComparisonMetrics"
ROOT = Path(__file__).resolve().parents[2]


def _blocks(n: int, bs: int = 25) -> list[SignalBlock]:
    rng = np.random.default_rng(7)
    return [SignalBlock(("a", "b", "c"), 500.0, k * bs, rng.normal(size=(3, bs)),
                        stamp_ns=10**18 + k * 50_000_000) for k in range(n)]


def _write(path: Path, blocks: list[SignalBlock], *, bad: dict[int, bytes | None] | None = None,
           flush_every: int = 0, topic: str = "/measurement/frames") -> None:
    st = typestore()
    bad = bad or {}
    with BagWriter(path, {topic: SB}, flush_period_s=1e9) as w:
        for k, b in enumerate(blocks):
            raw = st.serialize_cdr(block_to_rosbags(b, st), SB)
            w.write(topic, b.stamp_ns, bad.get(k) or raw if k in bad else raw)
            if flush_every and k % flush_every == flush_every - 1:
                w.flush()


def test_a_malformed_frame_in_the_middle_leaves_a_gap_in_place(tmp_path: Path) -> None:
    blocks = _blocks(400)
    _write(tmp_path / "bag", blocks, bad={200: b"\x00\x01\x00\x00" + bytes(40)})
    fr = read_frames(tmp_path / "bag")
    assert fr.n_messages == 400 and [k for k, _, _ in fr.skipped] == [200]
    assert fr.gaps == ((200 * 25, 201 * 25),)  # exactly the lost frame's samples
    assert [(r.first_index, r.n_samples) for r in fr.runs] == [(0, 5000), (5025, 4975)]
    # the good samples are where they were: nothing shifted
    np.testing.assert_array_equal(fr.runs[1].data[:, :25], blocks[201].data)
    np.testing.assert_array_equal(fr.runs[0].data[:, -25:], blocks[199].data)
    note = fr.note(fr.longest)
    assert "skipped 1 of 400 messages (first #200, 10.000 s in:" in note
    assert "1 gap(s) of 25 samples (0.050 s) at samples 5000..5024" in note
    assert "using samples 0..4999" in note


def test_layout_changes_and_repeats_are_skipped_not_joined(tmp_path: Path) -> None:
    blocks = _blocks(10)
    st = typestore()
    odd = SignalBlock(("a", "b"), 500.0, 125, np.zeros((2, 25)), stamp_ns=blocks[5].stamp_ns)
    _write(tmp_path / "bag", [*blocks[:5], blocks[4], *blocks[5:]],
           bad={5: None})  # block 4 twice: a repeat
    fr = read_frames(tmp_path / "bag")
    assert len(fr.runs) == 1 and fr.runs[0].n_samples == 250 and not fr.gaps
    assert [why.split()[0] for _, _, why in fr.skipped] == ["repeats"]
    with BagWriter(tmp_path / "odd", {"/measurement/frames": SB}) as w:
        for b in [*blocks[:5], odd, *blocks[6:]]:
            w.write("/measurement/frames", b.stamp_ns,
                    st.serialize_cdr(block_to_rosbags(b, st), SB))
    fr = read_frames(tmp_path / "odd")
    assert "channels or rate differ" in fr.skipped[0][2]
    assert fr.gaps == ((125, 150),)
    nan = SignalBlock(("a", "b", "c"), 500.0, 75, blocks[3].data.copy(),
                      stamp_ns=blocks[3].stamp_ns)
    nan.data[1, 7] = np.nan
    with BagWriter(tmp_path / "nan", {"/measurement/frames": SB}) as w:
        for b in [*blocks[:3], nan, *blocks[4:]]:
            w.write("/measurement/frames", b.stamp_ns,
                    st.serialize_cdr(block_to_rosbags(b, st), SB))
    fr = read_frames(tmp_path / "nan")
    assert fr.skipped[0][0] == 3 and "non-finite sample in b at 82" in fr.skipped[0][2]
    assert fr.gaps == ((75, 100),)


def test_read_imported_gives_the_longest_run_and_says_so(tmp_path: Path,
                                                          caplog: pytest.LogCaptureFixture
                                                          ) -> None:
    blocks = _blocks(40)
    _write(tmp_path / "bag", blocks, bad={10: bytes(30)})
    with caplog.at_level(logging.WARNING):
        block, chans = read_imported(tmp_path / "bag")
    assert (block.first_index, block.n_samples) == (275, 29 * 25)
    np.testing.assert_array_equal(block.data[:, :25], blocks[11].data)
    assert [c.name for c in chans] == ["a", "b", "c"]
    assert "skipped 1 of 40 messages" in caplog.text and "using samples 275..999" in caplog.text


def _metrics(st, names: list[str], err: list[float]):
    T = st.types
    hdr = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=0, nanosec=0),
                                   frame_id="")
    a = np.asarray(err, dtype=np.float64)
    return T[CM](header=hdr, model_version="v1", window_s=1.0, channel_names=names,
                 rms_error=a, residual_rms=a, rms_measured=a, rms_predicted=a,
                 overall_rms_error=float(a.max(initial=0.0)), samples=10)


def test_a_malformed_metrics_message_does_not_break_the_report(tmp_path: Path) -> None:
    from modal_twin.commands.report import twin_metrics as report_metrics
    from modal_twin.commands.residual import last_metrics

    st = typestore()
    with BagWriter(tmp_path / "bag", {"/twin/metrics": CM}) as w:
        w.write("/twin/metrics", 1, st.serialize_cdr(_metrics(st, ["x", "y"], [1.0, 2.0]), CM))
        w.write("/twin/metrics", 2, b"\x00\x01\x00\x00garbage")  # does not decode
        w.write("/twin/metrics", 3, st.serialize_cdr(_metrics(st, ["x", "y"], [3.0, 4.0]), CM))
        w.write("/twin/metrics", 4, st.serialize_cdr(_metrics(st, ["x", "y"], [5.0]), CM))
    m = last_metrics(tmp_path / "bag")
    assert list(m.rms_error) == [3.0, 4.0]  # the last one that decodes and agrees
    m2, _ = report_metrics(tmp_path / "bag")
    assert list(m2.rms_error) == [3.0, 4.0]


def _chunks(f: Path) -> list[int]:
    """Offsets of the chunk records (from their CRC fields)."""
    return [off - 9 - 24 for off, _ in _chunk_crcs(f)]


@pytest.mark.parametrize("where", ["records", "one byte", "length"])
def test_salvage_reads_on_past_a_corrupt_chunk(tmp_path: Path, where: str) -> None:
    blocks = _blocks(825)
    _write(tmp_path / "bag", blocks, flush_every=50, topic="/rig/raw")  # 17 chunks
    f = next((tmp_path / "bag").glob("*.mcap"))
    chunks = _chunks(f)
    assert len(chunks) == 17
    data = bytearray(f.read_bytes())
    c = chunks[8]  # messages 400..449
    off = c + 1 if where == "length" else c + 9 + 300  # the length, or the records
    for i in {"records": range(64), "one byte": range(1), "length": range(8)}[where]:
        data[off + i] ^= 0xA5
    f.write_bytes(bytes(data))
    scan = scan_mcap(f)
    assert len(scan.messages) == 775
    if where != "length":
        assert scan.bad_chunks == 1 and scan.lost_messages == 50
        assert scan.lost_span_ns == (blocks[400].stamp_ns, blocks[449].stamp_ns)
    else:
        assert scan.skipped_bytes > 0
    info = salvage(tmp_path / "bag")
    assert info.message_count == 775
    fr = read_frames(info.path, "/rig/raw")
    assert fr.gaps == ((400 * 25, 450 * 25),)  # the lost chunk is a gap, in place
    np.testing.assert_array_equal(fr.runs[1].data[:, :25], blocks[450].data)


def test_salvage_of_a_cut_file_still_reads_to_the_cut(tmp_path: Path) -> None:
    _write(tmp_path / "bag", _blocks(100), flush_every=20, topic="/rig/raw")
    f = next((tmp_path / "bag").glob("*.mcap"))
    c = _chunks(f)[3]
    f.write_bytes(f.read_bytes()[: c + 100])  # cut inside the fourth chunk
    scan = scan_mcap(f)
    assert len(scan.messages) == 60 and scan.cut and scan.bad_chunks == 0


@pytest.mark.slow
def test_residual_and_identify_on_a_record_with_a_malformed_frame(tmp_path: Path) -> None:
    """The truth model on its own record: 0 % error on the good part, as on the whole."""
    sys.path.insert(0, str(ROOT / "test"))
    from conftest import write_frames_bag

    from modal_twin.models.loading import load_model

    model = ROOT / "config" / "structures" / "building.yaml"
    plant = load_model(model).plant()
    write_frames_bag(tmp_path / "good", plant, seconds=16.0, scale=(0.5,) * 6, seed=3,
                     block=67)
    msgs = list(read_raw(tmp_path / "good"))
    with BagWriter(tmp_path / "bad", {"/measurement/frames": SB}) as w:
        for k, (t, _, ts, raw) in enumerate(msgs):
            w.write(t, ts, raw[:60] if k == len(msgs) // 2 else raw)
    r = subprocess.run([sys.executable, "-m", "modal_twin.cli", "residual", str(model),
                        str(tmp_path / "bad"), "--json", str(tmp_path / "r.json")],
                       capture_output=True, text=True, check=False, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "Traceback" not in r.stderr
    assert f"skipped 1 of {len(msgs)} messages" in r.stderr
    assert "gap(s) of 67 samples" in r.stderr
    import json

    fig = json.loads((tmp_path / "r.json").read_text())
    assert max(v["nrmse"] for v in fig.values()) < 1e-6
    r = subprocess.run([sys.executable, "-m", "modal_twin.cli", "identify",
                        str(tmp_path / "bad"), "--out", str(tmp_path / "id")],
                       capture_output=True, text=True, check=False, cwd=tmp_path)
    # the analysis ran on the first 7.97 s (whether modes stand out there is identify's)
    assert r.returncode in (0, 1) and "Traceback" not in r.stderr, r.stderr
    assert "skipped 1 of" in r.stderr and "using samples 0..7972" in r.stderr
    assert "8.0 s at 1000 Hz" in r.stdout


def test_settling_time_of_a_run_after_a_gap_is_the_slowest_decay() -> None:
    """Two modes (2 Hz at 5 %, 7 Hz at 1 %): the slowest decay rate is zeta w of the second,
    sigma = 0.01 * 2 pi 7; 1 % is reached after ln(100) / sigma s."""
    from types import SimpleNamespace

    from modal_twin.io.records import settling_samples

    w = 2 * np.pi * np.array([2.0, 7.0])
    z = np.array([0.05, 0.01])
    sysm = SimpleNamespace(M=np.eye(2), K=np.diag(w**2), C=np.diag(2 * z * w))
    n = settling_samples(SimpleNamespace(system=sysm), 1000.0)
    assert n == int(np.ceil(np.log(100.0) / (0.01 * w[1]) * 1000.0))
    undamped = SimpleNamespace(M=np.eye(1), K=np.eye(1), C=np.zeros((1, 1)))
    assert settling_samples(SimpleNamespace(system=undamped), 1000.0) >= 2**62
