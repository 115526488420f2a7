"""Blocks of multichannel samples: the unit in which signals travel between stages.

A block holds the channel names, the sample rate, the index of its first sample in the
stream (so that gaps and repeats are detected exactly) and the samples with channels on
the first axis and time on the last. It mirrors ``modal_twin_msgs/msg/SignalBlock``.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.errors import ShapeError, SignalError

__all__ = ["SignalBlock", "concatenate_blocks"]


@dataclass(frozen=True, slots=True)
class SignalBlock:
    """Samples of ``n_channels`` channels over ``n_samples`` instants.

    Attributes
    ----------
    channel_names : tuple of str
        Unique channel names, length ``n_channels``.
    fs_hz : float
        Sample rate in Hz (> 0).
    first_index : int
        Index of the first sample in its stream (>= 0).
    data : ndarray, shape (n_channels, n_samples)
        Samples in SI units.
    stamp_ns : int
        Time of the first sample in nanoseconds.
    source : str
        Producer (rig name, bag path ...).
    """

    channel_names: tuple[str, ...]
    fs_hz: float
    first_index: int
    data: FloatArray
    stamp_ns: int = 0
    source: str = ""
    _checked: bool = field(default=True, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not np.isfinite(self.fs_hz) or self.fs_hz <= 0:
            msg = f"fs_hz: expected a positive finite sample rate, got {self.fs_hz!r}"
            raise SignalError(msg)
        if self.first_index < 0:
            msg = f"first_index: expected >= 0, got {self.first_index}"
            raise SignalError(msg)
        data = np.asarray(self.data, dtype=np.float64)
        if data.ndim != 2 or data.shape[0] != len(self.channel_names):
            msg = (
                f"data: expected (n_channels, n_samples) with n_channels = "
                f"{len(self.channel_names)}, got {data.shape}"
            )
            raise ShapeError(msg)
        if len(set(self.channel_names)) != len(self.channel_names):
            dup = sorted({c for c in self.channel_names if self.channel_names.count(c) > 1})
            msg = f"channel_names: names must be unique, repeated {dup}"
            raise SignalError(msg)
        object.__setattr__(self, "data", data)
        object.__setattr__(self, "channel_names", tuple(self.channel_names))

    @property
    def n_channels(self) -> int:
        """Number of channels."""
        return int(self.data.shape[0])

    @property
    def n_samples(self) -> int:
        """Number of samples per channel."""
        return int(self.data.shape[1])

    @property
    def next_index(self) -> int:
        """Index of the sample that follows this block."""
        return self.first_index + self.n_samples

    def nonfinite(self) -> list[tuple[str, int]]:
        """Channels and stream indices of the first non-finite sample of each channel."""
        bad = ~np.isfinite(self.data)
        out: list[tuple[str, int]] = []
        for c in np.flatnonzero(bad.any(axis=1)):
            out.append((self.channel_names[c], self.first_index + int(np.argmax(bad[c]))))
        return out

    def select(self, names: tuple[str, ...] | list[str]) -> SignalBlock:
        """Block with only ``names``, in that order (SignalError names unknown ones)."""
        index = {n: i for i, n in enumerate(self.channel_names)}
        missing = [n for n in names if n not in index]
        if missing:
            msg = f"unknown channels {missing}; block has {list(self.channel_names)}"
            raise SignalError(msg)
        rows = [index[n] for n in names]
        return SignalBlock(
            tuple(names), self.fs_hz, self.first_index, self.data[rows], self.stamp_ns,
            self.source,
        )


def concatenate_blocks(blocks: list[SignalBlock]) -> SignalBlock:
    """Join consecutive blocks of one stream into one.

    Raises
    ------
    SignalError
        If the list is empty, channels or rates differ, or a block does not follow its
        predecessor (a gap or a repeat, named by its indices).
    """
    if not blocks:
        msg = "concatenate_blocks: no blocks given"
        raise SignalError(msg)
    first = blocks[0]
    for prev, blk in itertools.pairwise(blocks):
        if blk.channel_names != first.channel_names or blk.fs_hz != first.fs_hz:
            msg = "concatenate_blocks: channel names or sample rate change between blocks"
            raise SignalError(msg)
        if blk.first_index != prev.next_index:
            msg = (
                f"concatenate_blocks: block starting at sample {blk.first_index} does not "
                f"follow the one ending at {prev.next_index - 1}"
            )
            raise SignalError(msg)
    return SignalBlock(
        first.channel_names, first.fs_hz, first.first_index,
        np.concatenate([b.data for b in blocks], axis=1), first.stamp_ns, first.source,
    )
