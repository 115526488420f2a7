"""Candidate linear effects: a model parameter that is wrong or missing.

Added mass on a floor (``m_*``), a wrong concrete modulus (``E_*``): screened by
simulated sensitivities and fitted by simulation like the device laws.

Screening: with ``r`` the normalised residual of the nominal model on the training record
and ``s_p = d(prediction)/d(theta_p)`` by one forward difference (one simulation per
parameter), the share of ``|r|^2`` that ``alpha s_p`` removes is the score; ``alpha`` is the
starting change. A residual "with the shape of a mode" -- a linear stiffness or mass error --
is explained this way; a nonlinearity is not.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from functools import partial
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from modal_twin._types import FloatArray
from modal_twin.diagnosis.effect_kind import Facts, Job, Piece, Round
from modal_twin.diagnosis.fitting import (
    FittedEffect,
    Records,
    SimulationObjective,
    _parameter_std,
    channel_scale,
    judge_fit,
    normalised_residual,
)
from modal_twin.diagnosis.record import Record
from modal_twin.errors import ModalTwinError, OptionError
from modal_twin.models.effects import EffectSpec
from modal_twin.models.loading import ModelFactory
from modal_twin.models.plant import Plant

__all__ = ["KINDS", "PARAMETER", "PARAMETER_LAWS", "ParameterCandidate", "ParameterKind",
           "device_site", "fit_parameter", "rival_places", "screen_parameters"]

KINDS = {"m_": "added_mass", "E_": "stiffness", "EI_": "stiffness", "k_": "stiffness",
         "c_": "damping"}
PARAMETER_LAWS = tuple(dict.fromkeys(KINDS.values()))  # effects that change a parameter value
_LAW_FAMILY = {"added_mass": "mass", "stiffness": "stiffness", "damping": "damping"}


@dataclass(frozen=True, slots=True)
class ParameterCandidate:
    """A parameter change that explains part of the residual."""

    name: str
    kind: str  # added_mass | stiffness
    nominal: float
    start: float  # starting value (nominal + alpha h)
    gain: float  # share of the residual energy the change removes (training record)
    companions: tuple[tuple[str, float], ...] = ()  # starting values fitted with it (position)


def _residual(factory: ModelFactory, theta: dict[str, float], rec: Record, decimate: int,
              scale: FloatArray) -> FloatArray:
    plant = (factory.with_theta(theta) if theta else factory).plant()
    return normalised_residual(plant, rec, decimate, scale)


_MASS_COMPANIONS = ("added_mass_x", "added_mass_y", "added_mass_r")
_KIND_LAW = {"mass": "added_mass", "stiffness": "stiffness", "damping": "damping"}


def _info(factory: ModelFactory, name: str, nominal: float,
          prefixes: Sequence[str]) -> tuple[str, float, float] | None:
    """(law, lower, upper) of a parameter the diagnosis may change, None otherwise."""
    if not any(name.startswith(p) for p in prefixes):
        return None
    try:
        info = factory.parameter_info(name)
    except ModalTwinError:
        info = None
    if info is not None:
        if info.family in _MASS_COMPANIONS:
            return None  # fitted with their added mass, never alone
        law = _KIND_LAW[info.kind]
        lo = {"added_mass": 0.0, "damping": 0.01 * nominal}.get(law, info.lower)
        return law, float(min(lo, info.lower)), float(info.upper)
    kind = next((KINDS[p] for p in KINDS if name.startswith(p)), None)
    if kind is None:
        return None
    lo = {"added_mass": 0.0, "damping": 0.01 * nominal}.get(kind, 0.3 * nominal)
    return kind, lo, nominal * 5.0 + 1.0


def screen_parameters(factory: ModelFactory, train: Record, *,
                      prefixes: Sequence[str] | None = None, rel_step: float = 0.05,
                      decimate: int = 5) -> list[ParameterCandidate]:
    """Score every parameter whose name starts with one of ``prefixes`` (best first).

    ``prefixes`` defaults to the factory's ``parameter_prefixes`` (the building: masses,
    moduli, element groups, damping factors, the isolators' k and c and an added mass per
    floor; the vehicle: also its suspensions' k and c), else to every kind of
    :data:`KINDS`. The step is ``rel_step`` of the nominal value, or of the plausible range
    for a parameter whose nominal value is 0 (an added mass).
    """
    if prefixes is None:
        prefixes = tuple(factory.parameter_prefixes)
    values = factory.parameters()
    scale = channel_scale(train)
    r0 = _residual(factory, {}, train, decimate, scale)
    e0 = float(r0 @ r0)
    out = []
    for name, nominal in values.items():
        what = _info(factory, name, nominal, prefixes)
        if what is None or e0 <= 0:
            continue
        kind, lo, hi = what
        h = rel_step * (abs(nominal) if nominal else (hi - lo))
        if h <= 0:
            continue
        best: ParameterCandidate | None = None
        for where in _positions(factory, name):  # an added mass: at the centre and corners
            try:
                s = (_residual(factory, {name: nominal + h, **where}, train, decimate, scale)
                     - r0) / h
            except ModalTwinError:
                continue
            ss = float(s @ s)
            if ss <= 0:
                continue
            alpha = -float(s @ r0) / ss  # least-squares step along the sensitivity
            gain = float((s @ r0) ** 2 / ss / e0)
            if best is None or gain > best.gain:
                best = ParameterCandidate(name, kind, float(nominal),
                                          float(np.clip(nominal + alpha, lo, hi)), gain,
                                          tuple(where.items()))
        if best is not None:
            out.append(best)
    return sorted(out, key=lambda c: -c.gain)


# the level a parameter acts at: the places that compete with one another (a column line,
# a storey and a material all change the structure's stiffness; a floor's mass and a mass
# added on it, a floor's load)
_PLACE_CLASS = {"modulus": "structure", "group": "structure", "link": "structure",
                "added_mass": "mass"}


def _place_class(factory: ModelFactory, name: str) -> str:
    try:
        family = factory.parameter_info(name).family
    except (ModalTwinError, AttributeError):
        return ""
    return _PLACE_CLASS.get(family, family)


def device_site(factory: ModelFactory, name: str) -> str | None:
    """Return the device site a rate parameter belongs to (``k_ESB1_x`` -> ``ESB1``), or None.

    The longest site name that follows the parameter's prefix whole.
    """
    if not name.startswith(("k_", "c_")):
        return None
    rest = name[2:]
    hits = [s for s in getattr(factory, "sites", {}) if rest == s or rest.startswith(f"{s}_")]
    return max(hits, key=len) if hits else None


def rival_places(factory: ModelFactory, effect: EffectSpec) -> list[ParameterCandidate]:
    """Return the places that compete with a parameter change found, each as a candidate.

    The parameters of the same law and the same level (:data:`_PLACE_CLASS`: the structure's
    moduli, column lines and storeys; the devices' rates; the floors' masses), ``effect``'s
    own among them, each started at the change found: the same factor where both nominal
    values are non-zero, else the same increment (an added mass of ``m`` kg on another
    floor). The screening ranks places by a linear sensitivity at the nominal model; a large
    change found next to a device law fitted before it can land on a group that only
    overlaps the right one (a column line for its storey), which a fit at every rival, the
    others in place, tells apart.
    """
    values = factory.parameters()
    name = effect.component
    if name not in values or name not in effect.params:
        return []
    nom_p, v = float(values[name]), float(effect.params[name])
    level = _place_class(factory, name)
    out = []
    for q, nom_q in values.items():
        what = _info(factory, q, nom_q, (*factory.parameter_prefixes, name))
        if what is None or what[0] != effect.law or _place_class(factory, q) != level:
            continue
        law, lo, hi = what
        start = nom_q * v / nom_p if nom_p and nom_q else nom_q + (v - nom_p)
        start = float(np.clip(start, lo + 1e-6 * (hi - lo), hi - 1e-6 * (hi - lo)))
        own = tuple((n, effect.params[n]) for n in _companions(factory, q)
                    if q == name and n in effect.params)
        out.append(ParameterCandidate(q, law, float(nom_q), start, 0.0, own))
    return out


def _positions(factory: ModelFactory, name: str) -> list[dict[str, float]]:
    """Return where an added mass is tried while screening.

    The plan centre and the four corners of its floor (its ``_x`` / ``_y`` bounds), as a
    point mass; one empty entry for any other parameter.
    """
    comp = _companions(factory, name)
    if len(comp) < 2:
        return [{}]
    (nx, ny), values = comp[:2], factory.parameters()
    ix, iy = factory.parameter_info(nx), factory.parameter_info(ny)
    out = [{nx: values[nx], ny: values[ny]}]
    for fx in (0.1, 0.9):
        for fy in (0.1, 0.9):
            out.append({nx: ix.lower + fx * (ix.upper - ix.lower),
                        ny: iy.lower + fy * (iy.upper - iy.lower)})
    return out


def _companions(factory: ModelFactory, name: str) -> list[str]:
    """Return the parameters fitted together with an added mass.

    Its position and radius of gyration (``madd_R_x``, ``_y``, ``_r``).
    """
    values = factory.parameters()
    return [n for n in (f"{name}_x", f"{name}_y", f"{name}_r") if n in values]


def fit_parameter(factory: ModelFactory, cand: ParameterCandidate, train: Records,
                  test: Record, *, decimate: int = 5, max_nfev: int = 30) -> FittedEffect:
    """Fit one parameter (an added mass with its plan position) by simulation on ``train``.

    Judge on ``test``.

    Raises
    ------
    OptionError
        A start outside the physical range (negative mass or modulus).

    """
    t0 = time.perf_counter()
    prefixes = tuple(factory.parameter_prefixes)
    what = _info(factory, cand.name, cand.nominal, (*prefixes, cand.name))
    if what is None:
        lo, hi = 0.0, cand.nominal * 5.0 + 1.0
    else:
        _, lo, hi = what
    names = [cand.name, *_companions(factory, cand.name)]
    los, his, x0 = [lo], [hi], [cand.start]
    given = dict(cand.companions)
    for n in names[1:]:
        info = factory.parameter_info(n)
        los.append(info.lower)
        his.append(info.upper)
        start = given.get(n, factory.parameters()[n])
        if info.family == "added_mass_r" and start <= info.lower:
            start = info.lower + 0.25 * (info.upper - info.lower)  # d(m rg^2)/d rg = 0 at 0
        x0.append(start)
    lo_a, hi_a = np.asarray(los, float), np.asarray(his, float)
    span = np.maximum(hi_a - lo_a, 1e-12)
    x0_a = np.clip(np.asarray(x0, float), lo_a + 1e-9 * span, hi_a - 1e-9 * span)
    if not np.all((lo_a < x0_a) & (x0_a < hi_a)):
        msg = f"{cand.name}: start {cand.start} outside ({lo}, {hi})"
        raise OptionError(msg)

    def to_params(x: FloatArray) -> dict[str, float]:
        return {n: float(v) for n, v in zip(names, x, strict=True)}

    objective = SimulationObjective(lambda x: factory.with_theta(to_params(x)).plant(),
                                    train, decimate)
    scale = [abs(cand.nominal) or float(span[0]) * 0.1, *span[1:] * 0.1]
    sol = least_squares(objective, x0_a, bounds=(lo_a, hi_a), x_scale=scale, diff_step=1e-3,
                        max_nfev=max_nfev)
    effect = EffectSpec(cand.name, cand.kind, to_params(sol.x))
    fitted = judge_fit(effect, factory.with_theta(effect.params).plant(), factory.plant(), sol,
                       len(names), train, test, objective, t0,
                       _parameter_std(sol, to_params, names))
    edge = _on_plan_edge(factory, fitted.at_bound)
    return replace(fitted, at_bound=tuple(n for n in fitted.at_bound if n not in edge))


def _on_plan_edge(factory: ModelFactory, names: Sequence[str]) -> set[str]:
    """Return the position parameters of an added mass among ``names``.

    Their bounds are the floor's plan extent: a mass on the floor's edge (equipment on an
    edge beam, at a column line) is a place on the floor, not a fit stopped short by its
    bounds, so it is not flagged as one (its eccentricity is what the torsional coupling
    measures).
    """
    out = set()
    for n in names:
        with contextlib.suppress(ModalTwinError):
            if factory.parameter_info(n).family in ("added_mass_x", "added_mass_y"):
                out.add(n)
    return out


def _place_in_name(name: str) -> str:
    """Return the place a parameter's name holds (``m_F2`` -> ``F2``, ``k_RB2_x`` -> ``RB2``)."""
    if "_" not in name:
        return name
    head, _, rest = name.partition("_")
    if head in ("k", "c") and rest[-2:] in ("_x", "_y", "_z"):
        return rest[:-2]  # k_RB2_x: the device RB2
    return rest


