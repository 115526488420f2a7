"""Bag writer, reader, info and salvage without ROS processes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from modal_twin.errors import BagError
from modal_twin.io.bag import BagWriter, bag_info, read_blocks, read_messages, salvage
from modal_twin.io.convert import block_to_rosbags
from modal_twin.io.typestore import typestore
from modal_twin.signal_block import SignalBlock

SB = "modal_twin_msgs/msg/SignalBlock"


def _blocks(n: int, n_ch: int = 4, bs: int = 25) -> list[SignalBlock]:
    rng = np.random.default_rng(3)
    return [
        SignalBlock(tuple(f"c{i}" for i in range(n_ch)), 500.0, k * bs,
                    rng.normal(size=(n_ch, bs)), stamp_ns=10**18 + k * 50_000_000,
                    source="unit")
        for k in range(n)
    ]


def _write(path: Path, blocks: list[SignalBlock], **kw: object) -> None:
    st = typestore()
    with BagWriter(path, {"/rig/raw": SB}, **kw) as w:  # type: ignore[arg-type]
        for b in blocks:
            w.write("/rig/raw", b.stamp_ns, st.serialize_cdr(block_to_rosbags(b, st), SB))


def test_blocks_round_trip_exactly(tmp_path: Path) -> None:
    blocks = _blocks(40)
    _write(tmp_path / "bag", blocks)
    back = read_blocks(tmp_path / "bag", "/rig/raw")
    assert len(back) == len(blocks)
    for a, b in zip(blocks, back, strict=True):
        assert a.channel_names == b.channel_names
        assert a.first_index == b.first_index
        assert a.stamp_ns == b.stamp_ns
        assert a.fs_hz == b.fs_hz
        assert a.source == b.source
        np.testing.assert_array_equal(a.data, b.data)


def test_bag_opens_with_mcap_reader_and_info(tmp_path: Path) -> None:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    blocks = _blocks(12)
    _write(tmp_path / "bag", blocks)
    mcap_file = next((tmp_path / "bag").glob("*.mcap"))
    with mcap_file.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        decoded = [m for _, _, _, m in reader.iter_decoded_messages()]
    assert [m.first_sample_index for m in decoded] == [b.first_index for b in blocks]
    np.testing.assert_array_equal(np.asarray(decoded[5].data), blocks[5].data.ravel())
    info = bag_info(tmp_path / "bag")
    assert [(t.name, t.msgtype, t.count) for t in info.topics] == [("/rig/raw", SB, 12)]
    assert info.duration_s == pytest.approx(11 * 0.05)


def test_rotation_splits_into_parts_read_as_one(tmp_path: Path) -> None:
    blocks = _blocks(30, n_ch=8, bs=200)
    _write(tmp_path / "bag", blocks, rotate_bytes=40_000, flush_period_s=0.0)
    info = bag_info(tmp_path / "bag")
    assert len(info.parts) > 1
    back = read_blocks(tmp_path / "bag", "/rig/raw")
    assert [b.first_index for b in back] == [b.first_index for b in blocks]


def test_salvage_recovers_flushed_messages(tmp_path: Path) -> None:
    blocks = _blocks(50)
    _write(tmp_path / "bag", blocks, flush_period_s=0.0)  # every message flushed
    (tmp_path / "bag" / "metadata.yaml").unlink()
    f = next((tmp_path / "bag").glob("*.mcap"))
    data = f.read_bytes()
    f.write_bytes(data[: int(len(data) * 0.8)])  # cut as SIGKILL would
    with pytest.raises(BagError, match="cut off while recording"):
        bag_info(tmp_path / "bag")
    info = salvage(tmp_path / "bag")
    back = read_blocks(info.path, "/rig/raw")
    assert 30 <= len(back) < 50
    for a, b in zip(blocks, back, strict=False):
        np.testing.assert_array_equal(a.data, b.data)


def test_bad_bags_give_clear_errors(tmp_path: Path) -> None:
    with pytest.raises(BagError, match="no such bag"):
        bag_info(tmp_path / "missing")
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "x.mcap").write_bytes(b"this is not mcap at all")
    with pytest.raises(BagError, match="not an MCAP file"):
        salvage(foreign)
    (tmp_path / "plain.txt").write_text("hello")
    with pytest.raises(BagError, match="is a file"):
        bag_info(tmp_path / "plain.txt")
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(BagError, match="not a rosbag2 bag"):
        list(read_messages(empty))
    with pytest.raises(BagError, match="unknown message type"):
        BagWriter(tmp_path / "b2", {"/x": "nope_msgs/msg/Nope"})


def test_truncated_before_first_chunk_is_named(tmp_path: Path) -> None:
    _write(tmp_path / "bag", _blocks(5), flush_period_s=1e9)
    (tmp_path / "bag" / "metadata.yaml").unlink()
    f = next((tmp_path / "bag").glob("*.mcap"))
    f.write_bytes(f.read_bytes()[:200])
    with pytest.raises(BagError, match="cut before its first complete chunk"):
        salvage(tmp_path / "bag")
