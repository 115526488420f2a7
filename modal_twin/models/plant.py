"""A plant: a reduced system plus the meaning of its inputs and measured channels.

The simulator returns outputs ``y`` (rows of C_out) and device forces; a structure's
measured channels are some of each (e.g. linear isolators' forces are rows of y, nonlinear
devices' forces come from their laws). :class:`Plant` keeps, per channel, where its value
comes from, so that a truth rig and a nominal twin with different device sets still
produce the same channels in the same order.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.channels import ChannelSpec
from modal_twin.errors import ShapeError
from modal_twin.models.reduced import ReducedSystem, SimResult

__all__ = ["Plant"]

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
    """

    system: ReducedSystem
    input_names: tuple[str, ...]
    input_quantities: tuple[str, ...]
    channels: tuple[ChannelSpec, ...]
    sources: tuple[Source, ...]
    name: str = ""

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

    def measure(self, res: SimResult) -> FloatArray:
        """Channels (n_channels, nt) from a simulation result."""
        out = np.empty((len(self.channels), res.y.shape[1]))
        y_rows = [i for i, (k, _) in enumerate(self.sources) if k == "y"]
        f_rows = [i for i, (k, _) in enumerate(self.sources) if k == "force"]
        if y_rows:
            out[y_rows] = res.y[[self.sources[i][1] for i in y_rows]]
        if f_rows:
            out[f_rows] = res.force[[self.sources[i][1] for i in f_rows]]
        return out
