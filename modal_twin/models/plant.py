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

__all__ = ["Plant", "with_sensor_effects"]

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
    """

    system: ReducedSystem
    input_names: tuple[str, ...]
    input_quantities: tuple[str, ...]
    channels: tuple[ChannelSpec, ...]
    sources: tuple[Source, ...]
    name: str = ""
    readout: FloatArray | None = None

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

    def measure(self, res: SimResult) -> FloatArray:
        """Channels (n_channels, nt) from a simulation result."""
        out = np.empty((len(self.channels), res.y.shape[1]))
        y_rows = [i for i, (k, _) in enumerate(self.sources) if k == "y"]
        f_rows = [i for i, (k, _) in enumerate(self.sources) if k == "force"]
        if y_rows:
            out[y_rows] = res.y[[self.sources[i][1] for i in y_rows]]
        if f_rows:
            out[f_rows] = res.force[[self.sources[i][1] for i in f_rows]]
        return out if self.readout is None else self.readout @ out


def with_sensor_effects(plant: Plant, effects: Iterable[EffectSpec]) -> Plant:
    """Return the plant seen through sensors with gain or orientation errors.

    Gain: ``sensor_gain`` with ``gain``; orientation: ``sensor_angle`` with ``angle_deg``,
    turning the channel's ``_x`` / ``_y`` pair about z. The component of such an effect is a
    channel name.

    Raises
    ------
    OptionError
        An unknown channel, or an angle on a channel without its horizontal partner.
    """
    effects = tuple(effects)
    if not effects:
        return plant
    names = plant.channel_names
    R = np.eye(len(names)) if plant.readout is None else plant.readout.copy()
    for e in effects:
        if e.component not in names:
            msg = f"{e.law}: unknown channel {e.component!r}; channels: {list(names)[:8]} ..."
            raise OptionError(msg)
        i = names.index(e.component)
        if e.law == "sensor_gain":
            R[i] *= float(e.params.get("gain", 1.0))
            continue
        stem, _, axis = e.component.rpartition("_")
        partner = f"{stem}_{'y' if axis == 'x' else 'x'}"
        if axis not in ("x", "y") or partner not in names:
            msg = f"sensor_angle at {e.component!r}: needs the horizontal pair {partner!r}"
            raise OptionError(msg)
        j = names.index(partner)
        a = np.deg2rad(float(e.params.get("angle_deg", 0.0)))
        row_i, row_j = R[i].copy(), R[j].copy()
        s = 1.0 if axis == "x" else -1.0
        R[i] = np.cos(a) * row_i + s * np.sin(a) * row_j
    return replace(plant, readout=R, name=f"{plant.name}+sensors")