class ParameterKind:
    """Effect kind ``parameter``: a parameter value of the model is wrong.

    An element group's stiffness, a damping factor, a floor's mass, or a mass added at a
    place with its position (module docstring). Its effect's component is the parameter's
    name and its law one of :data:`PARAMETER_LAWS`; it is applied as a parameter value.
    """

    name = "parameter"
    families: tuple[str, ...] = tuple(dict.fromkeys(_LAW_FAMILY.values()))

    def owns(self, law: str) -> bool:
        """One of :data:`PARAMETER_LAWS`."""
        return law in PARAMETER_LAWS

    def laws(self) -> tuple[str, ...]:
        """:data:`PARAMETER_LAWS`."""
        return PARAMETER_LAWS

    def screen(self, rnd: Round) -> tuple[ParameterCandidate, ...]:
        """:func:`screen_parameters` on the training record."""
        rnd.say("screening parameters (mass, stiffness, damping) by simulated sensitivities")
        return tuple(screen_parameters(rnd.factory, rnd.train))

    def jobs(self, rnd: Round, candidates: tuple[Any, ...]) -> list[Job]:
        """Return the best ``n_fit + 2`` above the gain threshold (many, and cheap to fit)."""
        return [(f"{pc.kind} {pc.name}", partial(fit_parameter, rnd.factory, pc, rnd.fit_on,
                                                 rnd.test))
                for pc in candidates[:rnd.n_fit + 2] if pc.gain >= rnd.gain_threshold]

    def report(self, candidates: tuple[Any, ...]) -> list[str]:
        """One line for each of the best four."""
        return [f"  {pc.name:<12} {pc.kind:<14} removes {100 * pc.gain:6.2f} % of the "
                f"residual (start {pc.start:.4g}, nominal {pc.nominal:.4g})"
                for pc in candidates[:4]]

    def plant(self, factory: ModelFactory, effect: EffectSpec) -> Plant:
        """Return the plant with the parameter values changed."""
        return factory.with_theta(effect.params).plant()

    def apply(self, factory: ModelFactory, effect: EffectSpec) -> ModelFactory:
        """Return the factory with the parameter values changed."""
        return factory.with_theta(effect.params)

    def into_version(self, theta: dict[str, float], effects: tuple[EffectSpec, ...],
                     effect: EffectSpec) -> tuple[dict[str, float], tuple[EffectSpec, ...]]:
        """Return the version's parameter values with these changed."""
        return {**theta, **effect.params}, effects

    def facts(self, rnd: Round, effect: EffectSpec) -> Facts:
        """Return the model's parameter values (an added mass is judged against its floor's)."""
        return Facts(rnd.factory.parameters(),
                     evidence_family=rnd.evidence_family.get(
                         device_site(rnd.factory, effect.component) or effect.component, ""))

    def family(self, effect: EffectSpec, facts: Facts) -> str:
        """``mass``, ``stiffness`` or ``damping``."""
        return _LAW_FAMILY[effect.law]

    def place(self, effect: EffectSpec, factory: ModelFactory | None = None) -> str:
        """Return the place its model gives the parameter, else the place in its name."""
        if factory is not None:
            with contextlib.suppress(ModalTwinError):
                return factory.parameter_info(effect.component).place
        return _place_in_name(effect.component)

    def flags(self, effect: EffectSpec, facts: Facts) -> tuple[str, ...]:
        """Flag an added mass that is negative, or below 1 % of the floor mass it joins.

        And a change of a device's rate (``k_ESB1_x``) where the force measured across that
        device is its nominal law's to its noise (the evidence names nothing there,
        :func:`.device_kind.screen`): the device's own force refutes it, whatever it does
        for the accelerations (it stands in for a form gap elsewhere).
        """
        if effect.law != "added_mass":
            if facts.evidence_family == "nothing" and effect.component.startswith(("k_", "c_")):
                return (f"refuted: the force measured at the device of {effect.component} is "
                        "its nominal law's to its noise",)
            return ()
        nominal = facts.values
        name = effect.component
        added = effect.params[name] - nominal.get(name, 0.0)
        floor = name.removeprefix("madd_").removeprefix("m_")
        ref = nominal.get(f"m_{floor}", nominal.get(name, 0.0))
        if added < 0:
            return (f"implausible: {name} loses {-added:.4g} kg (an added mass cannot "
                    "be negative)",)
        if ref > 0 and added < 0.01 * ref:
            return (f"implausible: added mass {added:.4g} kg is below 1 % of the "
                    f"{ref:.4g} kg it joins",)
        return ()

    def start(self, factory: ModelFactory, component: str, law: str, train: Record
              ) -> dict[str, float]:
        """Return the parameter's current value."""
        return {component: self._nominal(factory, component, law)}

    def fit(self, factory: ModelFactory, component: str, law: str, start: dict[str, float],
            train: Record, test: Record) -> FittedEffect:
        """:func:`fit_parameter` from ``start`` (the current value when not given)."""
        nominal = self._nominal(factory, component, law)
        cand = ParameterCandidate(component, law, nominal,
                                  float(start.get(component, nominal)), 0.0)
        return fit_parameter(factory, cand, train, test)

    @staticmethod
    def _nominal(factory: ModelFactory, component: str, law: str) -> float:
        values = factory.parameters()
        if component not in values:
            msg = f"{law}: unknown parameter {component!r}; parameters: {sorted(values)}"
            raise OptionError(msg)
        return values[component]

    def joint(self, factory: ModelFactory, effect: EffectSpec) -> Piece | None:
        """Return the value between its bounds; an added mass with its position and radius.

        The position and radius between the floor's bounds (:meth:`parameter_info`), so a
        mass found where another effect was still missing can move on its floor as well as
        change its size.
        """
        name = effect.component
        v = float(effect.params[name])
        nom = factory.parameters()[name]
        lo = 0.0 if effect.law == "added_mass" else min(0.3 * nom, 0.5 * v)
        hi = max(5.0 * nom + 1.0, 2.0 * v)
        names = [name, *(n for n in _companions(factory, name) if n in effect.params)]
        los, his = [lo], [hi]
        for n in names[1:]:
            info = factory.parameter_info(n)
            los.append(info.lower)
            his.append(info.upper)
        lo_a, hi_a = np.asarray(los, float), np.asarray(his, float)
        span = np.maximum(hi_a - lo_a, 1e-12)
        x0 = np.clip([float(effect.params[n]) for n in names], lo_a + 1e-9 * span,
                     hi_a - 1e-9 * span)

        def to_params(x: FloatArray) -> dict[str, float]:
            return {n: float(a) for n, a in zip(names, x, strict=True)}

        return len(names), to_params, x0, lo_a, hi_a


PARAMETER = ParameterKind()
