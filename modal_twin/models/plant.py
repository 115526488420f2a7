"""A plant: a reduced system plus the meaning of its inputs and measured channels.

The simulator returns outputs ``y`` (rows of C_out) and device forces; a structure's
measured channels are some of each (e.g. linear isolators' forces are rows of y, nonlinear
devices' forces come from their laws). :class:`Plant` keeps, per channel, where its value
comes from, so that a truth rig and a nominal twin with different device sets still
produce the same channels in the same order.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.channels import ChannelSpec
from modal_twin.errors import OptionError, ShapeError
from modal_twin.models.effects import EffectSpec
from modal_twin.models.reduced import ReducedSystem, SimResult

__all__ = ["DelayLine", "Plant", "with_sensor_effects"]

Source = tuple[Literal["y", "force"], int]


@dataclass(frozen=True, slots=True)
class Plant:
    """Reduced system with named inputs and channels.

    Attributes
    ----------
    system : ReducedSystem
    input_names : tuple of str
        Names of the base inputs (columns of Gamma), e.g. ``("ax", ..., "arz")``.
    input_quantities : tuple of str
        Quantity of each input (``acceleration``, ``angular_acceleration``,
        ``displacement``, ``velocity``): how a rig measures it.
    channels : tuple of ChannelSpec
        Measured channels in order.
    sources : tuple of (kind, row)
        Per channel: ``("y", i)`` row i of the outputs or ``("force", i)`` row i of the
        device forces.
    name : str
        Model name and version (e.g. ``building@nominal``).
    readout : (n_channels, n_channels) array, optional
        What the sensors report of the true channel values (identity when None): a
        sensor gain error scales a diagonal entry, an orientation error mixes the two
        horizontal channels of a location (:func:`with_sensor_effects`).
    delays_s : tuple of (channel index, seconds)
        Channels whose sensor reports late (a time delay: a sensor or a converter whose
        clock lags), applied after the readout by a :class:`DelayLine` the caller keeps
        across blocks (:meth:`delay_line`).
    zeros : tuple of (channel index, offset, rate per s)
        Channels whose zero is off and creeps, ``offset + rate t`` (``t`` from the first
        sample the :class:`DelayLine` sees), added after the delays by the same line.
    input_places : tuple of (node, direction)
        Where each input acts, when it acts at a node (a point force); empty otherwise.
    input_positions_m : tuple of (x, y, z)
        The position of each such node, when the model knows it (a matrix model's
        ``node_xyz``); empty otherwise.
    """

    system: ReducedSystem
    input_names: tuple[str, ...]
    input_quantities: tuple[str, ...]
    channels: tuple[ChannelSpec, ...]
    sources: tuple[Source, ...]
    name: str = ""
    readout: FloatArray | None = None
    delays_s: tuple[tuple[int, float], ...] = ()
    zeros: tuple[tuple[int, float, float], ...] = ()
    input_places: tuple[tuple[str, str], ...] = ()
    input_positions_m: tuple[tuple[float, float, float], ...] = ()

    def __post_init__(self) -> None:
        if len(self.sources) != len(self.channels):
            msg = (f"sources: expected one per channel ({len(self.channels)}), got "
                   f"{len(self.sources)}")
            raise ShapeError(msg)
        if len(self.input_quantities) != len(self.input_names):
            msg = (f"input_quantities: expected one per input ({len(self.input_names)}), got "
                   f"{len(self.input_quantities)}")
            raise ShapeError(msg)
        if len(self.input_names) != self.system.n_in:
            msg = (f"input_names: expected {self.system.n_in} (columns of Gamma), got "
                   f"{len(self.input_names)}")
            raise ShapeError(msg)
        if self.input_places and len(self.input_places) != len(self.input_names):
            msg = (f"input_places: expected one per input ({len(self.input_names)}) or none, "
                   f"got {len(self.input_places)}")
            raise ShapeError(msg)
        if self.input_positions_m and len(self.input_positions_m) != len(self.input_places):
            msg = (f"input_positions_m: expected one per input place "
                   f"({len(self.input_places)}) or none, got {len(self.input_positions_m)}")
            raise ShapeError(msg)

    @property
    def channel_names(self) -> tuple[str, ...]:
        """Names of the measured channels."""
        return tuple(c.name for c in self.channels)

    def input_matrix(self, names: Sequence[str], data: FloatArray) -> FloatArray:
        """Return the inputs (n_inputs, nt) from measured rows ``data`` of inputs ``names``.

        Any subset of the model's inputs: the unmeasured ones are zero; names the model
        does not have are left out.
        """
        ag = np.zeros((len(self.input_names), np.shape(data)[-1]))
        for row, name in zip(data, names, strict=True):
            if name in self.input_names:
                ag[self.input_names.index(name)] = row
        return ag

    def delay_line(self, fs_hz: float) -> DelayLine | None:
        """Return the line of the delayed and creeping channels at ``fs_hz`` (None: none)."""
        if not self.delays_s and not self.zeros:
            return None
        return DelayLine(self.delays_s, fs_hz, zeros=self.zeros)

    def measure(self, res: SimResult, line: DelayLine | None = None) -> FloatArray:
        """Channels (n_channels, nt) from a simulation result.

        A plant with delayed channels needs its :meth:`delay_line`, kept by the caller from
        one block to the next (``OptionError`` without it: a delay is never dropped
        silently).
        """
        out = self._measure(res)
        if not self.delays_s and not self.zeros:
            return out
        if line is None:
            msg = (f"plant {self.name!r} has delayed or creeping channels: measure() needs its "
                   "delay_line(fs_hz)")
            raise OptionError(msg)
        return line.apply(out)

    def _measure(self, res: SimResult) -> FloatArray:
        out = np.empty((len(self.channels), res.y.shape[1]))
        y_rows = [i for i, (k, _) in enumerate(self.sources) if k == "y"]
        f_rows = [i for i, (k, _) in enumerate(self.sources) if k == "force"]
        if y_rows:
            out[y_rows] = res.y[[self.sources[i][1] for i in y_rows]]
        if f_rows:
            out[f_rows] = res.force[[self.sources[i][1] for i in f_rows]]
        return out if self.readout is None else self.readout @ out


class DelayLine:
    r"""Fractional delays of some channels, block by block (4-point Lagrange interpolation).

    A delay of :math:`\tau f_s = m + \alpha` samples (integer ``m``, ``0 <= alpha < 1``)
    reads :math:`y[n - m - \alpha]` from the samples :math:`n - m, \ldots, n - m - 3` with
    the cubic Lagrange weights: causal (the same result block by block as for the whole
    record), exact for cubic signals, amplitude error about 1e-3 at a tenth of the sampling
    rate. Samples before the first one are zero (the structure at rest).

    ``zeros`` (channel row, offset, rate per s) are then added, ``offset + rate t`` with
    ``t`` counted from the first sample the line sees (a zero that creeps from the start of
    a record, as a charge amplifier's output after its reset).
    """

    def __init__(self, delays_s: Sequence[tuple[int, float]], fs_hz: float, *,
                 zeros: Sequence[tuple[int, float, float]] = ()) -> None:
        self.fs_hz = float(fs_hz)
        self.zeros = tuple((int(i), float(b), float(r)) for i, b, r in zeros)
        if not np.all(np.isfinite([v for z in self.zeros for v in z[1:]])):
            msg = f"sensor zeros: expected finite offsets and rates, got {list(zeros)}"
            raise OptionError(msg)
        self.n_seen = 0
        self.rows = np.array([i for i, _ in delays_s], dtype=int)
        d = np.array([t for _, t in delays_s], float) * fs_hz
        if np.any(d < 0) or not np.all(np.isfinite(d)):
            msg = f"sensor delays: expected finite values >= 0, got {list(delays_s)}"
            raise OptionError(msg)
        # read y[n - d] = y[n - m - a] from samples n - m .. n - m - 3 (a in [0, 1))
        self.m = np.floor(d).astype(int)
        x = -(d - self.m)  # position of the wanted sample relative to n - m
        nodes = np.array([0.0, -1.0, -2.0, -3.0])
        w = np.ones((d.size, 4))
        for j in range(4):
            for q in range(4):
                if q != j:
                    w[:, j] *= (x - nodes[q]) / (nodes[j] - nodes[q])
        self.w = w
        self.keep = int(self.m.max(initial=0)) + 3
        self.tail = np.zeros((d.size, self.keep))

    def apply(self, y: FloatArray) -> FloatArray:
        """Return ``y`` (n_channels, nt) with delayed rows read late, creeping zeros added.

        The tail and the time are kept for the next block.
        """
        out = self._delay(np.array(y, float, copy=True))
        t = (self.n_seen + np.arange(out.shape[-1])) / self.fs_hz
        for row, offset, rate in self.zeros:
            out[row] += offset + rate * t
        self.n_seen += out.shape[-1]
        return out

    def _delay(self, out: FloatArray) -> FloatArray:
        if self.rows.size == 0:
            return out
        nt = out.shape[-1]
        hist = np.concatenate([self.tail, out[self.rows]], axis=1)  # (n_del, keep + nt)
        n = np.arange(nt) + self.keep
        for k, row in enumerate(self.rows):
            base = n - self.m[k]
            taps = np.stack([hist[k, base - j] for j in range(4)])
            out[row] = self.w[k] @ taps
        self.tail = hist[:, -self.keep:]
        return out


def with_sensor_effects(plant: Plant, effects: Iterable[EffectSpec]) -> Plant:
    """Return the plant seen through sensors with gain, orientation, timing or zero errors.

    Gain: ``sensor_gain`` with ``gain``; reversed polarity: ``sensor_polarity`` (a gain of
    -1); orientation: ``sensor_angle`` with ``angle_deg``, turning the channel's ``_x`` /
    ``_y`` pair about z; crossed cables: ``sensor_swap``, the channel and its horizontal
    partner read each other; time delay: ``sensor_delay`` with ``delay_s`` (>= 0); a zero
    that is off: ``sensor_offset`` with ``offset``; one that creeps: ``sensor_drift`` with
    ``offset`` and ``rate`` (per second, from the start of a record). The component of
    such an effect is a channel name.

    Raises
    ------
    OptionError
        An unknown channel, or an angle or a swap on a channel without its horizontal
        partner.
    """
    effects = tuple(effects)
    if not effects:
        return plant
    names = plant.channel_names
    R = np.eye(len(names)) if plant.readout is None else plant.readout.copy()
    delays = dict(plant.delays_s)
    zeros = {i: (b, r) for i, b, r in plant.zeros}
    for e in effects:
        if e.component not in names:
            msg = f"{e.law}: unknown channel {e.component!r}; channels: {list(names)[:8]} ..."
            raise OptionError(msg)
        i = names.index(e.component)
        if e.law == "sensor_delay":
            delays[i] = float(e.params.get("delay_s", 0.0))
        elif e.law in ("sensor_offset", "sensor_drift"):
            zeros[i] = (float(e.params.get("offset", 0.0)), float(e.params.get("rate", 0.0)))
        elif e.law in ("sensor_gain", "sensor_polarity"):
            R[i] *= -1.0 if e.law == "sensor_polarity" else float(e.params.get("gain", 1.0))
        else:
            _turn_or_swap(R, names, e)
    return replace(plant, readout=R, name=f"{plant.name}+sensors",
                   delays_s=tuple(sorted(delays.items())),
                   zeros=tuple((i, b, r) for i, (b, r) in sorted(zeros.items())))


def _turn_or_swap(R: FloatArray, names: tuple[str, ...], e: EffectSpec) -> None:
    """Turn (``sensor_angle``) or swap (``sensor_swap``) a channel's row of ``R``, in place.

    The other row is its horizontal partner's (``_x`` <-> ``_y``).
    """
    stem, _, axis = e.component.rpartition("_")
    partner = f"{stem}_{'y' if axis == 'x' else 'x'}"
    if axis not in ("x", "y") or partner not in names:
        msg = f"{e.law} at {e.component!r}: needs the horizontal pair {partner!r}"
        raise OptionError(msg)
    i, j = names.index(e.component), names.index(partner)
    row_i, row_j = R[i].copy(), R[j].copy()
    if e.law == "sensor_swap":
        R[i], R[j] = row_j, row_i
        return
    a = np.deg2rad(float(e.params.get("angle_deg", 0.0)))
    s = 1.0 if axis == "x" else -1.0
    R[i] = np.cos(a) * row_i + s * np.sin(a) * row_j
