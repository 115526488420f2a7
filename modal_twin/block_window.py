"""The last seconds of one contiguous stream of signal blocks (a node's sliding window)."""

from __future__ import annotations

import collections

from modal_twin.errors import SignalError
from modal_twin.signal_block import SignalBlock, concatenate_blocks
from modal_twin.validation import MEMORY_BUDGET_BYTES, check_array_budget

__all__ = ["BlockWindow"]


class BlockWindow:
    """Keep the last ``window_s`` seconds of a stream of :class:`SignalBlock`.

    A block that does not follow the previous one (a gap or repeat of the sample index, a
    new channel layout or sample rate) restarts the window: a window is always one
    contiguous record. The window's size is checked against the memory budget before a
    block is kept.

    Parameters
    ----------
    window_s : float
        Seconds kept (> 0).
    name : str
        What the blocks are, for messages (``"frames"``).
    budget_bytes : int
        Largest float64 window allowed.
    """

    def __init__(self, window_s: float, name: str = "blocks",
                 budget_bytes: int = MEMORY_BUDGET_BYTES) -> None:
        if not window_s > 0 or window_s == float("inf"):
            msg = f"window_s: expected a finite value > 0, got {window_s!r}"
            raise SignalError(msg)
        self.window_s = float(window_s)
        self.name = name
        self.budget_bytes = budget_bytes
        self.blocks: collections.deque[SignalBlock] = collections.deque()
        self.n_samples = 0
        self.n_received = 0

    def clear(self) -> None:
        """Forget every block."""
        self.blocks.clear()
        self.n_samples = 0

    def follows(self, blk: SignalBlock) -> bool:
        """Tell whether ``blk`` continues the window (or the window is empty)."""
        if not self.blocks:
            return True
        last = self.blocks[-1]
        return (blk.channel_names == last.channel_names and blk.fs_hz == last.fs_hz
                and blk.first_index == last.next_index)

    def add(self, blk: SignalBlock) -> bool:
        """Append ``blk``, dropping the oldest blocks beyond ``window_s``.

        Returns False when the block restarted the window (discontinuity), else True.

        Raises
        ------
        OptionError
            The window of this stream would exceed the memory budget (nothing changed).
        """
        keep = int(self.window_s * blk.fs_hz)
        check_array_budget((blk.n_channels, keep + blk.n_samples),
                           f"{self.name}: window_s x sample rate x channels",
                           self.budget_bytes)
        continued = self.follows(blk)
        if not continued:
            self.clear()
        self.blocks.append(blk)
        self.n_samples += blk.n_samples
        self.n_received += blk.n_samples
        while self.blocks and self.n_samples - self.blocks[0].n_samples >= keep:
            self.n_samples -= self.blocks.popleft().n_samples
        return continued

    def joined(self, last_s: float = 0.0) -> SignalBlock:
        """Return the window as one block; ``last_s > 0``: only its last ``last_s`` seconds.

        Raises
        ------
        SignalError
            The window is empty.

        """
        if not self.blocks:
            msg = f"no {self.name} received yet"
            raise SignalError(msg)
        blk = concatenate_blocks(list(self.blocks))
        if not last_s > 0:
            return blk
        n = min(blk.n_samples, max(int(min(last_s, self.window_s) * blk.fs_hz), 1))
        skip = blk.n_samples - n
        return SignalBlock(blk.channel_names, blk.fs_hz, blk.first_index + skip,
                           blk.data[:, skip:], blk.stamp_ns + round(skip / blk.fs_hz * 1e9),
                           blk.source)
