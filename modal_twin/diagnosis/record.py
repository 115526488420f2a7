"""A test record: measured inputs and responses of one run, as one contiguous array."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.channels import ChannelSpec
from modal_twin.errors import ShapeError, SignalError
from modal_twin.models.plant import Plant
from modal_twin.models.sensors import route_channels
from modal_twin.signal_block import SignalBlock, concatenate_blocks

__all__ = ["Record", "record_from_blocks"]


@dataclass(frozen=True, slots=True)
class Record:
    """Inputs (n_in, nt) and measured channels (n_ch, nt) sampled at ``fs_hz``.

    The first ``skip`` samples are simulated (they set the state) but not scored: a
    held-out segment cut from a longer run starts where the structure was already moving.
    ``noise_floor`` is the record's noise model, once estimated (per channel, a fraction of
    its RMS: :func:`.judge.record_noise_floors`); the fits whiten their residual by it
    (:func:`.fitting.channel_scale`). None: not estimated.
    """

    fs_hz: float
    input_names: tuple[str, ...]
    inputs: FloatArray
    channel_names: tuple[str, ...]
    data: FloatArray
    source: str = ""
    skip: int = 0
    noise_floor: FloatArray | None = None

    def __post_init__(self) -> None:
        if self.inputs.shape != (len(self.input_names), self.data.shape[-1]):
            msg = (f"inputs: expected ({len(self.input_names)}, {self.data.shape[-1]}), got "
                   f"{self.inputs.shape}")
            raise ShapeError(msg)
        if self.data.shape[0] != len(self.channel_names):
            msg = f"data: expected {len(self.channel_names)} rows, got {self.data.shape[0]}"
            raise ShapeError(msg)
        if self.data.shape[-1] < 2:
            msg = f"record {self.source!r}: too short ({self.data.shape[-1]} samples)"
            raise SignalError(msg)
        if not 0 <= self.skip < self.data.shape[-1] - 1:
            msg = f"skip: expected 0 <= skip < {self.data.shape[-1] - 1}, got {self.skip}"
            raise ShapeError(msg)
        n_ch = len(self.channel_names)
        if self.noise_floor is not None and np.shape(self.noise_floor) != (n_ch,):
            msg = f"noise_floor: expected ({n_ch},), got {np.shape(self.noise_floor)}"
            raise ShapeError(msg)
        for name, arr in (("inputs", self.inputs), ("data", self.data)):
            if not np.all(np.isfinite(arr)):
                msg = f"record {self.source!r}: non-finite samples in {name}"
                raise SignalError(msg)

    @property
    def n_samples(self) -> int:
        """Samples per channel."""
        return int(self.data.shape[-1])

    @property
    def scored(self) -> FloatArray:
        """The measured samples that count (after ``skip``)."""
        return self.data[:, self.skip:]

    def with_channels(self, names: list[str] | tuple[str, ...]) -> Record:
        """Return the same record restricted to ``names`` (in that order), its noise model too."""
        data, floor = self.channels(names), None
        if self.noise_floor is not None:
            idx = {n: i for i, n in enumerate(self.channel_names)}
            floor = np.asarray(self.noise_floor)[[idx[n] for n in names]]
        return Record(self.fs_hz, self.input_names, self.inputs, tuple(names), data,
                      self.source, self.skip, floor)

    def with_noise_floor(self, floor: FloatArray | None) -> Record:
        """Return the same record with its noise model ``floor`` (per channel, fraction of RMS)."""
        return Record(self.fs_hz, self.input_names, self.inputs, self.channel_names, self.data,
                      self.source, self.skip,
                      None if floor is None else np.asarray(floor, float))

    def channels(self, names: list[str] | tuple[str, ...]) -> FloatArray:
        """Rows of ``data`` for ``names`` (SignalError names the unknown ones)."""
        idx = {n: i for i, n in enumerate(self.channel_names)}
        missing = [n for n in names if n not in idx]
        if missing:
            msg = f"record {self.source!r} lacks channels {missing[:6]}"
            raise SignalError(msg)
        return self.data[[idx[n] for n in names]]

    def segment(self, start: int, stop: int, *, warmup: bool = False) -> Record:
        """Return samples ``start:stop`` as a new record.

        With ``warmup`` the samples before ``start`` are kept to be simulated but not scored
        (``skip = start``).
        """
        first = 0 if warmup else start
        return Record(self.fs_hz, self.input_names, self.inputs[:, first:stop],
                      self.channel_names, self.data[:, first:stop],
                      f"{self.source}[{start}:{stop}]", start - first)


def record_from_blocks(blocks: list[SignalBlock], *, source: str = "",
                       channels: Sequence[ChannelSpec] | None = None,
                       plant: Plant | None = None) -> Record:
    """Join measurement frames into a record.

    Without ``channels``, channels ``table_<x>`` become the inputs (named ``<x>``), the rest
    the measured channels. With a channel map (``channels``: an imported bag's), the roles
    decide: ``input`` channels drive the model input :func:`model_input_of` names (any
    subset of the model's inputs; the others are zero), ``output`` / ``device_*`` channels
    are the measured ones, named as the ``plant``'s channel at the same place, direction and
    quantity when there is one; ``reference`` channels are left out
    (:func:`~modal_twin.models.sensors.route_channels`).

    Raises
    ------
    SignalError
        Gaps between frames (named by sample index), or no input channel.
    ConfigError
        An input channel that drives none of the ``plant``'s inputs.
    """
    blk = concatenate_blocks(blocks)
    model = plant if channels is not None else None  # without a map: the naming rule
    route = route_channels(blk.channel_names, channels,
                           model.input_names if model is not None else None,
                           model.channels if model is not None else (),
                           source=f"record {source!r}")
    if not route.inputs:
        what = "with role input" if channels is not None else "table_*"
        msg = f"record {source!r}: no input channel ({what}) among the frames"
        raise SignalError(msg)
    row = {n: i for i, n in enumerate(blk.channel_names)}
    return Record(blk.fs_hz, tuple(t for _, t in route.inputs),
                  blk.data[[row[n] for n, _ in route.inputs]],
                  tuple(t for _, t in route.outputs),
                  blk.data[[row[n] for n, _ in route.outputs]], source)
