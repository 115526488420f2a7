"""Channel metadata: what each measured signal is (mirrors ``modal_twin_msgs/ChannelInfo``)."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["QUANTITY_UNITS", "ChannelSpec"]

QUANTITY_UNITS = {
    "acceleration": "m/s^2",
    "angular_acceleration": "rad/s^2",
    "displacement": "m",
    "velocity": "m/s",
    "force": "N",
}


@dataclass(frozen=True, slots=True)
class ChannelSpec:
    """One channel: name, quantity and SI unit, place, direction and sensitivity.

    ``sensitivity`` is raw units per SI unit (e.g. V per m/s^2): raw = sensitivity x SI.
    """

    name: str
    quantity: str
    location: str = ""
    direction: str = ""
    sensitivity: float = 1.0
    position_m: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @property
    def unit(self) -> str:
        """SI unit of the quantity ('' if unknown)."""
        return QUANTITY_UNITS.get(self.quantity, "")
