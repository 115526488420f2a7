"""Bags: chunk CRCs written and checked, bad messages skipped, cut rotated campaigns salvaged."""

from __future__ import annotations

import logging
import struct
from pathlib import Path

import numpy as np
import pytest

from modal_twin.errors import BagError
from modal_twin.io.bag import BagWriter, bag_info, read_blocks, salvage
from modal_twin.io.convert import block_to_rosbags
from modal_twin.io.typestore import typestore
from modal_twin.signal_block import SignalBlock

SB = "modal_twin_msgs/msg/SignalBlock"


def _blocks(n: int, n_ch: int = 4, bs: int = 25) -> list[SignalBlock]:
    rng = np.random.default_rng(5)
    return [SignalBlock(tuple(f"c{i}" for i in range(n_ch)), 500.0, k * bs,
                        rng.normal(size=(n_ch, bs)), stamp_ns=10**18 + k * 50_000_000)
            for k in range(n)]


def _write(path: Path, blocks: list[SignalBlock], bad_at: tuple[int, ...] = (), **kw: object
           ) -> None:
    st = typestore()
    with BagWriter(path, {"/rig/raw": SB}, **kw) as w:  # type: ignore[arg-type]
        for k, b in enumerate(blocks):
            raw = st.serialize_cdr(block_to_rosbags(b, st), SB)
            w.write("/rig/raw", b.stamp_ns, raw[:40] if k in bad_at else raw)


def _chunk_crcs(f: Path) -> list[tuple[int, int]]:
    """(offset of the CRC field, CRC) of every chunk record of an MCAP file."""
    data = f.read_bytes()
    pos, out = 8, []
    while pos + 9 <= len(data):
        op, length = data[pos], struct.unpack_from("<Q", data, pos + 1)[0]
        if op == 0x06:
            out.append((pos + 9 + 24, struct.unpack_from("<I", data, pos + 9 + 24)[0]))
        if op == 0x0F:  # footer
            break
        pos += 9 + length
    return out


def test_chunks_carry_crcs_and_a_bit_flip_is_detected(tmp_path: Path) -> None:
    _write(tmp_path / "bag", _blocks(40), flush_period_s=0.0)
    f = next((tmp_path / "bag").glob("*.mcap"))
    crcs = _chunk_crcs(f)
    assert len(crcs) >= 10 and all(c != 0 for _, c in crcs)
    assert len(read_blocks(tmp_path / "bag", "/rig/raw")) == 40  # reader verifies: all fine
    data = bytearray(f.read_bytes())
    off = crcs[3][0] + 4 + 200  # inside the fourth chunk's records
    data[off] ^= 0x10
    f.write_bytes(bytes(data))
    with pytest.raises(BagError, match="checksum mismatch"):
        read_blocks(tmp_path / "bag", "/rig/raw")


def test_malformed_message_is_skipped_and_reported(tmp_path: Path,
                                                   caplog: pytest.LogCaptureFixture) -> None:
    blocks = _blocks(20)
    _write(tmp_path / "bag", blocks, bad_at=(7,))
    with caplog.at_level(logging.WARNING):
        back = read_blocks(tmp_path / "bag", "/rig/raw")
    assert [b.first_index for b in back] == [b.first_index for b in blocks if b.first_index != 175]
    assert "skipped 1 malformed message(s); first: #7" in caplog.text


def test_foreign_topic_type_is_one_clear_error(tmp_path: Path) -> None:
    st = typestore()
    with BagWriter(tmp_path / "bag", {"/rig/raw": "std_msgs/msg/String"}) as w:
        S = st.types["std_msgs/msg/String"]
        w.write("/rig/raw", 1, st.serialize_cdr(S(data="hello"), "std_msgs/msg/String"))
    with pytest.raises(BagError, match=r"holds std_msgs/msg/String, expected .*SignalBlock"):
        read_blocks(tmp_path / "bag", "/rig/raw")


def test_rotated_campaign_cut_by_sigkill_is_salvaged_as_one(tmp_path: Path) -> None:
    blocks = _blocks(60, n_ch=8, bs=200)
    _write(tmp_path / "bag", blocks, rotate_bytes=40_000, flush_period_s=0.0)
    parts = sorted((tmp_path / "bag").glob("part_*"))
    assert len(parts) >= 3
    last = parts[-1]
    (last / "metadata.yaml").unlink()  # SIGKILL during the last part
    f = next(last.glob("*.mcap"))
    f.write_bytes(f.read_bytes()[: int(f.stat().st_size * 0.7)])
    with pytest.raises(BagError, match=r"rotated parts \['part_\d+'\] .* bag salvage"):
        bag_info(tmp_path / "bag")
    info = salvage(tmp_path / "bag")
    back = read_blocks(info.path, "/rig/raw")
    idx = [b.first_index for b in back]
    assert idx == [b.first_index for b in blocks[: len(idx)]]  # every part, in order
    assert len(idx) > 60 * (len(parts) - 1) / len(parts) - 5
    for a, b in zip(blocks, back, strict=False):
        np.testing.assert_array_equal(a.data, b.data)
