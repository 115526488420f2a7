"""Stream continuity: gaps, repeats, channel-layout changes and non-finite samples.

Each :class:`SignalBlock` carries the index of its first sample, so a gap or a repeat is
known exactly. :class:`StreamMonitor` checks each block against the stream so far and says
what to do with it; it never raises on bad data (a node must not crash on it).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

from modal_twin.signal_block import SignalBlock

__all__ = ["BlockVerdict", "StreamMonitor", "Verdict"]


class Verdict(Enum):
    """What a block is, relative to the stream."""

    OK = "ok"
    GAP = "gap"  # samples missing before this block (kept, gap reported)
    OVERLAP = "overlap"  # repeats part of the stream (repeated head trimmed)
    REPEAT = "repeat"  # nothing new (dropped)
    LAYOUT = "layout"  # channels or rate differ from the stream (dropped)
    NONFINITE = "nonfinite"  # NaN or Inf samples (dropped)
    EMPTY = "empty"  # no samples (dropped)
    RESTART = "restart"  # the stream jumps back (a new run or a replay)


@dataclass(frozen=True, slots=True)
class BlockVerdict:
    """Outcome of :meth:`StreamMonitor.check`: the block to pass on (or None) and why."""

    verdict: Verdict
    block: SignalBlock | None
    message: str = ""
    missing: int = 0


class StreamMonitor:
    """Follow one stream of blocks; counts every kind of fault it sees."""

    def __init__(self, expected_channels: tuple[str, ...] | None = None, *,
                 relock_after: int = 3) -> None:
        self.expected = expected_channels
        self.relock_after = relock_after
        self._pending: tuple[tuple[str, ...], float] | None = None
        self._pending_n = 0
        self.layout: tuple[tuple[str, ...], float] | None = None
        self.next_index: int | None = None
        self.counts: dict[Verdict, int] = dict.fromkeys(Verdict, 0)
        self.missing_samples = 0

    def check(self, block: SignalBlock) -> BlockVerdict:
        """Classify ``block``; returns the part of it that extends the stream, if any.

        Without ``expected_channels`` the stream locks onto the first layout it sees; a
        different layout that then arrives ``relock_after`` times in a row is taken as the
        stream's new layout (a stray first block cannot poison the stream).
        """
        v = self._check(block)
        if v.verdict is Verdict.LAYOUT and self.expected is None:
            layout = (block.channel_names, block.fs_hz)
            self._pending_n = self._pending_n + 1 if layout == self._pending else 1
            self._pending = layout
            if self._pending_n >= self.relock_after:
                self.layout, self.next_index = None, None
                self._pending, self._pending_n = None, 0
                v = self._check(block)
                v = BlockVerdict(v.verdict if v.verdict is not Verdict.OK else Verdict.GAP,
                                 v.block, f"stream layout changed to {block.n_channels} "
                                 f"channels at {block.fs_hz} Hz; following it", v.missing)
        elif v.block is not None:
            self._pending, self._pending_n = None, 0
        self.counts[v.verdict] += 1
        if v.block is not None:
            self.next_index = v.block.next_index
        return v

    def _check(self, block: SignalBlock) -> BlockVerdict:
        if block.n_samples == 0:
            return BlockVerdict(Verdict.EMPTY, None, f"empty block at sample {block.first_index}")
        layout = (block.channel_names, block.fs_hz)
        want = self.expected if self.expected is not None else (
            self.layout[0] if self.layout is not None else None)
        if want is not None and block.channel_names != want:
            unknown = [c for c in block.channel_names if c not in want]
            missing = [c for c in want if c not in block.channel_names]
            return BlockVerdict(
                Verdict.LAYOUT,
                None,
                f"block at sample {block.first_index} has {block.n_channels} channels "
                f"(expected {len(want)}); unknown {unknown[:8]}, missing {missing[:8]}"
                + ("" if unknown or missing else " (order differs)"),
            )
        if self.layout is not None and block.fs_hz != self.layout[1]:
            return BlockVerdict(
                Verdict.LAYOUT,
                None,
                f"block at sample {block.first_index}: sample rate {block.fs_hz} Hz, the "
                f"stream runs at {self.layout[1]} Hz",
            )
        bad = block.nonfinite()
        if bad:
            where = ", ".join(f"{c} at sample {i}" for c, i in bad[:4])
            return BlockVerdict(Verdict.NONFINITE, None, f"non-finite samples: {where}")
        self.layout = layout
        if self.next_index is None or block.first_index == self.next_index:
            return BlockVerdict(Verdict.OK, block)
        if block.first_index < self.next_index // 2:  # far back: a new run or a replay
            return BlockVerdict(Verdict.RESTART, block,
                                f"stream restarted at sample {block.first_index} "
                                f"(was at {self.next_index})")
        if block.first_index > self.next_index:
            n = block.first_index - self.next_index
            self.missing_samples += n
            return BlockVerdict(
                Verdict.GAP,
                block,
                f"gap: samples {self.next_index}..{block.first_index - 1} ({n}) missing",
                n,
            )
        if block.next_index <= self.next_index:
            return BlockVerdict(
                Verdict.REPEAT,
                None,
                f"repeated block: samples {block.first_index}..{block.next_index - 1} seen",
            )
        cut = self.next_index - block.first_index
        trimmed = SignalBlock(
            block.channel_names,
            block.fs_hz,
            self.next_index,
            block.data[:, cut:],
            block.stamp_ns + round(cut / block.fs_hz * 1e9),
            block.source,
        )
        return BlockVerdict(
            Verdict.OVERLAP,
            trimmed,
            f"overlap: {cut} repeated samples from {block.first_index} trimmed",
        )
