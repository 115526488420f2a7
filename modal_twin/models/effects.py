"""Library of physical effects that replace a device's nominal linear spring-dashpot.

An effect is a law placed at a model component (``ESB1``, ``RB2`` ...) with parameters
expressed relative to what the component already has (its nominal stiffness ``k``, damping
``c`` and carried weight ``W``), so that the same effect can be tried at any component.
The rig uses it to build truths the nominal model lacks; the diagnosis uses it to add a
candidate effect to the model.

The laws, their families, parameters and defaults are those of the one device registry,
:mod:`modal_twin.models.devices.registry` (the README renders it as a table):
:data:`EFFECT_LAWS` are the laws with a relative form (``linear``, ``stick_slip``,
``bilinear``, ``bilinear_hysteretic``, ``bouc_wen``, ``cubic``, ``gap``); every other law
(``bouc_wen_esb``, ``prandtl``) and any law given its absolute parameters (``kb`` of
``bilinear``, ``A`` of ``bouc_wen`` ...) is built as in a structure file.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from modal_twin.errors import OptionError
from modal_twin.models.devices import Device
from modal_twin.models.devices.registry import (
    ALIASES,
    LAWS,
    Site,
    build_effect_device,
    canonical_law,
    law_names,
)
from modal_twin.models.structure_yaml import DeviceSpec

__all__ = ["EFFECT_LAWS", "MOUNT_LAW", "SENSOR_LAWS", "EffectSpec", "effect_device"]


@dataclass(frozen=True, slots=True)
class EffectSpec:
    """A physical effect placed at a model component, with its parameters.

    A deprecated law name (:data:`~modal_twin.models.devices.registry.ALIASES`) is replaced
    by its canonical name, so that every stage downstream sees one name per law.
    """

    component: str
    law: str
    params: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        """Replace an alias by the canonical law name (logs a deprecation note once)."""
        if self.law in ALIASES:
            object.__setattr__(self, "law", canonical_law(self.law))


# a rigidly attached mass hung on a spring-damper instead (f_hz, zeta): an effect that
# changes the structure, not a device law (modal_twin.diagnosis.attachments)
MOUNT_LAW = "elastic_mount"
# what a sensor reports is off (a gain, an orientation about z, a time delay, a reversed
# polarity, a zero that is off or creeps, crossed cables of a horizontal pair): the
# component is a channel
SENSOR_LAWS = ("sensor_gain", "sensor_angle", "sensor_delay", "sensor_polarity",
               "sensor_offset", "sensor_drift", "sensor_swap")
EFFECT_LAWS: tuple[str, ...] = law_names(relative=True)
"""Laws that build from parameters relative to a component's nominal k, c, W."""


def effect_device(spec: DeviceSpec, law: str, params: dict[str, float], *,
                  weight: float = 0.0) -> Device:
    """Device with law ``law`` at component ``spec`` (named ``spec.name``).

    Parameters
    ----------
    spec : DeviceSpec
        The component (its nominal ``k``, ``c``).
    law : str
        A law of :mod:`modal_twin.models.devices.registry` (aliases accepted with a
        deprecation note).
    params : dict
        Relative (or absolute) parameters, see the registry.
    weight : float
        Vertical load carried by the component, N.

    Raises
    ------
    OptionError
        Unknown law (lists the valid ones), unknown parameters, or friction without weight.
    """
    if law not in LAWS and law not in ALIASES:
        msg = f"unknown effect law {law!r}; valid: {list(LAWS)} (aliases: {list(ALIASES)})"
        raise OptionError(msg)
    return build_effect_device(law, params, Site(spec.name, spec.k, spec.c, weight))
