"""The acquisition's impact mode: streamed frames of a hammer test -> one FRF matrix.

A roving-hammer test streams the force of every hit point (one force channel per point,
zero while the hammer is elsewhere: the excitation's ``kind: impact`` drive) and the fixed
responses. :class:`HammerTest` keeps the frames in stream order and, when the test ends,
segments them into hits, rejects double hits and overloads (each counted and said), averages
the accepted hits of each point and returns the FRF matrix
(:func:`~modal_twin.acquisition.impact.roving_hammer_frf`, [000] section 2). Writing it
(UFF 58) is the io edge's job (:mod:`modal_twin.io.impact_files`).

Forces and responses are told apart by :func:`hammer_channels`; tests of other hit points
(one record each) join by :func:`merge_points`.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from modal_twin._types import ComplexArray, FloatArray
from modal_twin.acquisition.impact import Estimator, ImpactFRF, roving_hammer_frf
from modal_twin.channels import ChannelSpec
from modal_twin.errors import OptionError, SignalError
from modal_twin.signal_block import SignalBlock

__all__ = ["MOTION", "HammerResult", "HammerTest", "hammer_channels", "merge_points"]

_MAX_SAMPLES = 50_000_000
"""Samples kept at most (channels x time, ~400 MB): a longer test is refused, not grown."""


@dataclass(frozen=True, slots=True)
class HammerResult:
    """FRF matrix of a hammer test with the verdict on every hit.

    Attributes
    ----------
    H : (n_out, n_in, n_f) complex array
        Response per newton: column ``i`` from the hits at force channel ``inputs[i]``.
    coherence : (n_out, n_in, n_f) array
    inputs, outputs : tuple of ChannelSpec
    per_point : tuple of ImpactFRF
        Each point's estimate, its hits and their verdicts.
    """

    f_hz: FloatArray
    H: ComplexArray
    coherence: FloatArray
    inputs: tuple[ChannelSpec, ...]
    outputs: tuple[ChannelSpec, ...]
    per_point: tuple[ImpactFRF, ...]
    estimator: str
    block_s: float

    @property
    def n_accepted(self) -> int:
        """Hits averaged, over all points."""
        return sum(p.n_averages for p in self.per_point)

    @property
    def n_rejected(self) -> int:
        """Hits rejected (double hit or overload), over all points."""
        return sum(len(p.hits) - p.n_averages for p in self.per_point)

    def lines(self, most: int = 5) -> list[str]:
        """Return the counts, then per point the hits kept and (``most``) rejections' reasons."""
        out = [f"impact: {self.n_accepted} hits averaged, {self.n_rejected} rejected "
               f"({self.estimator}, {self.block_s:g} s blocks, "
               f"{len(self.inputs)} points x {len(self.outputs)} responses)"]
        for c, p in zip(self.inputs, self.per_point, strict=True):
            out.append(f"  point {c.name}: {p.n_averages} of {len(p.hits)} hits averaged")
            why = p.rejected()
            out.extend(f"    rejected {r}" for r in why[:most])
            if len(why) > most:
                out.append(f"    ... and {len(why) - most} more rejected")
        return out


MOTION = ("acceleration", "velocity", "displacement")
"""Response quantities of a hammer test."""


def hammer_channels(channels: Iterable[ChannelSpec]
                    ) -> tuple[list[ChannelSpec], list[ChannelSpec]]:
    """Force (hit point) and response channels of a map, in order.

    The forces are the channels of quantity ``force`` and role ``input`` or ``output``
    (not a device's load cell, ``device_force``; a record whose inputs are ground
    accelerations is no hammer test); the responses the other channels of role ``output``
    or of a motion quantity (a driving-point accelerometer that a UFF file's reference node
    marked ``input`` is a response here).
    """
    chans = list(channels)
    forces = [c for c in chans if c.quantity == "force"
              and c.effective_role in ("input", "output")]  # not a device's load cell
    resp = [c for c in chans if c not in forces
            and (c.effective_role == "output" or c.quantity in MOTION)]
    return forces, resp


