"""A display stream: per-channel means of short windows, each with its own time stamp.

The channel x sample arrays of ``SignalBlock`` are what the pipeline needs, but plotting
tools (PlotJuggler, Foxglove) plot one value per field and message. :class:`BlockMeans`
turns a stream of blocks into one sample per channel every ``1 / rate_hz`` s: the mean of
the window (a boxcar, the cheapest filter that needs no state but the unfinished window:
its first null sits at the display rate, so what would alias from there is attenuated),
stamped at the window's centre. Windows run across block boundaries; a gap or a restart
in the stream (the next block does not start where the last ended) starts a new window.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modal_twin._types import FloatArray, IntArray
from modal_twin.errors import OptionError
from modal_twin.signal_block import SignalBlock

__all__ = ["BlockMeans", "DisplaySamples"]


@dataclass(frozen=True, slots=True)
class DisplaySamples:
    """Window means: ``values`` (n_channels, n_windows) stamped ``stamps_ns`` (n_windows,)."""

    channel_names: tuple[str, ...]
    stamps_ns: IntArray
    values: FloatArray


class BlockMeans:
    """Means of windows of ``round(fs / rate_hz)`` samples of a block stream.

    Parameters
    ----------
    rate_hz : float
        Display rate, Hz (a window of at least one sample: never above the stream's rate).
    """

    def __init__(self, rate_hz: float) -> None:
        if not (np.isfinite(rate_hz) and 0.0 < rate_hz <= 1e4):
            msg = f"rate_hz: expected a display rate in (0, 10000] Hz, got {rate_hz!r}"
            raise OptionError(msg)
        self.rate_hz = float(rate_hz)
        self._names: tuple[str, ...] = ()
        self._fs = 0.0
        self._next = -1  # stream index the pending samples continue at
        self._pending = np.zeros((0, 0))
        self._start_ns = 0  # stamp of the first pending sample

    def push(self, block: SignalBlock) -> DisplaySamples:
        """Add a block; return the windows it completed (possibly none)."""
        if (block.channel_names != self._names or block.fs_hz != self._fs
                or block.first_index != self._next):
            self._names, self._fs = block.channel_names, block.fs_hz
            self._pending = np.zeros((len(block.channel_names), 0))
            self._start_ns = block.stamp_ns
        data = np.concatenate([self._pending, block.data], axis=1)
        n = max(1, round(block.fs_hz / self.rate_hz))
        k = data.shape[1] // n
        dt_ns = 1e9 / block.fs_hz
        # integer nanoseconds: an epoch stamp (~1.8e18) does not fit a float's 53 bits
        offsets = np.round((np.arange(k) * n + (n - 1) / 2.0) * dt_ns).astype(np.int64)
        stamps = np.int64(self._start_ns) + offsets
        values = data[:, : k * n].reshape(len(self._names), k, n).mean(axis=2)
        self._pending = data[:, k * n:]
        self._start_ns += round(k * n * dt_ns)
        self._next = block.next_index
        return DisplaySamples(self._names, stamps, values)
