"""Effect families: what the evidence names first, and the laws that can express each.

The diagnosis names a **family** from the evidence and only then fits laws of that family;
a fitted law is reported under the family of what it does (a bilinear law with a post-yield
ratio below 1 softens, above 1 hardens).
"""

from __future__ import annotations

import numpy as np

from modal_twin.models.effects import MOUNT_LAW, SENSOR_LAWS, EffectSpec

__all__ = ["FAMILIES", "FAMILY_LAWS", "family_of", "place_of"]

FAMILIES = ("hysteresis", "friction", "softening", "hardening", "gap", "damping", "stiffness",
            "mass", "elastic_attachment", "sensor", "nothing")

# device laws (models.effects) that can express each family at a component, best first
FAMILY_LAWS: dict[str, tuple[str, ...]] = {
    "friction": ("stick_slip", "regularised_friction", "bilinear_hysteretic"),
    "hysteresis": ("bouc_wen", "bilinear_hysteretic", "stick_slip"),
    "softening": ("bilinear", "cubic"),
    "hardening": ("cubic", "bilinear", "gap"),
    "gap": ("gap", "cubic"),
    "stiffness": ("linear",),
    "damping": ("linear",),
}

# parameter kinds (diagnosis.parameters.KINDS) and other effect laws -> family
_LAW_FAMILY = {
    "stick_slip": "friction",
    "regularised_friction": "friction",
    "coulomb": "friction",
    "bouc_wen_esb": "friction",
    "bouc_wen": "hysteresis",
    "bouc_wen_sdp": "hysteresis",
    "bilinear_hysteretic": "hysteresis",
    "prandtl": "hysteresis",
    "gap": "gap",
    "added_mass": "mass",
    "stiffness": "stiffness",
    "damping": "damping",
    MOUNT_LAW: "elastic_attachment",
    **dict.fromkeys(SENSOR_LAWS, "sensor"),
}


def family_of(effect: EffectSpec, *, nominal_k: float | None = None,
              nominal_c: float | None = None, drift_scale: float | None = None,
              evidence_family: str = "") -> str:
    """Return the family of what a fitted effect does (module docstring).

    A bilinear hysteretic law whose elastic range ``ub`` is below 5 % of the drift it sees
    (``drift_scale``, e.g. its 99th percentile) is a slider that sticks and slips beside
    a spring: friction; with a wider elastic range it yields gradually: hysteresis. When
    the evidence at its place named one of the two (``evidence_family``), that decides.

    """
    law, p = effect.law, effect.params
    if law == "bilinear_hysteretic" and evidence_family in ("friction", "hysteresis"):
        return evidence_family  # the law can be either: the evidence at its place decides
    if law == "bilinear_hysteretic" and drift_scale and \
            float(p.get("ub", np.inf)) < 0.05 * drift_scale:
        return "friction"
    if law in _LAW_FAMILY:
        return _LAW_FAMILY[law]
    if law in ("bilinear", "bilinear_elastic"):
        return "softening" if float(p.get("ratio", 0.75)) < 1.0 else "hardening"
    if law == "cubic":
        return "hardening" if float(p.get("k3", 0.0)) > 0 else "softening"
    if law == "linear":
        dk = abs(float(p.get("k", nominal_k or 0.0)) / (nominal_k or 1.0) - 1.0) \
            if nominal_k else 0.0
        dc = abs(float(p.get("c", nominal_c or 0.0)) / (nominal_c or 1.0) - 1.0) \
            if nominal_c else 0.0
        return "damping" if dc > dk else "stiffness"
    return "nothing"


def place_of(effect: EffectSpec) -> str:
    """Where an effect sits.

    Its component, or for a parameter its place in the name (``m_F2`` -> ``F2``, ``kcol_1A`` ->
    ``1A``).
    """
    comp = effect.component
    if effect.law in ("added_mass", "stiffness", "damping") and "_" in comp:
        head, _, rest = comp.partition("_")
        if head in ("k", "c") and rest[-2:] in ("_x", "_y", "_z"):
            return rest[:-2]  # k_RB2_x: the device RB2
        return rest
    return comp
