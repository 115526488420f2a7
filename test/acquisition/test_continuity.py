from __future__ import annotations

import numpy as np

from modal_twin.acquisition.continuity import StreamMonitor, Verdict
from modal_twin.signal_block import SignalBlock

CH = ("a", "b")


def blk(i0: int, n: int = 10, ch: tuple[str, ...] = CH, fs: float = 100.0) -> SignalBlock:
    data = np.arange(i0, i0 + n, dtype=float)[None, :].repeat(len(ch), 0)
    return SignalBlock(ch, fs, i0, data, stamp_ns=int(i0 / fs * 1e9))


def test_contiguous_gap_overlap_repeat() -> None:
    m = StreamMonitor()
    assert m.check(blk(0)).verdict is Verdict.OK
    assert m.check(blk(10)).verdict is Verdict.OK
    g = m.check(blk(25))
    assert g.verdict is Verdict.GAP
    assert g.missing == 5
    assert "samples 20..24 (5) missing" in g.message
    o = m.check(blk(30))  # samples 30..34 seen already
    assert o.verdict is Verdict.OVERLAP
    assert o.block is not None
    assert o.block.first_index == 35
    assert o.block.n_samples == 5
    np.testing.assert_array_equal(o.block.data[0], np.arange(35, 40))
    assert o.block.stamp_ns == int(0.35e9)
    r = m.check(blk(30))
    assert r.verdict is Verdict.REPEAT
    assert r.block is None
    assert m.next_index == 40
    assert m.missing_samples == 5


def test_bad_blocks_are_dropped_with_reasons() -> None:
    m = StreamMonitor(expected_channels=CH)
    assert m.check(blk(0)).verdict is Verdict.OK
    w = m.check(blk(10, ch=("a", "b", "zz")))
    assert w.verdict is Verdict.LAYOUT
    assert "unknown ['zz']" in w.message
    bad = blk(10)
    bad.data[1, 3] = np.nan
    n = m.check(bad)
    assert n.verdict is Verdict.NONFINITE
    assert "b at sample 13" in n.message
    assert m.check(SignalBlock(CH, 100.0, 10, np.zeros((2, 0)))).verdict is Verdict.EMPTY
    assert m.check(blk(10)).verdict is Verdict.OK  # the stream goes on
    m2 = StreamMonitor()
    m2.check(blk(0))
    v = m2.check(blk(10, fs=200.0))
    assert v.verdict is Verdict.LAYOUT and "sample rate 200.0 Hz" in v.message
    assert m.counts[Verdict.LAYOUT] == 1
    assert m.counts[Verdict.NONFINITE] == 1


def test_stray_first_block_does_not_poison_the_stream() -> None:
    m = StreamMonitor()
    assert m.check(blk(0, ch=("stray",))).verdict is Verdict.OK  # locks onto it
    assert m.check(blk(0)).verdict is Verdict.LAYOUT
    assert m.check(blk(10)).verdict is Verdict.LAYOUT
    v = m.check(blk(20))  # third block of the new layout in a row: follow it
    assert v.block is not None and "layout changed" in v.message
    assert m.check(blk(30)).verdict is Verdict.OK


def test_a_stream_that_starts_again_at_zero_is_a_restart() -> None:
    m = StreamMonitor()
    for k in range(5):
        m.check(blk(10 * k))
    v = m.check(blk(0))
    assert v.verdict is Verdict.RESTART
    assert v.block is not None
    assert "restarted at sample 0 (was at 50)" in v.message
    assert m.check(blk(10)).verdict is Verdict.OK
