"""The diagnosis: where the model fails, which family of effect is missing, at which place.

One round (:func:`diagnose_round`) on a model (any version: its effects stay in place):

1. **Compare** on every record given (training, held-out, other levels): the normalised
   RMS of the residual per channel against the noise floor estimated from each record
   (:mod:`.noise`). The model fails where a channel's error exceeds twice its floor (an
   error beyond noise of 1.7x the noise itself); nothing else is significant.
2. **Where**: the held-out residual by place, direction, quantity, band and level
   (:mod:`.where`), and the modal view (:mod:`.modal_view`).
3. **Evidence before fits** (:mod:`.evidence`): at every component with measured drift and
   force, cycles (energy and secant stiffness against amplitude) and the family scores of
   a sparse regression of the residual restoring force (Eq. 20 of [003]); for parameters,
   the share of the residual their sensitivities explain (:mod:`.parameters`: mass with its
   place, stiffness of any element group, damping); for rigidly attached masses, elastic
   mounts (:mod:`.attachments`); for single channels, a gain or an orientation
   (:mod:`.sensors`).
4. **Fit laws of the named families** by simulation on the training record, then judge
   each on every record (:mod:`.judge`: lower on training and held-out, never worse on
   another level; flags for bounds and implausible values; ranked by held-out error and
   BIC together).

:func:`diagnose` repeats rounds while the model still fails and a candidate is accepted
(several effects at once), then refits all effects found jointly.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, replace
from functools import partial
from typing import Any

import numpy as np

from modal_twin.diagnosis.attachments import (
    AttachmentCandidate,
    fit_attachment,
    screen_attachments,
)
from modal_twin.diagnosis.evidence import DeviceEvidence, device_evidence
from modal_twin.diagnosis.families import FAMILY_LAWS
from modal_twin.diagnosis.fitting import FittedEffect, fit_effect, simulate_record
from modal_twin.diagnosis.joint import refit_jointly
from modal_twin.diagnosis.judge import (
    figures_on,
    judge,
    rank,
    record_noise_floors,
    worse_tolerance,
)
from modal_twin.diagnosis.modal_view import ModalView, modal_view
from modal_twin.diagnosis.noise import SIGNIFICANT_RATIO, ErrorFigures
from modal_twin.diagnosis.parameters import ParameterCandidate, fit_parameter, screen_parameters
from modal_twin.diagnosis.record import Record
from modal_twin.diagnosis.screening import ScreenedCandidate, screen_components
from modal_twin.diagnosis.sensors import SensorCandidate, fit_sensor, screen_sensors
from modal_twin.diagnosis.where import WhereReport, where_it_fails
from modal_twin.errors import ModalTwinError
from modal_twin.models.loading import ModelFactory, with_effects
from modal_twin.models.plant import Plant

__all__ = ["Diagnosis", "diagnose", "diagnose_round"]

log = logging.getLogger(__name__)

Mapper = Callable[..., Iterable[Any]]


@dataclass(frozen=True, slots=True)
class Diagnosis:
    """Outcome of :func:`diagnose` (or of one round)."""

    significant: bool
    summary: str
    where: WhereReport
    screened: tuple[ScreenedCandidate, ...]
    parameters: tuple[ParameterCandidate, ...]
    fitted: tuple[FittedEffect, ...]  # ranked (judge.rank): usable first
    skipped: tuple[str, ...]
    modal: ModalView | None = None  # identified vs model modes, held-out record
    attachments: tuple[AttachmentCandidate, ...] = ()  # rigid masses hung elastically
    evidence: tuple[DeviceEvidence, ...] = ()
    sensors: tuple[SensorCandidate, ...] = ()
    before: tuple[ErrorFigures, ...] = ()  # the model as given, every record
    after: tuple[ErrorFigures, ...] = ()  # with every effect found, every record
    found: tuple[FittedEffect, ...] = ()  # effects accepted, in the order found (refitted)
    rounds: int = 1

    @property
    def best(self) -> FittedEffect | None:
        """The first effect found (None when nothing significant or nothing accepted)."""
        if self.found:
            return self.found[0]
        usable = [f for f in self.fitted if not f.rejected and not f.flags]
        return usable[0] if self.significant and usable else None

    def format(self) -> str:
        """Report text: errors against noise, where, evidence, candidates, decision."""
        out = ["MODEL AGAINST MEASUREMENT (NRMSE = RMS(measured - model) / RMS(measured), "
               "median over channels; noise floor from each record)"]
        out += [f"  before: {f.line()}" for f in self.before]
        out += [f"  after:  {f.line()}" for f in self.after if self.found]
        out += ["", "WHERE THE MODEL FAILS (held-out record)", self.where.format(), ""]
        if self.modal is not None:
            out += ["MODAL VIEW (N4SID of the held-out record vs the model's modes)",
                    self.modal.format(), ""]
        if self.evidence:
            out.append("EVIDENCE AT THE DEVICES (training record, before any fit)")
            out += ["  " + e.format() for e in self.evidence]
            out.append("")
        out.append("OTHER CANDIDATES (screened on the training record)")
        for pc in self.parameters[:4]:
            out.append(f"  {pc.name:<12} {pc.kind:<14} removes {100 * pc.gain:6.2f} % of the "
                       f"residual (start {pc.start:.4g}, nominal {pc.nominal:.4g})")
        for ac in self.attachments[:4]:
            out.append(f"  {ac.component:<12} {'elastic_mount':<14} removes {100 * ac.gain:6.2f} "
                       f"% of the residual (best mount frequency {ac.f_hz:.3g} Hz)")
        for sc in self.sensors[:4]:
            out.append(f"  {sc.channel:<12} {sc.law:<14} removes {100 * sc.gain:6.2f} % of its "
                       f"residual ({sc.value:.4g})")
        out += ["", "FITTED BY SIMULATION (NRMSE as RMS over channels: train / held-out, before "
                "-> after; ranked)"]
        for f in self.fitted:
            recs = "; ".join(f"{100 * b:.2f}->{100 * a:.2f} %" for _, b, a, *_ in f.records[:2])
            state = ("REJECTED: " + f.rejected) if f.rejected else (
                "FLAGGED: " + "; ".join(f.flags) if f.flags else "accepted")
            out.append(f"  {f.place:<10} {f.family:<12} {f.effect.law:<20} {recs:<28} "
                       f"BIC {f.bic:10.1f}  {state}\n      {f.parameter_text()}")
        for s in self.skipped:
            out.append(f"  skipped: {s}")
        out += ["", f"DECISION: {self.summary}"]
        return "\n".join(out)


def _device_data(rec: Record, names: Iterable[str]) -> tuple[dict, dict]:
    drifts, forces = {}, {}
    for n in names:
        cols_d, cols_f = [f"{n}_dx", f"{n}_dy"], [f"{n}_fx", f"{n}_fy"]
        if all(c in rec.channel_names for c in cols_d + cols_f):
            drifts[n], forces[n] = rec.channels(cols_d), rec.channels(cols_f)
    return drifts, forces


def _common_channels(factory: ModelFactory, records: Sequence[Record]
                     ) -> tuple[list[Record], list[str]]:
    names = set(factory.plant().channel_names)
    skipped = [f"channel {c}: not in the model" for c in records[0].channel_names
               if c not in names]
    keep = [c for c in records[0].channel_names if c in names]
    return [r.with_channels(keep) if skipped else r for r in records], skipped


def _significant(figs: Sequence[ErrorFigures]) -> tuple[str, ...]:
    out: list[str] = []
    for f in figs:
        out += [c for c in f.significant_channels(SIGNIFICANT_RATIO) if c not in out]
    return tuple(out)


def _device_jobs(factory: ModelFactory, fit_on: tuple[Record, ...],
                 evidence: Sequence[DeviceEvidence], drifts: dict, forces: dict,
                 test: Record, n_families: int
                 ) -> tuple[list[ScreenedCandidate], list[tuple[str, Callable[[], FittedEffect]]]]:
    train = fit_on[0]
    screened: list[ScreenedCandidate] = []
    jobs: list[tuple[str, Callable[[], FittedEffect]]] = []
    for ev in evidence:
        sc = ev.family_scores()
        fams = [g for g in sorted(sc, key=lambda g: -sc[g]) if sc[g] > 0]
        nonlinear = [g for g in fams if g not in ("stiffness", "damping")]
        fams = (nonlinear or fams)[:n_families]
        # every law of the family named first, the first law of the next one
        first = list(FAMILY_LAWS.get(fams[0], ())) if fams else []
        laws = tuple(dict.fromkeys(first + [x for g in fams[1:]
                                            for x in FAMILY_LAWS.get(g, ())[:1]]))
        if not laws:
            continue
        comp = ev.component
        scr = screen_components({comp: drifts[comp]}, {comp: forces[comp]},
                                {comp: factory.sites[comp]}, {comp: factory.weight(comp)},
                                train.fs_hz, laws=tuple(x for x in laws if x != "linear"))
        screened += scr
        starts = {c.law: c.params for c in scr}
        for law in laws:
            if law == "linear":
                jobs.append((f"linear at {comp}",
                             partial(fit_effect, factory, comp, "linear", {}, fit_on, test)))
            elif law in starts:
                jobs.append((f"{law} at {comp}", partial(fit_effect, factory, comp, law,
                                                         starts[law], fit_on, test)))
    return screened, jobs


def diagnose_round(factory: ModelFactory, records: Sequence[Record], *, n_fit: int = 3,
                   gain_threshold: float = 0.01, n_families: int = 2,
                   progress: Callable[[str], None] | None = None, mapper: Mapper = map,
                   exclude: Iterable[tuple[str, str]] = ()) -> Diagnosis:
    """One round on ``factory``'s model.

    ``records[0]`` trains, ``records[1]`` is held out, the rest are other levels the result
    must not be worse on (module docstring).
    """
    say = progress or (lambda s: None)
    records, skipped = _common_channels(factory, records)
    train, test = records[0], records[1]
    nominal = factory.plant()
    noises = record_noise_floors(nominal, records)
    say("simulating the model on every record")
    before = figures_on(nominal, records, noises)
    where, modal = _where_and_modal(nominal, test, skipped)
    sig = _significant(before)
    if not sig:
        worst = max(before, key=lambda f: f.median_over_noise)
        summary = (f"nothing significant is missing: every channel is within "
                   f"{SIGNIFICANT_RATIO}x its noise floor on every record (worst median "
                   f"x{worst.median_over_noise:.2f} on {worst.record or 'a record'})")
        return Diagnosis(False, summary, where, (), (), (), tuple(skipped), modal,
                         before=before, after=before)
    say("gathering evidence at the devices (force-state maps, cycles)")
    evidence, drifts, forces = _evidence(factory, train, noises[0], skipped)
    # fits use every record but the held-out one: a low-level record pins what a law does
    # where it barely engages (a break-away force, an initial stiffness)
    fit_on = (train, *records[2:])
    screened, jobs = _device_jobs(factory, fit_on, evidence, drifts, forces, test, n_families)
    say("screening parameters (mass, stiffness, damping) by simulated sensitivities")
    params = screen_parameters(factory, train)
    attachments: list[AttachmentCandidate] = []
    if tuple(factory.attachments()):
        say("screening elastic mounts of the rigidly attached masses")
        attachments = screen_attachments(factory, train)
    sensors = screen_sensors(train.channel_names, train.scored,
                             simulate_record(nominal, train)[:, train.skip:], sig,
                             fs_hz=train.fs_hz)
    jobs += _global_jobs(factory, fit_on, test, params, attachments, sensors, n_fit,
                         gain_threshold)
    fitted = [f for f in _run_jobs(jobs, mapper, skipped, say)
              if (f.effect.component, f.effect.law) not in set(exclude)]
    ev_family = {e.component: _top_family(e) for e in evidence}
    # a later round must earn its effect: 5 % lower, not 1 %
    lower_by = 0.05 if factory.base_effects or set(exclude) else 0.01
    ranked = rank([_judge(factory, f, before, records, noises, ev_family, lower_by)
                   for f in fitted], ev_family)
    return Diagnosis(True, _round_summary(ranked, sig), where, tuple(screened), tuple(params),
                     tuple(ranked), tuple(skipped), modal, tuple(attachments),
                     tuple(evidence), tuple(sensors), before, before)


def _where_and_modal(nominal: Plant, test: Record, skipped: list[str]
                     ) -> tuple[WhereReport, ModalView | None]:
    """Return where the model fails on the held-out record, and its modal view."""
    pred_test = simulate_record(nominal, test)
    specs = {c.name: c for c in nominal.channels}
    where = where_it_fails(test.scored, pred_test[:, test.skip:],
                           tuple(specs[c] for c in test.channel_names), test.fs_hz,
                           inputs=test.inputs[:, test.skip:])
    modal: ModalView | None = None
    try:
        modal = modal_view(nominal, test)
    except (ModalTwinError, ValueError, np.linalg.LinAlgError) as err:
        skipped.append(f"modal view: {err}")
    return where, modal


def _evidence(factory: ModelFactory, train: Record, noise: np.ndarray, skipped: list[str]
              ) -> tuple[list[DeviceEvidence], dict, dict]:
    """Evidence at every component with measured drift and force (not one with an effect).

    A component that already carries an effect is refined by the joint refit, not screened
    again.
    """
    carried = {e.component for e in factory.base_effects}
    drifts, forces = _device_data(train, [s for s in factory.sites if s not in carried])
    if not drifts and factory.sites:
        skipped.append("evidence: no component has measured drift and force")
    tr_noise = dict(zip(train.channel_names, noise, strict=True))
    evidence = []
    for comp in drifts:
        fv = [(tr_noise[f"{comp}_f{a}"] * float(np.std(forces[comp][i]))) ** 2
              for i, a in enumerate("xy")]
        spec = factory.sites[comp]
        evidence.append(device_evidence(comp, drifts[comp], forces[comp], spec.k, spec.c,
                                        train.fs_hz, noise_var=fv))
    return evidence, drifts, forces


def _global_jobs(factory: ModelFactory, fit_on: tuple[Record, ...], test: Record,
                 params: Sequence[ParameterCandidate],
                 attachments: Sequence[AttachmentCandidate],
                 sensors: Sequence[SensorCandidate], n_fit: int, gain_threshold: float
                 ) -> list[tuple[str, Callable[[], FittedEffect]]]:
    """Fit jobs of the parameter, mount and sensor candidates worth a simulation."""
    jobs: list[tuple[str, Callable[[], FittedEffect]]] = []
    for pc in params[:n_fit + 2]:  # parameters are many and cheap to fit
        if pc.gain >= gain_threshold:
            jobs.append((f"{pc.kind} {pc.name}",
                         partial(fit_parameter, factory, pc, fit_on, test)))
    for ac in attachments[:n_fit]:
        if ac.gain >= gain_threshold:
            jobs.append((f"elastic_mount at {ac.component}", partial(
                fit_attachment, factory, ac.component, {"f_hz": ac.f_hz}, fit_on, test)))
    for sc in sensors[:n_fit]:
        jobs.append((f"{sc.law} at {sc.channel}",
                     partial(fit_sensor, factory, sc, fit_on[0], test)))
    return jobs


def _round_summary(ranked: Sequence[FittedEffect], sig: Sequence[str]) -> str:
    usable = [f for f in ranked if not f.rejected and not f.flags]
    if not usable:
        return (f"the model fails ({len(sig)} channels above {SIGNIFICANT_RATIO}x their "
                "noise floor) but no candidate lowers the error on every record")
    b = usable[0]
    return (f"missing: {b.family} at {b.place} ({b.effect.law}) -- held-out NRMSE "
            f"{100 * b.records[1][1]:.2f} % -> {100 * b.records[1][2]:.2f} % "
            f"(x{b.records[1][3]:.2f} the noise floor)")


def _top_family(e: DeviceEvidence) -> str:
    sc = e.family_scores()
    nonlinear = {g: s for g, s in sc.items() if g not in ("stiffness", "damping") and s > 0}
    pick = nonlinear or {g: s for g, s in sc.items() if s > 0}
    return max(pick, key=lambda g: pick[g]) if pick else "nothing"


def _run_jobs(jobs: Sequence[tuple[str, Callable[[], FittedEffect]]], mapper: Mapper,
              skipped: list[str], say: Callable[[str], None]) -> list[FittedEffect]:
    say(f"fitting {len(jobs)} candidates by simulation")
    out: list[FittedEffect] = []
    for (label, _), res in zip(jobs, mapper(_call, [j for _, j in jobs]), strict=True):
        if isinstance(res, str):
            skipped.append(f"{label}: {res}")
        else:
            out.append(res)
    return out


def _call(job: Callable[[], FittedEffect]) -> FittedEffect | str:
    """Run one fit; a refused fit comes back as its message (executors keep going)."""
    try:
        return job()
    except (ModalTwinError, ValueError, np.linalg.LinAlgError) as err:
        return str(err)


def _judge(factory: ModelFactory, f: FittedEffect, before: Sequence[ErrorFigures],
           records: Sequence[Record], noises: Sequence[np.ndarray],
           ev_family: dict[str, str], lower_by: float) -> FittedEffect:
    e = f.effect
    if e.law in ("added_mass", "stiffness", "damping"):
        plant = factory.with_theta(e.params).plant()
    else:
        plant = factory.plant([e])
    spec = factory.sites.get(e.component)
    k = float(np.mean(spec.k)) if spec is not None and hasattr(spec, "k") else None
    c = float(np.mean(spec.c)) if spec is not None and hasattr(spec, "c") else None
    values = factory.parameters()
    floor = {n: v for n, v in values.items() if n.startswith("m_")}
    cols = [f"{e.component}_d{a}" for a in "xy"]
    drift = (float(np.quantile(np.abs(records[0].channels(cols)), 0.99))
             if all(x in records[0].channel_names for x in cols) else None)
    out = judge(f, plant, before, records, noises, nominal_values=values, floor_mass=floor,
                nominal_k=k, nominal_c=c, drift_scale=drift,
                evidence_family=ev_family.get(e.component, ""), lower_by=lower_by)
    info_of = getattr(factory, "parameter_info", None)
    if e.law in ("added_mass", "stiffness", "damping") and info_of is not None:
        with contextlib.suppress(ModalTwinError):
            out = replace(out, place=info_of(e.component).place)
    return out


def _apply(factory: ModelFactory, f: FittedEffect) -> ModelFactory:
    if f.effect.law in ("added_mass", "stiffness", "damping"):
        return factory.with_theta(f.effect.params)
    return with_effects(factory, [f.effect])


def _apply_all(factory: ModelFactory, found: Sequence[FittedEffect]) -> ModelFactory:
    for f in found:
        factory = _apply(factory, f)
    return factory


def _without_idle(factory: ModelFactory, found: list[FittedEffect], records: Sequence[Record],
                  noises: Sequence[np.ndarray], say: Callable[[str], None]
                  ) -> list[FittedEffect]:
    """Drop effects the others made idle (backward elimination after the joint refit).

    An effect found early can stand in for one found later (a column line for the storey
    it belongs to); after the joint refit it may do nothing. It is dropped when the model
    without it is not worse on any record (within the sampling tolerance of an RMS).
    """
    keep = list(found)
    for f in list(found):
        if len(keep) < 2:
            break
        rest = [g for g in keep if g is not f]
        with_all = figures_on(_apply_all(factory, keep).plant(), records, noises)
        without = figures_on(_apply_all(factory, rest).plant(), records, noises)
        if all(b.score <= a.score * (1.0 + worse_tolerance(r))
               for a, b, r in zip(with_all, without, records, strict=True)):
            say(f"dropped {f.family} at {f.place}: the other effects do its work")
            keep = rest
    return keep


def diagnose(
    factory: ModelFactory,
    train: Record,
    test: Record,
    *,
    levels: Sequence[Record] = (),
    n_fit: int = 3,
    max_effects: int = 3,
    gain_threshold: float = 0.01,
    progress: Callable[[str], None] | None = None,
    mapper: Mapper = map,
    joint: bool = True,
    **_ignored: object,
) -> Diagnosis:
    """Diagnose ``factory``'s model.

    (any version) against a training and a held-out record and any other records (``levels``,
    e.g. a low-level run): rounds while the model still fails and a candidate is accepted, then
    a joint refit of everything found.

    Parameters
    ----------
    n_fit : int
        Parameter, mount and sensor candidates fitted by simulation per round.
    max_effects : int
        Effects found at most.
    mapper : callable
        ``map``-like function the fits go through (``Executor.map`` for a process pool or
        a Dask cluster); the default runs them one after another.

    """
    say = progress or (lambda s: None)
    records = [train, test, *levels]
    first = diagnose_round(factory, records, n_fit=n_fit, gain_threshold=gain_threshold,
                           progress=progress, mapper=mapper)
    found: list[FittedEffect] = []
    current, d = factory, first
    while d.significant and d.best is not None and len(found) < max_effects:
        found.append(d.best)
        current = _apply(current, d.best)
        say(f"effect {len(found)}: {d.best.family} at {d.best.place}; looking for the next")
        exclude = {(f.effect.component, f.effect.law) for f in found}
        d = diagnose_round(current, records, n_fit=n_fit, gain_threshold=gain_threshold,
                           progress=progress, mapper=mapper, exclude=exclude)
    if not found:
        return first
    if joint and len(found) > 1:
        say("refitting all effects found jointly")
        found = refit_jointly(factory, found, (records[0], *records[2:]))
    rec_c, _ = _common_channels(factory, records)
    noises = [f.noise for f in first.before]  # the floors of the model as given
    if len(found) > 1:
        found = _without_idle(factory, found, rec_c, noises, say)
    after = figures_on(_apply_all(factory, found).plant(), rec_c, noises)
    names = ", ".join(f"{f.family} at {f.place} ({f.effect.law})" for f in found)
    b, a = first.before[1], after[1]
    summary = (f"missing: {names} -- held-out NRMSE {100 * b.median_nrmse:.2f} % -> "
               f"{100 * a.median_nrmse:.2f} % median over channels (x{a.median_over_noise:.2f} "
               f"the noise floor; Eq. (8) of [004] median {100 * float(np.nanmedian(b.eq8)):.2f}"
               f" % -> {100 * float(np.nanmedian(a.eq8)):.2f} %)")
    if d.significant and d.best is None and len(found) < max_effects:
        summary += f"; still above the noise after that: {d.summary}"
    return replace(first, summary=summary, found=tuple(found), after=after,
                   rounds=len(found) + 1)
