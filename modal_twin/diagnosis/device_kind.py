"""Effect kind ``device``: a device law of the registry placed at a device site.

Screened where a site's drift and force are measured (channels with the roles
``device_drift`` / ``device_force`` at that location, :mod:`modal_twin.channels`): the
evidence (:mod:`.evidence`) names families, :data:`FAMILY_LAWS` the laws tried for each,
and the force-state screening (:mod:`.screening`, Eq. (20) of [003]) their starts; each law
is then fitted by simulation (:func:`.fitting.fit_effect`). Its families are the device
registry's (:data:`modal_twin.models.devices.registry.FAMILIES`); a law whose registry
entry lists several reports the one its fitted parameters show (:func:`family_of`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from functools import partial
from typing import Any

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.channels import ChannelSpec, device_channels
from modal_twin.diagnosis.behaviour import Behaviour, classify_behaviour, reported_family
from modal_twin.diagnosis.effect_kind import Facts, Job, Piece, PlacedEffect, Round
from modal_twin.diagnosis.evidence import DeviceEvidence, device_evidence, velocity_cutoff
from modal_twin.diagnosis.fitting import FittedEffect, _transform, fit_effect
from modal_twin.diagnosis.record import Record
from modal_twin.diagnosis.screening import (
    ScreenedCandidate,
    _respond,
    drift_velocity,
    parameter_grid,
    screen_components,
)
from modal_twin.errors import ModalTwinError, OptionError
from modal_twin.models.devices.base import Device
from modal_twin.models.devices.registry import ALIASES, FAMILIES, LAWS, law_entry
from modal_twin.models.effects import EffectSpec, effect_device
from modal_twin.models.loading import ModelFactory

__all__ = ["DEVICE", "FAMILY_LAWS", "DeviceCandidate", "DeviceKind", "behaviour_on",
           "family_of", "input_share", "measured_device"]

# device laws that can express each family at a component, best first (a law may express
# a family beside its own: stick-slip also makes a loop, a gap also hardens)
FAMILY_LAWS: Mapping[str, tuple[str, ...]] = {
    "friction": ("stick_slip", "regularised_friction", "bilinear_hysteretic"),
    "hysteresis": ("bouc_wen", "iwan", "bilinear_hysteretic", "stick_slip"),
    "softening": ("bilinear", "smooth_bilinear", "cubic"),
    "hardening": ("cubic", "bilinear", "gap"),
    "gap": ("gap", "cubic"),
    "stiffness": ("linear",),
    "damping": ("linear",),
}
_LINEAR = ("stiffness", "damping")  # what the nominal law already has
# linear laws with memory, by the linear family they change: tried where that family
# leads the evidence beside a significant nonlinear one (a damper behind a bushing: a
# damping change whose force lags with frequency, which the loop regressors read as
# hysteresis); where the linear terms alone explain the residual, the plain linear law is
# the candidate, and a stiffness lead beside friction is a slider's spring, not a damper
_LINEAR_WITH_MEMORY: Mapping[str, tuple[str, ...]] = {"damping": ("maxwell",)}


@dataclass(frozen=True, slots=True)
class DeviceCandidate:
    """Return the evidence at one site, the laws it names and their screened starts."""

    evidence: DeviceEvidence
    laws: tuple[str, ...]
    screened: tuple[ScreenedCandidate, ...]


def measured_device(channels: Iterable[ChannelSpec], rec: Record, component: str
                    ) -> tuple[list[str], list[str]] | None:
    """Names of the drift and force channels of ``component`` measured in ``rec``.

    By role and location (:func:`modal_twin.channels.device_channels`): x and y of an
    isolator, z of a vehicle's suspension; None unless every direction the model gives
    both of is in the record.
    """
    chans = tuple(channels)
    drift = device_channels(chans, component, "device_drift")
    force = device_channels(chans, component, "device_force")
    if drift and len(drift) == len(force) and all(
            c in rec.channel_names for c in drift + force):
        return drift, force
    return None


def input_share(factory: ModelFactory, component: str, rec: Record, n_dir: int
                ) -> tuple[FloatArray, FloatArray] | None:
    """Return the input's own part of a site's drift and of its rate on ``rec``, or None.

    From the factory's ``site_inputs(component)`` (input name -> coefficient of the drift,
    and of its rate; a vehicle's primary suspension: ``-z_i``, ``-z_i'``), where it has
    one; the first direction only (the others take none).
    """
    eu, ev = factory.site_inputs(component)
    if not eu and not ev:
        return None
    u_in, v_in = np.zeros((n_dir, rec.inputs.shape[1])), np.zeros((n_dir, rec.inputs.shape[1]))
    for row, coef in ((u_in, eu), (v_in, ev)):
        for name, a in coef.items():
            row[0] += a * rec.inputs[rec.input_names.index(name)]
    return u_in, v_in


def _bilinear_hysteretic(p: Mapping[str, float], facts: Facts) -> str:
    if facts.evidence_family in ("friction", "hysteresis"):
        return facts.evidence_family  # the law can be either: the evidence decides
    if facts.drift_scale and float(p.get("ub", np.inf)) < 0.05 * facts.drift_scale:
        return "friction"
    return "hysteresis"


def _linear(p: Mapping[str, float], facts: Facts) -> str:
    k, c = facts.nominal_k, facts.nominal_c
    dk = abs(float(p.get("k", k or 0.0)) / (k or 1.0) - 1.0) if k else 0.0
    dc = abs(float(p.get("c", c or 0.0)) / (c or 1.0) - 1.0) if c else 0.0
    return "damping" if dc > dk else "stiffness"


# laws whose registry entry lists several families: which one the fitted parameters show
_FAMILY_RULES: Mapping[str, Callable[[Mapping[str, float], Facts], str]] = {
    "bilinear_hysteretic": _bilinear_hysteretic,
    "bilinear": lambda p, f: "softening" if float(p.get("ratio", 0.75)) < 1.0 else "hardening",
    "smooth_bilinear": lambda p, f: ("softening" if float(p.get("ratio", 0.75)) < 1.0
                                     else "hardening"),
    "cubic": lambda p, f: "hardening" if float(p.get("k3", 0.0)) > 0 else "softening",
    "linear": _linear,
}


def family_of(effect: EffectSpec, facts: Facts | None = None) -> str:
    """Return the family of what a fitted device law does.

    A bilinear law (sharp or smooth) with a post-yield ratio below 1 softens, above 1
    hardens; a cubic one hardens for ``k3 > 0``; a linear one changes the stiffness or the
    damping, whichever moved more from the nominal. A bilinear hysteretic law whose elastic
    range ``ub`` is below 5 % of the drift it sees (``facts.drift_scale``) is a slider that
    sticks and slips beside a spring (friction), otherwise it yields (hysteresis), unless
    the evidence at its place named one of the two. Any other law reports the first family
    of its registry entry.
    """
    rule = _FAMILY_RULES.get(effect.law)
    if rule is not None:
        return rule(effect.params, facts or Facts())
    return law_entry(effect.law).families[0]


def behaviour_on(factory: ModelFactory, channels: Iterable[ChannelSpec], rec: Record,
                 effect: EffectSpec) -> Behaviour | None:
    """Return what a fitted device law does along its site's measured drift (:mod:`.behaviour`).

    The law's force along the record's drift and its velocity (as the screening drives a
    law, :func:`.screening.screen_components`) and at zero velocity (its rate-independent
    part), read in the direction of the largest drift against the site's nominal k and c.
    None where the site's drift is not measured or the law cannot be driven.
    """
    spec = factory.sites.get(effect.component)
    cols = measured_device(channels, rec, effect.component)
    if spec is None or cols is None:
        return None
    u = rec.channels(cols[0])
    v = drift_velocity(u, rec.fs_hz, velocity_cutoff(u, rec.fs_hz))
    try:
        dev = effect_device(spec, effect.law, dict(effect.params),
                            weight=factory.weight(effect.component))
        f = _respond(dev, u, v, 1.0 / rec.fs_hz)
        f_static = _respond(dev, u, np.zeros_like(v), 1.0 / rec.fs_hz)  # rate-independent
    except (ModalTwinError, ValueError):
        return None
    d = int(np.argmax(np.std(u, axis=1)))
    k = np.atleast_1d(np.asarray(spec.k, float))
    c = np.atleast_1d(np.asarray(spec.c, float))
    b = classify_behaviour(u[d], v[d], f[d], k=float(k[min(d, k.size - 1)]),
                           c=float(c[min(d, c.size - 1)]), f_static=f_static[d])
    if b.family not in _LINEAR and _homogeneous(dev, u, v, f, 1.0 / rec.fs_hz):
        return None  # linear with memory (a damper behind a bushing): its law's family
    return b


def _homogeneous(dev: Device, u: FloatArray, v: FloatArray, f: FloatArray, dt: float,
                 tol: float = 1e-3) -> bool:
    """Whether the law's force scales with its drift history (``f(u / 2) = f(u) / 2``).

    A linear law, with memory or not, does; every law with a threshold, a yield drift or
    a power does not. The loop and secant readings of :mod:`.behaviour` cannot tell a
    relaxing linear law (a Maxwell damper) from a softening spring; this can.
    """
    try:
        half = _respond(dev, 0.5 * u, 0.5 * v, dt)
    except (ModalTwinError, ValueError):
        return False
    return bool(np.linalg.norm(half - 0.5 * f) <= tol * 0.5 * np.linalg.norm(f))


class DeviceKind(PlacedEffect):
    """Return the ``device`` effect kind (module docstring)."""

    name = "device"
    families: tuple[str, ...] = FAMILIES

    def owns(self, law: str) -> bool:
        """Accept a law or alias of the device registry."""
        return law in LAWS or law in ALIASES

    def laws(self) -> tuple[str, ...]:
        """Return the device registry's laws."""
        return tuple(LAWS)

    def screen(self, rnd: Round) -> tuple[DeviceCandidate, ...]:
        """Evidence at every measured site without an effect; the laws it names, screened.

        Sets ``rnd.evidence_family`` (site -> the family its evidence names first).
        """
        rnd.say("gathering evidence at the devices (force-state maps, cycles)")
        factory = rnd.factory
        carried = {e.component for e in factory.base_effects}
        out: list[DeviceCandidate] = []
        for comp in (s for s in factory.sites if s not in carried):
            found = _site_evidence(rnd, comp)
            if found is None:
                continue
            ev, u, f, fs_hz, share = found
            spec = factory.sites[comp]
            rnd.evidence_family[comp] = _top_family(ev)
            laws = _laws_named(ev, rnd.n_families)
            scr = screen_components({comp: u}, {comp: f}, {comp: spec},
                                    {comp: factory.weight(comp)}, fs_hz,
                                    laws=tuple(x for x in laws if x != "linear"),
                                    input_shares=None if share is None else {comp: share}
                                    ) if laws else []
            out.append(DeviceCandidate(ev, laws, tuple(scr)))
        if not out and factory.sites:
            rnd.skipped.append("evidence: no component has measured drift and force")
        return tuple(out)

    def jobs(self, rnd: Round, candidates: tuple[Any, ...]) -> list[Job]:
        """Return a fit of every law named at a site (linear from the nominal, others screened)."""
        jobs: list[Job] = []
        for cand in candidates:
            comp = cand.evidence.component
            starts = {c.law: c.params for c in cand.screened}
            for law in cand.laws:
                if law == "linear" or law in starts:
                    jobs.append((f"{law} at {comp}", partial(
                        fit_effect, rnd.factory, comp, law, starts.get(law, {}), rnd.fit_on,
                        rnd.test)))
        return jobs

    def report(self, candidates: tuple[Any, ...]) -> list[str]:
        """Return the evidence has its own section of the report: no lines here."""
        return []

    def facts(self, rnd: Round, effect: EffectSpec) -> Facts:
        """Return the site's nominal k and c, its measured drift scale, the evidence there.

        And what the fitted law does along the training record (:func:`behaviour_on`).
        """
        spec = rnd.factory.sites.get(effect.component)
        cols = measured_device(rnd.nominal.channels, rnd.train, effect.component)
        drift = (float(np.quantile(np.abs(rnd.train.channels(cols[0])), 0.99))
                 if cols is not None else None)
        return Facts(rnd.factory.parameters(),
                     float(np.mean(spec.k)) if spec is not None else None,
                     float(np.mean(spec.c)) if spec is not None else None, drift,
                     rnd.evidence_family.get(effect.component, ""),
                     behaviour_on(rnd.factory, rnd.nominal.channels, rnd.train, effect))

    def family(self, effect: EffectSpec, facts: Facts) -> str:
        """Return the family of what the fitted law does on the record, else :func:`family_of`.

        Where its behaviour (``facts.behaviour``) and the law's own family disagree in kind
        (linear, dissipative, elastic), the behaviour wins: a Bouc-Wen fit that is a plain
        dashpot reports damping, a bilinear spring whose fit encloses loops hysteresis
        (:func:`.behaviour.reported_family`).
        """
        return reported_family(facts.behaviour, family_of(effect, facts))

    def start(self, factory: ModelFactory, component: str, law: str, train: Record
              ) -> dict[str, float]:
        """Return the middle of the law's grid, scaled to the measured drift and force."""
        if component not in factory.sites:
            msg = f"unknown component {component!r}; components: {sorted(factory.sites)}"
            raise OptionError(msg)
        chans = factory.plant().channels
        cols = measured_device(chans, train, component)
        if cols is None:
            want = [*device_channels(chans, component, "device_drift"),
                    *device_channels(chans, component, "device_force")]
            missing = [c for c in want if c not in train.channel_names] or [
                f"the drift and force of {component} (x, y)"]
            msg = f"{law} at {component}: the training record lacks {missing}"
            raise OptionError(msg)
        u, f = train.channels(cols[0]), train.channels(cols[1])
        grid = parameter_grid(law, float(np.abs(u).max()), float(np.abs(f).max()),
                              float(np.mean(factory.sites[component].k)),
                              factory.weight(component))
        return grid[len(grid) // 2]

    def fit(self, factory: ModelFactory, component: str, law: str, start: dict[str, float],
            train: Record, test: Record) -> FittedEffect:
        """:func:`.fitting.fit_effect`."""
        return fit_effect(factory, component, law, start, train, test)

    def joint(self, factory: ModelFactory, effect: EffectSpec) -> Piece | None:
        """Return the law's bounded transform (:func:`.fitting._transform`) from its values."""
        spec = factory.sites.get(effect.component)
        if spec is None:
            return None
        start = dict(effect.params)
        if effect.law == "linear":
            start.setdefault("c0", float(np.mean(spec.c)) or 1.0)
        try:
            names, to_p, to_x, lo_x, hi_x = _transform(effect.law, start,
                                                       float(np.mean(spec.k)))
        except ModalTwinError:
            return None
        x0 = np.clip(to_x(start), lo_x + 1e-9, hi_x - 1e-9)
        keep_all = effect.law == "linear"

        def params(x: np.ndarray) -> dict[str, float]:
            return {n: v for n, v in to_p(x).items() if keep_all or n in names}

        # the size is the coordinates', not the names': a parameter held as started (the
        # gap's kp, the Bouc-Wen's uncoupled form) is named but has no coordinate
        return x0.size, params, x0, lo_x, hi_x


_Share = tuple[FloatArray, FloatArray] | None
_SiteEvidence = tuple[DeviceEvidence, np.ndarray, np.ndarray, float, _Share]


def _site_evidence(rnd: Round, comp: str) -> _SiteEvidence | None:
    """Return the evidence at ``comp``, its drift, force, rate and input share.

    The input share: the input's own part of the drift and its rate there
    (:func:`input_share`).

    From the training record; when it names no family there, from the first other level
    the fits use (``rnd.fit_on``) whose evidence names one: a law with a threshold (a
    friction force, a clearance) can leave a small share of the force at one level (a
    slider that slips beside a large viscous force) and most of it at another (the same
    slider stuck at a low level). Where the training record named none only because its
    nominal law leaves under 1 % of the force (``min_share`` of
    :func:`.evidence.device_evidence`), the other level has shown the site is not nominal,
    so the training record is read again in full (:func:`_read_in_full`) and its families
    taken when it names any (a stuck slider reads as a stiff spring or a dashpot at the low
    level, the slipping one as friction on the strong record); the laws' starts are still
    screened on the other level, where the law's share of the force is large. None when
    the site's drift and force are not measured.
    """
    first: _SiteEvidence | None = None
    first_i = -1
    for i, rec in enumerate(rnd.records):
        if i == 1:  # the held-out record never informs a candidate
            continue
        got = _evidence_on(rnd, comp, i)
        if got is None:
            continue
        if _top_family(got[0]) == "nothing":
            if first is None:
                first, first_i = got, i
            continue
        if first is None:
            return got
        name = rec.source or f"record {i}"
        full = _read_in_full(rnd, comp, first_i, name)
        if full is not None:  # its families; the starts screened where the law shows most
            return (full, *got[1:])
        ev = replace(got[0], notes=(*got[0].notes, f"from {name}: the training record "
                                    "names no family here"))
        return (ev, *got[1:])
    return first


def _evidence_on(rnd: Round, comp: str, i: int, min_share: float = 0.01
                 ) -> _SiteEvidence | None:
    """Return the evidence at ``comp`` on ``rnd.records[i]`` (None when not measured)."""
    rec = rnd.records[i]
    cols = measured_device(rnd.nominal.channels, rec, comp)
    if cols is None:
        return None
    spec = rnd.factory.sites[comp]
    noise = dict(zip(rec.channel_names, rnd.noise[i], strict=True))
    u, f = rec.channels(cols[0]), rec.channels(cols[1])
    fv = [(noise[n] * float(np.std(f[j]))) ** 2 for j, n in enumerate(cols[1])]
    share = input_share(rnd.factory, comp, rec, u.shape[0])
    ev = device_evidence(comp, u, f, spec.k, spec.c, rec.fs_hz, noise_var=fv,
                         min_share=min_share, input_share=share)
    return ev, u, f, rec.fs_hz, share


def _read_in_full(rnd: Round, comp: str, i: int, other: str) -> DeviceEvidence | None:
    """Return the evidence of record ``i`` at ``comp`` without the 1 % cut, when it names one.

    Its regression then judges the residual against the noise alone (a family must still
    beat ``p ln N`` noise variances and 10 % of the residual); None when it names none.
    """
    got = _evidence_on(rnd, comp, i, min_share=0.0)
    if got is None or _top_family(got[0]) == "nothing":
        return None
    ev = got[0]
    note = (f"read in full: {other} shows the site is not nominal (the nominal law leaves "
            f"{100 * ev.residual_share:.2f} % of the force here); the starts screened on "
            f"{other}")
    return replace(ev, notes=(*ev.notes, note))


def _laws_named(ev: DeviceEvidence, n_families: int) -> tuple[str, ...]:
    """Every law of the family the evidence names first, the first law of the next ones.

    Nonlinear families go first; where a linear one still leads the evidence, its laws
    with memory (:data:`_LINEAR_WITH_MEMORY`: damping, a ``maxwell`` damper) are tried
    beside them.
    """
    sc = ev.family_scores()
    fams = [g for g in sorted(sc, key=lambda g: -sc[g]) if sc[g] > 0]
    nonlinear = [g for g in fams if g not in _LINEAR]
    lead = fams[0] if fams else ""
    fams = (nonlinear or fams)[:n_families]
    first = list(FAMILY_LAWS.get(fams[0], ())) if fams else []
    rest = [x for g in fams[1:] for x in FAMILY_LAWS.get(g, ())[:1]]
    if nonlinear:
        rest += list(_LINEAR_WITH_MEMORY.get(lead, ()))
    return tuple(dict.fromkeys(first + rest))


def _top_family(e: DeviceEvidence) -> str:
    sc = e.family_scores()
    nonlinear = {g: s for g, s in sc.items() if g not in _LINEAR and s > 0}
    pick = nonlinear or {g: s for g, s in sc.items() if s > 0}
    return max(pick, key=lambda g: pick[g]) if pick else "nothing"


def evidence_of(candidates: Sequence[DeviceCandidate]) -> tuple[DeviceEvidence, ...]:
    """Return the evidence of every screened site."""
    return tuple(c.evidence for c in candidates)


DEVICE = DeviceKind()
