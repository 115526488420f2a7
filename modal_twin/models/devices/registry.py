"""The one registry of device laws: name -> kind code, class, builders, defaults, family.

Every nonlinear law of :mod:`modal_twin.models.devices` has ONE name here. A law is built

* from a structure file's ``params`` (absolute SI values, :func:`build_device`), used by
  :func:`modal_twin.models.structure_yaml.make_device`;
* from an effect's ``params`` relative to what the component already has -- its nominal
  stiffness ``k``, damping ``c`` and carried weight ``W`` (:func:`build_effect_device`),
  used by :func:`modal_twin.models.effects.effect_device`. Effect params that name an
  absolute-only parameter (``kb`` of ``bilinear``, ``A`` of ``bouc_wen`` ...) select the
  absolute form, so either form is accepted wherever a law is named.

Old names are aliases (``bilinear_elastic`` -> ``bilinear``, ``bouc_wen_sdp`` ->
``bouc_wen``): they build the same device and log a deprecation note once per process.
Kind codes are the ``KIND_*`` of :mod:`modal_twin.models.devices.base`, the numbers the
jitted dispatch (:mod:`modal_twin.models.devices._dispatch`) and the twin switch on.
:func:`markdown_table` renders the table the README shows.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.errors import ConfigError, OptionError
from modal_twin.models.devices.base import Device
from modal_twin.models.devices.bilinear import (
    BilinearElastic,
    BilinearHysteretic,
    law_bilinear_elastic,
    law_bilinear_hysteretic,
)
from modal_twin.models.devices.bouc_wen import BoucWenESB, BoucWenSDP, law_bw_esb, law_bw_sdp
from modal_twin.models.devices.coulomb import CoulombFriction, law_coulomb
from modal_twin.models.devices.cubic import CubicSpring, law_cubic
from modal_twin.models.devices.gap import GapSpring, law_gap
from modal_twin.models.devices.iwan import IwanJoint, law_iwan
from modal_twin.models.devices.linear import LinearDevice, law_linear
from modal_twin.models.devices.maxwell import MaxwellDamper, law_maxwell
from modal_twin.models.devices.prandtl import PrandtlJoint, law_prandtl
from modal_twin.models.devices.smooth_bilinear import SmoothBilinearSpring, law_smooth_bilinear

__all__ = [
    "ALIASES",
    "FAMILIES",
    "KINDS",
    "LAWS",
    "LawEntry",
    "Site",
    "build_device",
    "build_effect_device",
    "canonical_law",
    "law_entry",
    "law_names",
    "markdown_table",
]

_log = logging.getLogger(__name__)

FAMILIES = ("stiffness", "damping", "softening", "hardening", "hysteresis", "friction", "gap")
"""Families of missing effects a law can stand for (DESIGN.md, "the loop", step 3)."""

Builder = Callable[[dict[str, Any], "Site"], Device]


@dataclass(frozen=True, slots=True)
class Site:
    """The component a law is placed at: its label and nominal linear properties.

    Attributes
    ----------
    name : str
        Component label (``ESB1`` ...); the device gets it as its name.
    k : (2,) float array
        Nominal horizontal stiffness (x, y), N/m.
    c : (2,) float array
        Nominal viscous damping (x, y), N s/m.
    weight : float, optional
        Vertical load carried, N (friction laws need it; None: unknown).
    """

    name: str
    k: FloatArray
    c: FloatArray
    weight: float | None = None


@dataclass(frozen=True, slots=True)
class LawEntry:
    """One device law.

    Attributes
    ----------
    name : str
        Canonical name (structure ``type``, effect ``law``).
    cls : type of Device
        The class the builders return.
    law : callable
        The jitted law function (``law(p, s, u, v, f, Kt, Ct, s_new)``).
    families : tuple of str
        Families of :data:`FAMILIES` the law can report in, the one it reports when its
        parameters do not decide first (the diagnosis's ``device`` kind,
        :func:`modal_twin.diagnosis.device_kind.family_of`).
    parameters : tuple of str
        Keys of the absolute form (structure files).
    defaults : mapping
        Defaults of the absolute form (``"nominal c"``: the component's own value).
    effect_parameters : tuple of str
        Keys of the relative form (effects); empty when the law has none.
    effect_defaults : mapping
        Defaults of the relative form.
    source : str
        Equation and paper of the law.
    aliases : tuple of str
        Deprecated names accepted for it.
    build : callable
        ``build(params, site) -> Device`` of the absolute form (pops what it uses).
    build_relative : callable, optional
        The same for the relative form.
    """

    name: str
    cls: type[Device]
    law: Callable[..., None]
    families: tuple[str, ...]
    parameters: tuple[str, ...]
    defaults: Mapping[str, Any]
    source: str
    build: Builder
    effect_parameters: tuple[str, ...] = ()
    effect_defaults: Mapping[str, Any] = field(default_factory=dict)
    aliases: tuple[str, ...] = ()
    build_relative: Builder | None = None

    @property
    def kind(self) -> int:
        """Kind code of the jitted dispatch: the class's ``base.KIND_*``."""
        return self.cls.kind


def _c(p: dict[str, Any], site: Site) -> list[float]:
    return [float(v) for v in p.pop("c", site.c)]


def _cmean(p: dict[str, Any], site: Site) -> float:
    return float(p.pop("c", np.mean(site.c)))


def _c_pair(site: Site) -> tuple[float, float]:
    """Return the component's nominal dashpot per direction (x, y), N s/m."""
    c = np.broadcast_to(np.asarray(site.c, float), (2,))
    return float(c[0]), float(c[1])


def _take(p: dict[str, Any], key: str, default: float) -> float:
    return float(p.pop(key, default))


def _kmean(site: Site) -> float:
    return float(np.mean(site.k))


# ---------------------------------------------------------------- absolute forms (structure)
def _abs_linear(p: dict[str, Any], site: Site) -> Device:
    c = _c(p, site)
    k = [float(v) for v in p.pop("k", site.k)]
    return LinearDevice(k, c, name=site.name, **p)


def _abs_bilinear(cls: type[BilinearElastic]) -> Builder:
    def build(p: dict[str, Any], site: Site) -> Device:
        c = _c(p, site)
        return cls(float(p.pop("k")), float(p.pop("kb")), float(p.pop("ub")), c,
                   name=site.name, **p)
    return build


def _abs_smooth_bilinear(p: dict[str, Any], site: Site) -> Device:
    c = _c(p, site)
    return SmoothBilinearSpring(float(p.pop("k")), float(p.pop("kb")), float(p.pop("ub")), c,
                                name=site.name, **p)


def _abs_iwan(p: dict[str, Any], site: Site) -> Device:
    """Absolute form: k, kr per direction (one value: both), uy, c (default the nominal c)."""
    c = _c(p, site)
    return IwanJoint(p.pop("k"), p.pop("kr", 0.0), float(p.pop("uy")), c, name=site.name,
                     **p)


def _abs_bw_esb(p: dict[str, Any], site: Site) -> Device:
    c = _c(p, site)
    W = p.pop("W", "auto")
    if W == "auto":
        if site.weight is None:
            msg = f"device {site.name}: params.W is 'auto' and no weight was given"
            raise ConfigError(msg)
        W = site.weight
    return BoucWenESB(float(p.pop("A")), float(p.pop("beta")), float(p.pop("gamma")), c,
                      W=float(W), name=site.name, **p)


def _abs_bw_sdp(p: dict[str, Any], site: Site) -> Device:
    c = _c(p, site)
    K = np.asarray(p.pop("K"), dtype=float)
    return BoucWenSDP(float(p.pop("A")), float(p.pop("beta")), float(p.pop("gamma")), K,
                      float(p.pop("alpha")), c, name=site.name, **p)


def _abs_cubic(p: dict[str, Any], site: Site) -> Device:
    c = _c(p, site)
    return CubicSpring(float(p.pop("k1")), float(p.pop("k3")), c, name=site.name, **p)


def _abs_coulomb(p: dict[str, Any], site: Site) -> Device:
    c = _cmean(p, site)
    return CoulombFriction(float(p.pop("Fs")), float(p.pop("Fk")), float(p.pop("kt")), c,
                           n_dir=2, name=site.name, **p)


def _abs_regularised_friction(p: dict[str, Any], site: Site) -> Device:
    """Build Coulomb friction with its dashpot ``c`` given as one value or a pair (x, y).

    When ``c`` is not given, the component's nominal dashpot per direction.
    """
    c_given = p.pop("c", None)
    c = (_c_pair(site) if c_given is None else float(c_given) if np.ndim(c_given) == 0
         else _c_pair(Site(site.name, site.k, np.asarray(c_given, float))))
    return CoulombFriction(float(p.pop("Fs")), float(p.pop("Fk")), float(p.pop("kt")), c,
                           n_dir=2, name=site.name, **p)


def _abs_gap(p: dict[str, Any], site: Site) -> Device:
    c = _cmean(p, site)
    return GapSpring(float(p.pop("k")), float(p.pop("g")), c, n_dir=2, name=site.name, **p)


def _abs_maxwell(p: dict[str, Any], site: Site) -> Device:
    """Absolute form: kp (default the nominal k), kb, c (default the nominal c)."""
    n = 2
    kp = np.broadcast_to(np.asarray(p.pop("k", site.k), float), (n,))
    kb = np.broadcast_to(np.asarray(p.pop("kb"), float), (n,))
    c = np.broadcast_to(np.asarray(p.pop("c", site.c), float), (n,))
    return MaxwellDamper(list(kp), list(kb), list(c), name=site.name, **p)


def _abs_prandtl(p: dict[str, Any], site: Site) -> Device:
    return PrandtlJoint(_take(p, "K1", site.k[0]), _take(p, "K2", 0.0), _take(p, "K3", 0.0),
                        _take(p, "D1", site.c[0]), float(p.pop("Fs")), float(p.pop("Kb")),
                        name=site.name, **p)


# ---------------------------------------------------------------- relative forms (effects)
_STICK_SLIP = {"mu_s": 0.09, "mu_k": 0.06, "kt_factor": 1.0}
_BILINEAR = {"ratio": 0.75, "ub": 0.03}
_SMOOTH_BILINEAR = {"ratio": 0.75, "ub": 0.03, "n": 2.0}
_BOUC_WEN = {"alpha": 0.3, "uy": 0.03, "c_factor": 1.0, "uncoupled": 0.0}
_IWAN = {"alpha": 0.2, "uy": 0.03, "c_factor": 1.0, "isotropic": 0.0}
_CUBIC = {"k3": 0.0}
_GAP = {"g": 0.01, "kp": 0.0}
_REG_FRICTION = {"kp": 0.0, "v_s": 0.05, "v_reg": 0.005, "c_factor": 1.0}
_MAXWELL = {"c_factor": 1.0, "tau": 0.02}


def _rel_linear(p: dict[str, Any], site: Site) -> Device:
    return LinearDevice([_take(p, "k", site.k[0]), _take(p, "ky", site.k[1])],
                        [_take(p, "c", site.c[0]), _take(p, "cy", site.c[1])], name=site.name)


def _friction_limits(p: dict[str, Any], site: Site, law: str) -> tuple[float, float]:
    """(Fs, Fk) given (one of them: both equal), or mu_s, mu_k times the carried weight.

    The defaults are mu_s 0.09, mu_k 0.06.
    """
    if "Fs" in p or "Fk" in p:
        fs, fk = p.pop("Fs", None), p.pop("Fk", None)
        return float(fk if fs is None else fs), float(fs if fk is None else fk)
    W = site.weight or 0.0
    if W <= 0:
        msg = f"{law} at {site.name}: mu_s / mu_k need the carried weight; give Fs, Fk"
        raise OptionError(msg)
    return (_take(p, "mu_s", _STICK_SLIP["mu_s"]) * W,
            _take(p, "mu_k", _STICK_SLIP["mu_k"]) * W)


def _rel_stick_slip(p: dict[str, Any], site: Site) -> Device:
    """Coulomb friction in series with the nominal stiffness (Sec. 6 of [004])."""
    Fs, Fk = _friction_limits(p, site, "stick_slip")
    kt = _kmean(site) * _take(p, "kt_factor", _STICK_SLIP["kt_factor"])
    # kp: the share of the component's own spring kept beside the slider (0 by default)
    share = _take(p, "kp", 0.0)
    kp = (share * float(site.k[0]), share * float(site.k[1]))
    return CoulombFriction(Fs, Fk, kt, float(np.mean(site.c)), n_dir=2, name=site.name,
                           kp=kp, v_s=_take(p, "v_s", 0.0))


def _rel_regularised_friction(p: dict[str, Any], site: Site) -> Device:
    """Viscous-regularised friction with a speed-dependent limit beside a share of k."""
    Fs, Fk = _friction_limits(p, site, "regularised_friction")
    share = _take(p, "kp", _REG_FRICTION["kp"])
    kp = (share * float(site.k[0]), share * float(site.k[1]))
    # c_factor: the share of the component's dashpot beside the slider (a damper whose
    # viscous part a friction element partly replaced), per direction as kp
    share_c = _take(p, "c_factor", _REG_FRICTION["c_factor"])
    cx, cy = _c_pair(site)
    c = (share_c * cx, share_c * cy)
    return CoulombFriction(Fs, Fk, _kmean(site), c, n_dir=2,
                           name=site.name, kp=kp, v_s=_take(p, "v_s", _REG_FRICTION["v_s"]),
                           v_reg=_take(p, "v_reg", _REG_FRICTION["v_reg"]))


def _rel_bilinear(cls: type[BilinearElastic]) -> Builder:
    def build(p: dict[str, Any], site: Site) -> Device:
        # k: the mean initial stiffness; each direction keeps the nominal anisotropy
        kx, ky = float(site.k[0]), float(site.k[1])
        aniso = kx > 0 and ky > 0
        k1 = _take(p, "k", _kmean(site)) * (kx / _kmean(site) if aniso else 1.0)
        return cls(k1, _take(p, "ratio", _BILINEAR["ratio"]) * k1,
                   _take(p, "ub", _BILINEAR["ub"]), [float(v) for v in site.c], name=site.name,
                   y_scale=ky / kx if aniso else 1.0)
    return build


def _rel_smooth_bilinear(p: dict[str, Any], site: Site) -> Device:
    """Build the relative form: kb = ratio k, ub and the sharpness n as given.

    k: the mean initial stiffness; each direction keeps the nominal anisotropy.
    """
    kx, ky = float(site.k[0]), float(site.k[1])
    aniso = kx > 0 and ky > 0
    k1 = _take(p, "k", _kmean(site)) * (kx / _kmean(site) if aniso else 1.0)
    return SmoothBilinearSpring(
        k1, _take(p, "ratio", _SMOOTH_BILINEAR["ratio"]) * k1,
        _take(p, "ub", _SMOOTH_BILINEAR["ub"]), [float(v) for v in site.c], name=site.name,
        n=_take(p, "n", _SMOOTH_BILINEAR["n"]), y_scale=ky / kx if aniso else 1.0)


def _rel_bouc_wen(p: dict[str, Any], site: Site) -> Device:
    """z saturates at sqrt(A / (beta + gamma)) = uy with A = 1, beta = gamma.

    ``uncoupled`` 1: each direction yields on its own (two orthogonal dampers, no circular
    yield surface; :class:`BoucWenSDP`); 0: Eq. (10) of [004].
    """
    scale = _take(p, "k", _kmean(site)) / _kmean(site)
    uy = _take(p, "uy", _BOUC_WEN["uy"])
    b = 0.5 / uy**2
    c_factor = _take(p, "c_factor", _BOUC_WEN["c_factor"])  # the dashpot beside it
    return BoucWenSDP(1.0, b, b, np.diag(scale * np.asarray(site.k, float)),
                      _take(p, "alpha", _BOUC_WEN["alpha"]),
                      [c_factor * float(v) for v in site.c], name=site.name,
                      uncoupled=_take(p, "uncoupled", _BOUC_WEN["uncoupled"]) >= 0.5)


def _rel_iwan(p: dict[str, Any], site: Site) -> Device:
    """Build the relative form of the Iwan joint (the parameters of ``bouc_wen``).

    Stuck stiffness ``k`` (mean), of which ``alpha`` stays as the residual spring at full
    slip (the Jenkins elements ``(1 - alpha) k``), full slip at ``uy``, the dashpot
    ``c_factor`` times the nominal one.

    ``isotropic`` 1: the same joint in x and y (one contact, ``k`` in both); 0: each
    direction keeps the nominal spring's anisotropy about ``k``.
    """
    kn = np.asarray(site.k, float)[:2]
    if _take(p, "isotropic", _IWAN["isotropic"]) >= 0.5:
        kn = np.full(2, _kmean(site))
    kk = _take(p, "k", _kmean(site)) / _kmean(site) * kn if _kmean(site) > 0 else kn
    alpha = _take(p, "alpha", _IWAN["alpha"])
    c_factor = _take(p, "c_factor", _IWAN["c_factor"])
    return IwanJoint(list((1.0 - alpha) * kk), list(alpha * kk), _take(p, "uy", _IWAN["uy"]),
                     [c_factor * float(v) for v in site.c], name=site.name)


def _rel_cubic(p: dict[str, Any], site: Site) -> Device:
    # k: the mean linear stiffness; each direction keeps the nominal spring's anisotropy
    kx, ky = _take(p, "k", _kmean(site)) / _kmean(site) * np.asarray(site.k, float)[:2]
    return CubicSpring(float(kx), _take(p, "k3", _CUBIC["k3"]), [float(v) for v in site.c],
                       name=site.name, m=_take(p, "m", 3.0), k1y=float(ky))


def _rel_gap(p: dict[str, Any], site: Site) -> Device:
    # kp: the share of the component's own spring-dashpot kept beside the gap (0: a bare
    # dead band, the default; 1: a bearing that hits a stop)
    share = _take(p, "kp", _GAP["kp"])
    kp = (share * float(site.k[0]), share * float(site.k[1]))
    cp = (share * float(site.c[0]), share * float(site.c[1]))
    g = _take(p, "g", _GAP["g"])
    return GapSpring(_take(p, "k", _kmean(site)), g,
                     0.0 if share else float(np.mean(site.c)), n_dir=2, name=site.name,
                     kp=kp, cp=cp, g_neg=_take(p, "g_neg", g), n=_take(p, "n", 1.0))


def _rel_maxwell(p: dict[str, Any], site: Site) -> Device:
    """Put the component's dashpot (x c_factor) behind a spring kb = c / tau, beside its spring.

    k: the mean parallel stiffness; each direction keeps the nominal anisotropy.
    """
    kn = np.asarray(site.k, float)[:2]
    kp = _take(p, "k", _kmean(site)) / _kmean(site) * kn if _kmean(site) > 0 else kn
    c = _take(p, "c_factor", _MAXWELL["c_factor"]) * np.asarray(site.c, float)[:2]
    tau = _take(p, "tau", _MAXWELL["tau"])
    if not tau > 0:
        msg = f"maxwell at {site.name}: tau must be > 0 s, got {tau}"
        raise OptionError(msg)
    kb = np.maximum(c, 1e-300) / tau
    return MaxwellDamper(list(kp), list(kb), list(c), name=site.name)


_NOM_C = {"c": "nominal c"}
_ENTRIES = (
    LawEntry("linear", LinearDevice, law_linear, ("stiffness", "damping"),
             ("k", "c"), {"k": "nominal k", "c": "nominal c"}, "Eq. (1) of [004]",
             _abs_linear, ("k", "ky", "c", "cy"),
             {"k": "nominal kx", "ky": "nominal ky", "c": "nominal cx", "cy": "nominal cy"},
             build_relative=_rel_linear),
    LawEntry("stick_slip", CoulombFriction, law_coulomb, ("friction",),
             ("Fs", "Fk", "kt", "c"), {"c": "mean nominal c"}, "Sec. 6 of [004]",
             _abs_coulomb, ("mu_s", "mu_k", "Fs", "Fk", "kt_factor"), _STICK_SLIP,
             build_relative=_rel_stick_slip),
    LawEntry("regularised_friction", CoulombFriction, law_coulomb, ("friction",),
             ("Fs", "Fk", "kt", "c", "kp", "v_s", "v_reg"),
             {"c": "nominal c per direction", "kp": (0.0, 0.0), "v_s": 0.0},
             "viscous-regularised Coulomb friction, Stribeck speed dependence",
             _abs_regularised_friction,
             ("mu_s", "mu_k", "Fs", "Fk", "kp", "v_s", "v_reg", "c_factor"),
             {"mu_s": 0.09, "mu_k": 0.06, **_REG_FRICTION},
             build_relative=_rel_regularised_friction),
    LawEntry("bilinear", BilinearElastic, law_bilinear_elastic,
             ("softening", "hardening"), ("k", "kb", "ub", "c"), _NOM_C, "Eq. (9) of [004]",
             _abs_bilinear(BilinearElastic), ("k", "ratio", "ub"), _BILINEAR,
             aliases=("bilinear_elastic",), build_relative=_rel_bilinear(BilinearElastic)),
    LawEntry("smooth_bilinear", SmoothBilinearSpring, law_smooth_bilinear,
             ("softening", "hardening"), ("k", "kb", "ub", "c", "n"), {**_NOM_C, "n": 2.0},
             "Eq. (1) of Richard & Abbott (1975), the Menegotto-Pinto backbone without "
             "memory (elastic); n -> inf: Eq. (9) of [004]", _abs_smooth_bilinear,
             ("k", "ratio", "ub", "n"), _SMOOTH_BILINEAR,
             build_relative=_rel_smooth_bilinear),
    LawEntry("bilinear_hysteretic", BilinearHysteretic,
             law_bilinear_hysteretic, ("hysteresis", "friction"), ("k", "kb", "ub", "c"), _NOM_C,
             "Eq. (9) of [004], kinematic hardening", _abs_bilinear(BilinearHysteretic),
             ("k", "ratio", "ub"), _BILINEAR,
             build_relative=_rel_bilinear(BilinearHysteretic)),
    LawEntry("bouc_wen", BoucWenSDP, law_bw_sdp, ("hysteresis",),
             ("A", "beta", "gamma", "K", "alpha", "c", "uncoupled"),
             {**_NOM_C, "uncoupled": 0}, "Eqs. (10), (11b) of [004]",
             _abs_bw_sdp, ("k", "uy", "alpha", "c_factor", "uncoupled"), _BOUC_WEN,
             aliases=("bouc_wen_sdp",), build_relative=_rel_bouc_wen),
    LawEntry("iwan", IwanJoint, law_iwan, ("hysteresis",), ("k", "kr", "uy", "c"),
             {**_NOM_C, "kr": 0.0}, "Iwan (1966) parallel Jenkins elements, uniform slip "
             "density (Segalman 2005, chi = 0): parabolic backbone, Masing branches, "
             "Madelung memory", _abs_iwan, ("k", "alpha", "uy", "c_factor", "isotropic"), _IWAN,
             build_relative=_rel_iwan),
    LawEntry("bouc_wen_esb", BoucWenESB, law_bw_esb, ("friction", "hysteresis"),
             ("A", "beta", "gamma", "c", "W", "mu0", "mu1", "mu2", "S"),
             {"c": "nominal c", "W": "auto (carried weight)", "mu0": 0.0606, "mu1": -0.5883,
              "mu2": 0.1148, "S": 0.1018}, "Eqs. (10), (11a) of [004]", _abs_bw_esb),
    LawEntry("cubic", CubicSpring, law_cubic, ("softening", "hardening"),
             ("k1", "k3", "c", "m"), {**_NOM_C, "m": 3.0},
             "Eq. (3) of [003], K1 and K3 terms (free exponent m)", _abs_cubic,
             ("k", "k3", "m"), _CUBIC, build_relative=_rel_cubic),
    LawEntry("gap", GapSpring, law_gap, ("gap",), ("k", "g", "c", "g_neg", "n"),
             {"c": "mean nominal c", "g_neg": "g", "n": 1.0}, "dead band or one-sided stop, "
             "contact spring (linear or Hertz-like)", _abs_gap, ("k", "g", "kp", "g_neg", "n"),
             _GAP,
             build_relative=_rel_gap),
    LawEntry("prandtl", PrandtlJoint, law_prandtl, ("hysteresis", "friction"),
             ("K1", "K2", "K3", "D1", "Fs", "Kb"),
             {"K1": "nominal kx", "K2": 0.0, "K3": 0.0, "D1": "nominal cx"},
             "Eqs. (3), (6)-(12) of [003] (uniaxial, x)", _abs_prandtl),
    LawEntry("maxwell", MaxwellDamper, law_maxwell, ("damping",), ("k", "kb", "c"),
             {"k": "nominal k", "c": "nominal c"},
             "dashpot in series with a spring kb (Maxwell), beside the spring k; "
             "K(w) = k + kb i w c / (kb + i w c)", _abs_maxwell,
             ("k", "c_factor", "tau"), _MAXWELL, build_relative=_rel_maxwell),
)

LAWS: Mapping[str, LawEntry] = MappingProxyType({e.name: e for e in _ENTRIES})
"""Canonical law name -> entry, in table order."""

ALIASES: Mapping[str, str] = MappingProxyType(
    {a: e.name for e in _ENTRIES for a in e.aliases})
"""Deprecated law name -> canonical name."""

KINDS: Mapping[int, tuple[str, ...]] = MappingProxyType(
    {kind: tuple(e.name for e in _ENTRIES if e.kind == kind)
     for kind in sorted({e.kind for e in _ENTRIES})})
"""Kind code of the jitted dispatch -> canonical names of the laws that use it (the twin
kernel has one branch per code; test/twin/test_kernel_laws.py runs every law through it)."""

_warned: set[str] = set()


def canonical_law(name: str) -> str:
    """Return the canonical name of ``name`` (an alias logs a deprecation note once).

    Raises
    ------
    OptionError
        For a name that is neither a law nor an alias (lists the valid ones).
    """
    if name in LAWS:
        return name
    if name in ALIASES:
        new = ALIASES[name]
        if name not in _warned:
            _warned.add(name)
            _log.warning("device law %r is deprecated: use %r (same law)", name, new)
        return new
    msg = f"unknown device law {name!r}; valid: {list(LAWS)} (aliases: {list(ALIASES)})"
    raise OptionError(msg)


def law_entry(name: str) -> LawEntry:
    """Return the entry of a law or alias (see :func:`canonical_law`)."""
    return LAWS[canonical_law(name)]


def law_names(*, family: str | None = None, relative: bool = False) -> tuple[str, ...]:
    """Return canonical law names in table order.

    Parameters
    ----------
    family : str, optional
        Only laws of this family (one of :data:`FAMILIES`).
    relative : bool
        Only laws that build from effect params relative to a component's nominal k, c, W.

    Raises
    ------
    OptionError
        For an unknown family.
    """
    if family is not None and family not in FAMILIES:
        msg = f"family: expected one of {list(FAMILIES)}, got {family!r}"
        raise OptionError(msg)
    return tuple(e.name for e in _ENTRIES
                 if (family is None or family in e.families)
                 and (not relative or e.build_relative is not None))


def build_device(name: str, params: Mapping[str, Any], site: Site) -> Device:
    """Build law ``name`` from its absolute parameters (a structure file's ``params``).

    Missing required parameters raise KeyError and unexpected ones TypeError (the structure
    parser names the entry); parameters the law refuses raise ModelError.

    Raises
    ------
    OptionError
        Unknown law.
    ConfigError
        ``bouc_wen_esb`` with ``W: auto`` and no weight.
    """
    return law_entry(name).build(dict(params), site)


def build_effect_device(name: str, params: Mapping[str, Any], site: Site) -> Device:
    """Build law ``name`` from effect params, relative to the site's nominal k, c, W.

    Params naming a parameter only the absolute form has (``kb``, ``A`` ...), and every
    law without a relative form, take the absolute form (:func:`build_device`).

    Raises
    ------
    OptionError
        Unknown law, unknown parameters, friction coefficients without a weight.
    """
    entry = law_entry(name)
    only_abs = set(entry.parameters) - set(entry.effect_parameters)
    if entry.build_relative is None or only_abs & set(params):
        return entry.build(dict(params), site)
    p = dict(params)
    dev = entry.build_relative(p, site)
    if p:
        msg = f"effect {name} at {site.name}: unknown parameters {sorted(p)}"
        raise OptionError(msg)
    return dev


def _fmt(d: Mapping[str, Any]) -> str:
    return ", ".join(f"{k}={v}" for k, v in d.items()) or "-"


def markdown_table() -> str:
    """Return the registry as the Markdown table of the README (one row per law)."""
    rows = ["| law | aliases | family | structure params (defaults) | effect params "
            "(defaults; k, c, W nominal) | source |",
            "|---|---|---|---|---|---|"]
    for e in _ENTRIES:
        eff = (f"{', '.join(e.effect_parameters)} ({_fmt(e.effect_defaults)})"
               if e.build_relative is not None else "as structure")
        rows.append(f"| `{e.name}` | {', '.join(f'`{a}`' for a in e.aliases) or '-'} | "
                    f"{', '.join(e.families)} | {', '.join(e.parameters)} "
                    f"({_fmt(e.defaults)}) | {eff} | {e.source} |")
    return "\n".join(rows)
