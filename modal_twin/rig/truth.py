"""Simulated test rig.

A truth model (which may carry effects the nominal model lacks) driven by the drive signal, with
sensor noise and sensitivities, producing raw blocks.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.errors import SignalError
from modal_twin.models.plant import Plant
from modal_twin.models.sensors import (
    measured_channels,
    rig_channels,
    table_channels,
    with_sensitivity,
)
from modal_twin.signal_block import SignalBlock
from modal_twin.twin.simulator import Simulator

__all__ = ["TruthRig", "rig_channels", "table_channels", "with_sensitivity"]


class TruthRig:
    """Turn drive blocks into raw measurement blocks.

    The measured table inputs (``table_<input>``) then the plant's channels; raw = sensitivity
    x (SI + noise).

    Parameters
    ----------
    plant : Plant
        The truth (it may hold effects the nominal model lacks).
    dt : float
        Sample interval of the drive, s.
    noise_rms : dict
        Sensor noise RMS per quantity (SI), e.g. ``{"acceleration": 0.002}``.
    seed : int
        Noise seed.
    channels : sequence of str
        Patterns (fnmatch) of the plant's channels measured; empty = all
        (:func:`~modal_twin.models.sensors.measured_channels`).

    """

    def __init__(self, plant: Plant, dt: float, *, noise_rms: dict[str, float] | None = None,
                 sensitivity: dict[str, float] | None = None, seed: int = 0,
                 channels: Sequence[str] = ()) -> None:
        self.plant = plant
        self.sim = Simulator(plant.system, dt, modal_histories=False)
        self.line = plant.delay_line(1.0 / dt)
        self.rng = np.random.default_rng(seed)
        kept = measured_channels(plant, channels)
        keep = {c.name for c in kept}
        self._rows = [i for i, c in enumerate(plant.channels) if c.name in keep]
        self.channels = with_sensitivity(table_channels(plant) + kept, sensitivity or {})
        self.names = tuple(c.name for c in self.channels)
        self.sens = np.array([c.sensitivity for c in self.channels])[:, None]
        noise = noise_rms or {}
        self.noise = np.array([noise.get(c.quantity, 0.0) for c in self.channels])
        self.next_index = 0

    def process(self, drive: SignalBlock) -> SignalBlock:
        """Simulate one drive block; the raw block continues the rig's own sample count.

        Raises
        ------
        SignalError
            If the drive lacks one of the plant's inputs (unknown channels are ignored).
        """
        missing = [c for c in self.plant.input_names if c not in drive.channel_names]
        if missing:
            msg = f"drive block lacks channels {missing}; it has {list(drive.channel_names)}"
            raise SignalError(msg)
        ag = drive.select(list(self.plant.input_names)).data
        res = self.sim.step_block(ag)
        si: FloatArray = np.vstack([ag, self.plant.measure(res, self.line)[self._rows]])
        if np.any(self.noise > 0):
            si = si + self.noise[:, None] * self.rng.standard_normal(si.shape)
        block = SignalBlock(self.names, drive.fs_hz, self.next_index, self.sens * si,
                            stamp_ns=drive.stamp_ns, source="rig")
        self.next_index = block.next_index
        return block
