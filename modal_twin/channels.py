"""Channel metadata: what each measured signal is (mirrors ``modal_twin_msgs/ChannelInfo``).

A channel map is the list of :class:`ChannelSpec` of a record. Besides the name, quantity,
unit, place and direction, each channel has a **role** that tells the stages what it is:

- ``input``: a measured excitation of the structure (table or base acceleration, a force);
- ``output``: a measured response;
- ``device_drift`` / ``device_force``: the drift across / the force in a device (damper,
  isolator), used by the device laws;
- ``reference``: measured but neither an input nor an output of the model (a reference
  sensor, a temperature).

Channels of the shipped scenarios carry no role; :func:`default_role` gives it from the
name (``table_*`` -> input, ``*_dx/_dy`` -> device drift, ``*_fx/_fy`` -> device force,
everything else output), so the naming rules stay valid.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any

from modal_twin.errors import ConfigError

__all__ = [
    "AXES",
    "QUANTITY_UNITS",
    "ROLES",
    "ChannelSpec",
    "channel_map_from_dict",
    "channel_map_to_dict",
    "channels_with_role",
    "default_role",
    "device_channels",
    "direction_vector",
]

QUANTITY_UNITS = {
    "acceleration": "m/s^2",
    "angular_acceleration": "rad/s^2",
    "displacement": "m",
    "velocity": "m/s",
    "force": "N",
    "pressure": "Pa",
    "strain": "m/m",
}
ROLES = ("input", "output", "device_drift", "device_force", "reference")
"""The roles a channel can play (module docstring)."""
AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}
"""Axis labels of the structure frame and their unit vectors."""


def default_role(name: str) -> str:
    """Role of a channel of the shipped scenarios, from its name (module docstring)."""
    if name.startswith("table_"):
        return "input"
    if re.search(r"_d[xy]$", name):
        return "device_drift"
    if re.search(r"_f[xy]$", name):
        return "device_force"
    return "output"


@dataclass(frozen=True, slots=True)
class ChannelSpec:
    """One channel: name, quantity and SI unit, place, direction, sensitivity and role.

    ``sensitivity`` is raw units per SI unit (e.g. V per m/s^2): raw = sensitivity x SI.
    The fields after ``position_m`` are optional (older code builds channels without them).

    Attributes
    ----------
    role : str
        One of :data:`ROLES`; ``""`` means "from the name" (:func:`default_role`).
    node : str
        Node of the model / test geometry the sensor sits on (``""`` if unknown).
    unit_si : str
        SI unit when the quantity is not in :data:`QUANTITY_UNITS` (``""``: from the
        quantity).
    meta : tuple of (key, value) pairs
        Header metadata kept from the source file (filter corners, azimuth, file name ...).
    """

    name: str
    quantity: str
    location: str = ""
    direction: str = ""
    sensitivity: float = 1.0
    position_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    role: str = ""
    node: str = ""
    unit_si: str = ""
    meta: tuple[tuple[str, Any], ...] = field(default=(), compare=False)

    def __post_init__(self) -> None:
        if self.role and self.role not in ROLES:
            msg = f"channel {self.name!r}: role expected one of {ROLES}, got {self.role!r}"
            raise ConfigError(msg)

    @property
    def unit(self) -> str:
        """SI unit of the quantity ('' if unknown)."""
        return self.unit_si or QUANTITY_UNITS.get(self.quantity, "")

    @property
    def effective_role(self) -> str:
        """The role, or the one the name implies (:func:`default_role`)."""
        return self.role or default_role(self.name)

    def with_role(self, role: str) -> ChannelSpec:
        """Return the same channel with another role."""
        return replace(self, role=role)


def direction_vector(direction: str) -> tuple[float, float, float] | None:
    """Return the unit vector of a direction label (``x``, ``-y``, ``0.6,0.8,0``).

    None if the label is not a direction.
    """
    d = direction.strip().lower()
    sign = -1.0 if d.startswith("-") else 1.0
    axis = d.lstrip("+-")
    if axis in AXES:
        return tuple(sign * v for v in AXES[axis])  # type: ignore[return-value]
    parts = d.split(",")
    if len(parts) == 3:
        try:
            v = [float(p) for p in parts]
        except ValueError:
            return None
        n = math.sqrt(sum(c * c for c in v))
        return (v[0] / n, v[1] / n, v[2] / n) if n > 0 else None
    return None


def channels_with_role(channels: Iterable[ChannelSpec], role: str) -> list[ChannelSpec]:
    """Return the channels whose (effective) role is ``role``, in order."""
    if role not in ROLES:
        msg = f"role: expected one of {ROLES}, got {role!r}"
        raise ConfigError(msg)
    return [c for c in channels if c.effective_role == role]


def device_channels(channels: Iterable[ChannelSpec], device: str, role: str) -> list[str]:
    """Return the names of the channels of ``role`` at ``device`` (its location), x, y, z.

    ``role`` is ``device_drift`` or ``device_force``; a device's drift and force are found
    by role and place, never by a channel name's pattern.
    """
    if role not in ("device_drift", "device_force"):
        msg = f"role: expected device_drift or device_force, got {role!r}"
        raise ConfigError(msg)
    found = {c.direction: c.name for c in channels_with_role(channels, role)
             if c.location == device}
    return [found[a] for a in "xyz" if a in found]


def channel_map_to_dict(channels: Iterable[ChannelSpec], **extra: Any) -> dict[str, Any]:
    """Channel map as a JSON-ready dict (``{"channels": [...], **extra}``)."""
    rows = []
    for c in channels:
        rows.append({
            "name": c.name, "role": c.effective_role, "quantity": c.quantity, "unit": c.unit,
            "location": c.location, "node": c.node, "direction": c.direction,
            "sensitivity": c.sensitivity, "position_m": list(c.position_m),
            "meta": dict(c.meta),
        })
    return {"channels": rows, **extra}


def channel_map_from_dict(d: Mapping[str, Any], source: str = "channel map"
                          ) -> list[ChannelSpec]:
    """Inverse of :func:`channel_map_to_dict` (unknown keys of a channel are refused).

    Raises
    ------
    ConfigError
        No ``channels`` list, a channel without ``name``, an unknown key or role.
    """
    rows = d.get("channels") if isinstance(d, Mapping) else None
    if not isinstance(rows, list):
        msg = f"{source}: expected a mapping with a 'channels' list, got {type(d).__name__}"
        raise ConfigError(msg)
    known = {"name", "role", "quantity", "unit", "location", "node", "direction",
             "sensitivity", "position_m", "meta"}
    out = []
    for k, r in enumerate(rows):
        if not isinstance(r, Mapping) or "name" not in r:
            msg = f"{source}: channel {k} expected a mapping with a 'name', got {r!r}"
            raise ConfigError(msg)
        bad = sorted(set(r) - known)
        if bad:
            msg = f"{source}: channel {r['name']!r} has unknown keys {bad}; known {sorted(known)}"
            raise ConfigError(msg)
        q = str(r.get("quantity", "acceleration"))
        unit = str(r.get("unit", ""))
        out.append(ChannelSpec(
            str(r["name"]), q, str(r.get("location", "")), str(r.get("direction", "")),
            float(r.get("sensitivity", 1.0)),
            tuple(float(v) for v in r.get("position_m", (0.0, 0.0, 0.0))),  # type: ignore[arg-type]
            str(r.get("role", "")), str(r.get("node", "")),
            unit if unit and unit != QUANTITY_UNITS.get(q) else "",
            tuple(sorted(dict(r.get("meta") or {}).items())),
        ))
    return out
