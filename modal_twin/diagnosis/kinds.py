"""The registry of effect kinds the diagnosis looks for, and the one family vocabulary.

:data:`KINDS` maps a kind's name to its :class:`~.effect_kind.EffectKind` (as rosbags keeps
its type stores: a protocol and a dict). The pipeline screens every kind and fits the jobs
they make, in this order; the judgement, the joint refit, the whole-job helpers and the
report ask :func:`kind_of` an effect's kind and never test its law by name.

Adding a candidate kind = one module (a class following :class:`~.effect_kind.EffectKind`)
and one line here. Adding a device law = its module in :mod:`modal_twin.models.devices` and
one line in :mod:`modal_twin.models.devices.registry` (and its kernel branch): the
``device`` kind then screens, fits and reports it.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

from modal_twin.diagnosis.attachments import MOUNT
from modal_twin.diagnosis.device_kind import DEVICE
from modal_twin.diagnosis.effect_kind import EffectKind
from modal_twin.diagnosis.parameters import PARAMETER
from modal_twin.diagnosis.sensors import SENSOR
from modal_twin.errors import OptionError

__all__ = ["FAMILIES", "KINDS", "NOTHING", "effect_laws", "kind_of"]

KINDS: Mapping[str, EffectKind] = MappingProxyType({
    "device": DEVICE,  # a device law of models/devices/registry.py at a device site
    "parameter": PARAMETER,  # an element group's stiffness, a damping, an (added) mass
    "mount": MOUNT,  # a rigidly attached mass that hangs on an elastic mount
    "sensor": SENSOR,  # one channel's gain or orientation
})
"""Effect kind name -> kind, in the order the diagnosis screens them."""

NOTHING = "nothing"
"""The family of a diagnosis that names none."""

FAMILIES: tuple[str, ...] = (
    *dict.fromkeys(f for k in KINDS.values() for f in k.families), NOTHING)
"""The one family vocabulary every kind reports in (the device laws' families first)."""


def effect_laws() -> tuple[str, ...]:
    """Every effect law of every kind, in registry order."""
    return tuple(law for k in KINDS.values() for law in k.laws())


def kind_of(law: str) -> EffectKind:
    """Return the kind of an effect with law ``law``.

    Raises
    ------
    OptionError
        For a law no kind owns (lists the valid ones).
    """
    for kind in KINDS.values():
        if kind.owns(law):
            return kind
    msg = f"unknown effect law {law!r}; valid: {list(effect_laws())}"
    raise OptionError(msg)
