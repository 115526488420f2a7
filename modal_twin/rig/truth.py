"""Simulated test rig: a truth model driven by the drive signal, producing raw blocks.

The truth may carry effects the nominal model lacks; sensor noise and sensitivities are
applied.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.channels import ChannelSpec
from modal_twin.errors import SignalError
from modal_twin.models.plant import Plant
from modal_twin.rig.config import RigFile
from modal_twin.signal_block import SignalBlock
from modal_twin.twin.simulator import Simulator

__all__ = ["TruthRig", "rig_channels", "table_channels", "with_sensitivity"]


class TruthRig:
    """Turn drive blocks into raw measurement blocks.

    The measured table inputs (``table_<input>``) then the plant's channels;
    raw = sensitivity x (SI + noise).

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
    """

    def __init__(self, plant: Plant, dt: float, *, noise_rms: dict[str, float] | None = None,
                 sensitivity: dict[str, float] | None = None, seed: int = 0) -> None:
        self.plant = plant
        self.sim = Simulator(plant.system, dt, modal_histories=False)
        self.rng = np.random.default_rng(seed)
        self.channels = with_sensitivity(table_channels(plant) + plant.channels,
                                         sensitivity or {})
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
        si: FloatArray = np.vstack([ag, self.plant.measure(res)])
        if np.any(self.noise > 0):
            si = si + self.noise[:, None] * self.rng.standard_normal(si.shape)
        block = SignalBlock(self.names, drive.fs_hz, self.next_index, self.sens * si,
                            stamp_ns=drive.stamp_ns, source="rig")
        self.next_index = block.next_index
        return block


def rig_channels(rig: RigFile) -> tuple[ChannelSpec, ...]:
    """Return the channels of a rig: the channel map the acquisition applies.

    Table inputs, then the structure's, with the rig's sensitivities per quantity.
    """
    from modal_twin.models.loading import load_model

    plant = load_model(rig.structure).plant()
    return with_sensitivity(table_channels(plant) + plant.channels,
                            rig.sensitivity)


def table_channels(plant: Plant) -> tuple[ChannelSpec, ...]:
    """Return the measured input channels ``table_<input>`` of a plant.

    Table motion, track irregularity: each with the plant's quantity for it.
    """
    return tuple(ChannelSpec(f"table_{n}", q, "table", n.removeprefix("a"))
                 for n, q in zip(plant.input_names, plant.input_quantities, strict=True))


def with_sensitivity(channels: tuple[ChannelSpec, ...],
                     sensitivity: dict[str, float]) -> tuple[ChannelSpec, ...]:
    """Channels with the sensitivity of their quantity (1.0 where none is given)."""
    return tuple(replace(c, sensitivity=sensitivity.get(c.quantity, 1.0)) for c in channels)