def merge_points(results: Sequence[HammerResult]) -> HammerResult:
    """One FRF matrix from tests of the same responses at other hit points (columns joined).

    Raises
    ------
    SignalError
        The tests differ in responses, frequency lines or estimator.
    """
    first = results[0]
    for r in results[1:]:
        if [c.name for c in r.outputs] != [c.name for c in first.outputs]:
            msg = (f"impact: tests differ in responses ({[c.name for c in first.outputs]} "
                   f"and {[c.name for c in r.outputs]})")
            raise SignalError(msg)
        if r.f_hz.shape != first.f_hz.shape or not np.allclose(r.f_hz, first.f_hz):
            msg = "impact: tests differ in frequency lines (sample rate or block length)"
            raise SignalError(msg)
    return HammerResult(first.f_hz, np.concatenate([r.H for r in results], axis=1),
                        np.concatenate([r.coherence for r in results], axis=1),
                        tuple(c for r in results for c in r.inputs), first.outputs,
                        tuple(p for r in results for p in r.per_point), first.estimator,
                        first.block_s)


class HammerTest:
    """Frames of one hammer test kept in stream order, processed at the end.

    Parameters
    ----------
    channels : sequence of ChannelSpec
        The channel map (forces and responses found by :func:`hammer_channels`).
    block_s : float
        One hit's block (frequency resolution ``1 / block_s``); hits closer than that are
        double hits.
    estimator : {"H1", "H2", "Hv"}
    checks
        ``tau_s``, ``double_hit``, ``force_range``, ``trigger`` ... as
        :func:`~modal_twin.acquisition.impact.impact_frf`.
    """

    def __init__(self, channels: Sequence[ChannelSpec], *, block_s: float,
                 estimator: Estimator = "H1", **checks: float | None) -> None:
        forces, resp = hammer_channels(channels)
        if not forces or not resp:
            msg = (f"impact: expected force channels (quantity force) and responses, got "
                   f"{len(forces)} force and {len(resp)} response channels (quantities "
                   f"{sorted({c.quantity for c in channels})})")
            raise OptionError(msg)
        if not block_s > 0:
            msg = f"impact_block_s: expected > 0, got {block_s}"
            raise OptionError(msg)
        self.inputs, self.outputs = tuple(forces), tuple(resp)
        self.block_s, self.estimator, self.checks = block_s, estimator, checks
        self.fs_hz: float | None = None
        self._parts: list[FloatArray] = []
        self._next: int | None = None
        self.n_samples = 0
        self.gaps = 0

    def add(self, frame: SignalBlock) -> None:
        """Append a frame (it must hold every force and response channel).

        A frame that does not follow the previous one (a gap) is appended with zeros in
        between up to a second, so hit times stay right; a longer gap or another sample
        rate is an error.
        """
        names = [c.name for c in (*self.inputs, *self.outputs)]
        missing = [n for n in names if n not in frame.channel_names]
        if missing:
            msg = f"impact: frame lacks channels {missing[:5]}"
            raise SignalError(msg)
        if self.fs_hz is None:
            self.fs_hz = frame.fs_hz
        elif frame.fs_hz != self.fs_hz:
            msg = f"impact: sample rate changed from {self.fs_hz} to {frame.fs_hz} Hz"
            raise SignalError(msg)
        data = frame.select(names).data
        if self._next is not None and frame.first_index != self._next:
            gap = frame.first_index - self._next
            if gap < 0 or gap > self.fs_hz:
                msg = f"impact: frame at sample {frame.first_index}, expected {self._next}"
                raise SignalError(msg)
            self._parts.append(np.zeros((len(names), gap)))
            self.n_samples += gap
            self.gaps += 1
        if (self.n_samples + data.shape[1]) * len(names) > _MAX_SAMPLES:
            msg = f"impact: test longer than {_MAX_SAMPLES} samples kept; frame dropped"
            raise SignalError(msg)
        self._parts.append(data)
        self.n_samples += data.shape[1]
        self._next = frame.first_index + data.shape[1]

    def finish(self) -> HammerResult:
        """Hits found, checked and averaged per point (every rejection counted).

        Raises
        ------
        SignalError
            No frame, or a point without an accepted hit (the reasons named).
        """
        if self.fs_hz is None or not self._parts:
            msg = "impact: no frame received"
            raise SignalError(msg)
        x = np.concatenate(self._parts, axis=1)
        n_in = len(self.inputs)
        H, f, coh, per_point = roving_hammer_frf(
            x[:n_in], x[n_in:], self.fs_hz, block_s=self.block_s, estimator=self.estimator,
            **self.checks)
        return HammerResult(f, H, coh, self.inputs, self.outputs, per_point, self.estimator,
                            self.block_s)

