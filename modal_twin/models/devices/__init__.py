"""Nonlinear device laws (one law per module, each a numba function the twin also calls).

Their names, kind codes, builders, defaults and families: :mod:`.registry`.
"""

from __future__ import annotations

from modal_twin.models.devices.base import Device, DeviceResponse
from modal_twin.models.devices.bilinear import (
    BilinearElastic,
    BilinearHysteretic,
    table10_rubber_bearing,
)
from modal_twin.models.devices.bouc_wen import BoucWenESB, BoucWenSDP, table10_esb, table10_sdp
from modal_twin.models.devices.coulomb import CoulombFriction
from modal_twin.models.devices.cubic import CubicSpring
from modal_twin.models.devices.gap import GapSpring
from modal_twin.models.devices.iwan import IwanJoint
from modal_twin.models.devices.linear import LinearDevice, table6_updated
from modal_twin.models.devices.maxwell import MaxwellDamper
from modal_twin.models.devices.prandtl import PrandtlJoint, table2_mode_bay
from modal_twin.models.devices.smooth_bilinear import SmoothBilinearSpring

__all__ = [
    "BilinearElastic",
    "BilinearHysteretic",
    "BoucWenESB",
    "BoucWenSDP",
    "CoulombFriction",
    "CubicSpring",
    "Device",
    "DeviceResponse",
    "GapSpring",
    "IwanJoint",
    "LinearDevice",
    "MaxwellDamper",
    "PrandtlJoint",
    "SmoothBilinearSpring",
    "table2_mode_bay",
    "table6_updated",
    "table10_esb",
    "table10_rubber_bearing",
    "table10_sdp",
]
