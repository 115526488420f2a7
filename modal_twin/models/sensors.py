"""The channel map of a rig file.

Measured table inputs, then the structure's sensors, each with the rig's sensitivity for its
quantity (what the acquisition calibrates with).
"""

from __future__ import annotations

from dataclasses import replace

from modal_twin.channels import ChannelSpec
from modal_twin.models.plant import Plant
from modal_twin.models.rig_file import RigFile

__all__ = ["rig_channels", "table_channels", "with_sensitivity"]


def rig_channels(rig: RigFile) -> tuple[ChannelSpec, ...]:
    """Channels of a rig (table inputs, then the structure's).

    With the rig's sensitivities per quantity: the channel map the acquisition applies.
    """
    from modal_twin.models.loading import load_model

    plant = load_model(rig.structure).plant()
    return with_sensitivity(table_channels(plant) + plant.channels,
                            rig.sensitivity)


def table_channels(plant: Plant) -> tuple[ChannelSpec, ...]:
    """Measured input channels ``table_<input>`` of a plant.

    (table motion, track irregularity), each with the plant's quantity for it.
    """
    return tuple(ChannelSpec(f"table_{n}", q, "table", n.removeprefix("a"))
                 for n, q in zip(plant.input_names, plant.input_quantities, strict=True))


def with_sensitivity(channels: tuple[ChannelSpec, ...],
                     sensitivity: dict[str, float]) -> tuple[ChannelSpec, ...]:
    """Channels with the sensitivity of their quantity (1.0 where none is given)."""
    return tuple(replace(c, sensitivity=sensitivity.get(c.quantity, 1.0)) for c in channels)
