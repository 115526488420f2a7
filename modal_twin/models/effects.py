"""Library of physical effects that replace a device's nominal linear spring-dashpot.

An effect is a law placed at a model component (``ESB1``, ``RB2`` ...) with parameters
expressed relative to what the component already has (its nominal stiffness ``k``, damping
``c`` and carried weight ``W``), so that the same effect can be tried at any component.
The rig uses it to build truths the nominal model lacks; the diagnosis uses it to add a
candidate effect to the model.

========================  ======================================================  ==========
law                       device and parameters (defaults)                        source
========================  ======================================================  ==========
``linear``                k-c spring-dashpot (``k``, ``c`` nominal)               Eq. (1) [004]
``stick_slip``            Coulomb friction in series with the nominal stiffness:  Sec. 6 [004]
                          static ``mu_s`` and kinetic ``mu_k`` coefficients times
                          ``W`` (or forces ``Fs``, ``Fk`` in N), ``kt_factor`` 1
``bilinear``              elastic bilinear (Eq. (9) of [004]): post-yield         Eq. (9) [004]
                          ``ratio`` = kb / k (0.75) above ``ub`` (0.03 m)
``bilinear_hysteretic``   the same with kinematic hardening (dissipative)         [004]
``bouc_wen``              bidirectional Bouc-Wen hysteresis (Eqs. 10, 11b):       Eqs. 10-11 [004]
                          initial stiffness ``k`` (nominal), post-yield ratio
                          ``alpha`` (0.3), yield drift ``uy`` (0.03 m)
``cubic``                 k u + ``k3`` u^3 (N/m^3; < 0 softening)                 Eq. (2) [003]
``gap``                   spring ``k`` (nominal) acting beyond a gap ``g`` (m)
others                    any type of :data:`~modal_twin.models.structure_yaml.DEVICE_TYPES`
                          with explicit parameters
========================  ======================================================  ==========
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from modal_twin.errors import OptionError
from modal_twin.models.devices import (
    BilinearElastic,
    BilinearHysteretic,
    BoucWenSDP,
    CoulombFriction,
    CubicSpring,
    Device,
    GapSpring,
    LinearDevice,
)
from modal_twin.models.structure_yaml import DEVICE_TYPES, DeviceSpec, make_device

__all__ = ["EFFECT_LAWS", "MOUNT_LAW", "SENSOR_LAWS", "EffectSpec", "effect_device"]


@dataclass(frozen=True, slots=True)
class EffectSpec:
    """A physical effect placed at a model component, with its parameters."""

    component: str
    law: str
    params: dict[str, float] = field(default_factory=dict)


# a rigidly attached mass hung on a spring-damper instead (f_hz, zeta): an effect that
# changes the structure, not a device law (modal_twin.diagnosis.attachments)
MOUNT_LAW = "elastic_mount"
# what a sensor reports is off (a gain, an orientation about z): the component is a channel
SENSOR_LAWS = ("sensor_gain", "sensor_angle")
EFFECT_LAWS = ("linear", "stick_slip", "bilinear", "bilinear_hysteretic", "bouc_wen", "cubic",
               "gap")


def _take(p: dict[str, Any], key: str, default: float) -> float:
    return float(p.pop(key, default))


def effect_device(spec: DeviceSpec, law: str, params: dict[str, float], *,
                  weight: float = 0.0) -> Device:
    """Device with law ``law`` at component ``spec`` (named ``spec.name``, bidirectional).

    Raises
    ------
    OptionError
        Unknown law (lists the valid ones), unknown parameters, or friction without weight.
    """
    p: dict[str, Any] = dict(params)
    k = float(np.mean(spec.k))
    c = [float(v) for v in spec.c]
    name = spec.name
    dev: Device
    if law == "linear":
        dev = LinearDevice([_take(p, "k", spec.k[0]), _take(p, "ky", spec.k[1])],
                           [_take(p, "c", c[0]), _take(p, "cy", c[1])], name=name)
    elif law == "stick_slip":
        if "Fs" in p or "Fk" in p:
            Fs, Fk = _take(p, "Fs", 0.0), _take(p, "Fk", 0.0)
        else:
            if weight <= 0:
                msg = f"stick_slip at {name}: mu_s / mu_k need the carried weight; give Fs, Fk"
                raise OptionError(msg)
            Fs, Fk = _take(p, "mu_s", 0.09) * weight, _take(p, "mu_k", 0.06) * weight
        dev = CoulombFriction(Fs, Fk, k * _take(p, "kt_factor", 1.0), float(np.mean(c)),
                              n_dir=2, name=name)
    elif law in ("bilinear", "bilinear_hysteretic"):
        cls = BilinearElastic if law == "bilinear" else BilinearHysteretic
        k1 = _take(p, "k", k)
        dev = cls(k1, _take(p, "ratio", 0.75) * k1, _take(p, "ub", 0.03), c, name=name)
    elif law == "bouc_wen":  # z saturates at sqrt(A / (beta + gamma)) = uy with A = 1
        scale = _take(p, "k", k) / k
        uy = _take(p, "uy", 0.03)
        b = 0.5 / uy**2
        dev = BoucWenSDP(1.0, b, b, np.diag(scale * np.asarray(spec.k, float)),
                         _take(p, "alpha", 0.3), c, name=name)
    elif law == "cubic":
        dev = CubicSpring(_take(p, "k", k), _take(p, "k3", 0.0), c, name=name)
    elif law == "gap":
        dev = GapSpring(_take(p, "k", k), _take(p, "g", 0.01), float(np.mean(c)), n_dir=2,
                        name=name)
    elif law in DEVICE_TYPES:
        return make_device(replace(spec, type=law, params=dict(params)), weight=weight)
    else:
        msg = f"unknown effect law {law!r}; valid: {sorted({*EFFECT_LAWS, *DEVICE_TYPES})}"
        raise OptionError(msg)
    if p:
        msg = f"effect {law} at {name}: unknown parameters {sorted(p)}"
        raise OptionError(msg)
    return dev
