"""Effect families: the one vocabulary, and the family and place of a fitted effect.

The diagnosis names a **family** from the evidence and only then fits laws of that family;
a fitted effect is reported under the family of what it does (a bilinear law with a
post-yield ratio below 1 softens, above 1 hardens). The vocabulary is derived from the
registry of effect kinds (:data:`modal_twin.diagnosis.kinds.FAMILIES`); each kind says which
family its effects report in.
"""

from __future__ import annotations

from modal_twin.diagnosis.effect_kind import Facts
from modal_twin.diagnosis.kinds import FAMILIES, kind_of
from modal_twin.models.effects import EffectSpec

__all__ = ["FAMILIES", "family_of", "place_of"]


def family_of(effect: EffectSpec, *, nominal_k: float | None = None,
              nominal_c: float | None = None, drift_scale: float | None = None,
              evidence_family: str = "") -> str:
    """Return the family of what a fitted effect does (its kind decides).

    ``nominal_k`` / ``nominal_c`` are the mean nominal stiffness and damping of the device
    site, ``drift_scale`` the drift it sees (e.g. its 99th percentile), ``evidence_family``
    the family the evidence named at its place
    (:func:`modal_twin.diagnosis.device_kind.family_of`).
    """
    facts = Facts(nominal_k=nominal_k, nominal_c=nominal_c, drift_scale=drift_scale,
                  evidence_family=evidence_family)
    return kind_of(effect.law).family(effect, facts)


def place_of(effect: EffectSpec) -> str:
    """Where an effect sits.

    Its component, or for a parameter its place in the name (``m_F2`` -> ``F2``, ``kcol_1A``
    -> ``1A``).
    """
    return kind_of(effect.law).place(effect)
