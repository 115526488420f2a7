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
   BIC together). A device law reports the family of what its fit does on the training
   record (:mod:`.behaviour`), its name beside it.

:func:`diagnose` repeats rounds while the model still fails and a candidate is accepted
(several effects at once), chooses again the law of each device effect found before the
last with the others in place, then refits all effects found jointly and drops, by backward
elimination on the whitened information criterion, those the data do not demand.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import partial
from typing import Any

import numpy as np

from modal_twin.diagnosis.device_kind import DeviceCandidate, _top_family
from modal_twin.diagnosis.effect_kind import Job, Round
from modal_twin.diagnosis.evidence import DeviceEvidence
from modal_twin.diagnosis.fitting import FittedEffect, simulate_record
from modal_twin.diagnosis.joint import refit_jointly
from modal_twin.diagnosis.judge import (
    figures_on,
    labelled,
    rank,
    record_noise_floors,
    with_noise_floors,
)
from modal_twin.diagnosis.kinds import KINDS, kind_of
from modal_twin.diagnosis.modal_view import ModalView, modal_view
from modal_twin.diagnosis.noise import SIGNIFICANT_RATIO, ErrorFigures
from modal_twin.diagnosis.record import Record
from modal_twin.diagnosis.refine import (
    Mapper,
    RoundRow,
    apply_all,
    apply_effect,
    fit_records,
    judged,
    paired,
    places_rechosen,
    run_jobs,
    sampling_tolerances,
    whitened_criterion,
    without_idle,
)
from modal_twin.diagnosis.where import WhereReport, where_it_fails
from modal_twin.errors import ModalTwinError
from modal_twin.models.loading import ModelFactory
from modal_twin.models.plant import Plant

__all__ = ["Diagnosis", "diagnose", "diagnose_round"]

log = logging.getLogger(__name__)

@dataclass(frozen=True, slots=True)
class Diagnosis:
    """Outcome of :func:`diagnose` (or of one round)."""

    significant: bool
    summary: str
    where: WhereReport
    fitted: tuple[FittedEffect, ...]  # ranked (judge.rank): usable first
    skipped: tuple[str, ...]
    modal: ModalView | None = None  # identified vs model modes, held-out record
    # every effect kind's screened candidates, best first (kind name -> candidates)
    candidates: Mapping[str, tuple[Any, ...]] = field(default_factory=dict)
    before: tuple[ErrorFigures, ...] = ()  # the model as given, every record
    after: tuple[ErrorFigures, ...] = ()  # with every effect found, every record
    found: tuple[FittedEffect, ...] = ()  # effects accepted, in the order found (refitted)
    rounds: int = 1
    # effects found but dropped by the backward elimination after the joint refit, with why
    dropped: tuple[str, ...] = ()
    # every round's ranked fits and its decision (empty: one round, ``fitted`` / ``summary``)
    round_fits: tuple[tuple[FittedEffect, ...], ...] = ()
    round_summaries: tuple[str, ...] = ()
    # per round its heading (the model it ran on; a law chosen again: which and where) and
    # the fit it took (None: none); empty: the headings and fits of forward rounds only
    round_titles: tuple[str, ...] = ()
    round_added: tuple[FittedEffect | None, ...] = ()

    @property
    def evidence(self) -> tuple[DeviceEvidence, ...]:
        """The evidence at every device site screened (training record, before any fit)."""
        return tuple(c.evidence for c in self.candidates.get("device", ())
                     if isinstance(c, DeviceCandidate))

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
        for name, kind in KINDS.items():
            out += kind.report(self.candidates.get(name, ()))
        out += ["", *self.table()]
        for s in self.skipped:
            out.append(f"  skipped: {s}")
        if self.dropped:
            out += ["", "DROPPED AFTER THE JOINT REFIT (backward elimination on the whitened "
                    "information criterion over every record)"]
            out += [f"  {w}" for w in self.dropped]
        out += ["", f"DECISION: {self.summary}"]
        return "\n".join(out)

    def table(self) -> list[str]:
        """Return the ranked fits of every round, each with its figures, decision and reason.

        One table for ``diagnose`` and ``effects add --auto``: per candidate its place,
        family (with the law fitted and what it does), NRMSE before -> after on the
        training and held-out records, BIC, and ADDED / accepted / FLAGGED (why) /
        REJECTED (the record and the figure it failed on); per round its decision; a round
        that chose an early device law again (:func:`_reselected`) as its own round, the
        law it took in place of the first marked ADDED; last, the effects found (after the
        joint refit).
        """
        fits = self.round_fits or (self.fitted,)
        summaries = self.round_summaries or (self.summary,)
        out = ["FITTED BY SIMULATION (NRMSE as RMS over channels: train / held-out, before "
               "-> after; ranked, every round)"]
        for i, (ranked, summary) in enumerate(zip(fits, summaries, strict=True)):
            added = self.added_in_round(i)
            out.append(f" {self.round_title(i)}")
            out += [_fit_line(f, f is added) for f in ranked] or ["  no candidate fitted"]
            out.append(f"  decision: {summary}")
        if self.found:
            out.append(" effects found (refitted jointly where several)")
            out += [f"  {f.place:<10} {f.family_text()}\n      {f.parameter_text()}"
                    for f in self.found]
        return out

    def round_title(self, i: int) -> str:
        """Return round ``i``'s heading: the model it ran on (a law chosen again: which)."""
        if self.round_titles:
            return self.round_titles[i]
        return _forward_title(i, self.found[:i])

    def added_in_round(self, i: int) -> FittedEffect | None:
        """Return the fit round ``i`` added (its best usable one), None when it added none.

        A round that chose a law again: the law it took in place of the first (None when
        it kept that one).
        """
        if self.round_added:
            return self.round_added[i] if i < len(self.round_added) else None
        fits = self.round_fits or (self.fitted,)
        if i >= len(self.found) or i >= len(fits):
            return None
        return next((f for f in fits[i] if not f.rejected and not f.flags), None)


    def to_dict(self) -> dict[str, Any]:
        """Return the decision, the effects found and the table of every round, as JSON data.

        The same rounds (``title``: :meth:`round_title`), rows and decisions as :meth:`table`
        (``decision``: ADDED, accepted, FLAGGED or REJECTED; ``reason``: the flags or the
        record and figure it failed on).
        """
        fits = self.round_fits or (self.fitted,)
        summaries = self.round_summaries or (self.summary,)
        return {
            "significant": self.significant, "summary": self.summary,
            "found": [_fit_row(f) for f in self.found],
            "rounds": [{"title": self.round_title(i), "decision": summary, "candidates": [
                _fit_row(f, _decision(f, f is self.added_in_round(i))) for f in ranked]}
                for i, (ranked, summary) in enumerate(zip(fits, summaries, strict=True))],
            "dropped": list(self.dropped), "skipped": list(self.skipped)}


def _forward_title(i: int, with_: Sequence[FittedEffect]) -> str:
    """Heading of forward round ``i``: the model as given with the effects added before."""
    names = ", ".join(f"{f.family} at {f.place}" for f in with_)
    return f"round {i + 1}: the model as given" + (f" with {names}" if names else "")


def _decision(f: FittedEffect, added: bool) -> tuple[str, str]:
    """Return a candidate's decision (ADDED, accepted, FLAGGED, REJECTED) and its reason."""
    if f.rejected:
        return "REJECTED", f.rejected
    if f.flags:
        return "FLAGGED", "; ".join(f.flags)
    return ("ADDED" if added else "accepted"), ""


def _fit_row(f: FittedEffect, decision: tuple[str, str] | None = None) -> dict[str, Any]:
    """One candidate (or effect found) as JSON data: what :func:`_fit_line` prints."""
    row: dict[str, Any] = {
        "place": f.place, "family": f.family, "behaviour": f.behaviour, "law": f.effect.law,
        "component": f.effect.component, "params": dict(f.effect.params), "bic": f.bic,
        "records": [{"record": r[0], "nrmse_before": r[1], "nrmse_after": r[2],
                     "after_over_noise": r[3]} for r in f.records]}
    if decision is not None:
        row["decision"], row["reason"] = decision
    return row


def _fit_line(f: FittedEffect, added: bool) -> str:
    """One candidate of :meth:`Diagnosis.table`: figures, decision and reason, its words."""
    recs = "; ".join(f"{100 * b:.2f}->{100 * a:.2f} %" for _, b, a, *_ in f.records[:2])
    decision, reason = _decision(f, added)
    state = f"{decision}: {reason}" if reason else decision
    line = (f"  {f.place:<10} {f.family:<12} {f.effect.law:<20} {recs:<28} "
            f"BIC {f.bic:10.1f}  {state}\n      {f.parameter_text()}")
    return line + (f"\n      {f.family_text()}" if f.behaviour else "")


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


def diagnose_round(factory: ModelFactory, records: Sequence[Record], *, n_fit: int = 3,
                   gain_threshold: float = 0.01, n_families: int = 2,
                   progress: Callable[[str], None] | None = None, mapper: Mapper = map,
                   exclude: Iterable[tuple[str, str]] = (), only: str = "") -> Diagnosis:
    """One round on ``factory``'s model.

    ``records[0]`` trains, ``records[1]`` is held out, the rest are other levels the result
    must not be worse on (module docstring). ``only``: fit the laws at that device site only.
    """
    say = progress or (lambda s: None)
    records, skipped = _common_channels(factory, records)
    test = records[1]
    nominal = factory.plant()
    noises = record_noise_floors(nominal, records)
    records = with_noise_floors(records, noises)  # the fits whiten as the judge does
    say("simulating the model on every record")
    before = figures_on(nominal, records, noises)
    where, modal = _where_and_modal(nominal, test, skipped)
    sig = _significant(before)
    if not sig:
        worst = max(before, key=lambda f: f.median_over_noise)
        summary = (f"nothing significant is missing: every channel is within "
                   f"{SIGNIFICANT_RATIO}x its noise floor on every record (worst median "
                   f"x{worst.median_over_noise:.2f} on {worst.record or 'a record'})")
        return Diagnosis(False, summary, where, (), tuple(skipped), modal,
                         before=before, after=before)
    rnd = Round(factory, records, nominal, noises, sig, skipped, say, n_fit, gain_threshold,
                n_families)
    candidates: dict[str, tuple[Any, ...]] = {}
    jobs: list[Job] = []
    for name, kind in KINDS.items():  # screened in registry order, fitted in one batch
        candidates[name] = kind.screen(rnd)
        jobs += kind.jobs(rnd, candidates[name])
    if only:
        jobs = [j for j in jobs if j[0].endswith(f" at {only}")]
    fitted = [f for f in run_jobs(jobs, mapper, skipped, say)
              if (f.effect.component, f.effect.law) not in set(exclude)]
    # a later round must earn its effect: 5 % lower, not 1 %, and on the training and the
    # held-out record each beyond its sampling tolerance (judge.unearned)
    later = bool(factory.base_effects or set(exclude))
    lower_by = 0.05 if later else 0.01
    earn = sampling_tolerances(nominal, records) if later and fitted else []
    ranked = rank([judged(rnd, f, before, lower_by, earn) for f in fitted],
                  rnd.evidence_family)
    return Diagnosis(True, _round_summary(ranked, sig), where, tuple(ranked), tuple(skipped),
                     modal, candidates, before, before)


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


def _round_summary(ranked: Sequence[FittedEffect], sig: Sequence[str]) -> str:
    """One line: the best usable candidate, or why the best ranked one was refused."""
    usable = [f for f in ranked if not f.rejected and not f.flags]
    if not usable:
        fails = (f"the model fails ({len(sig)} channels above {SIGNIFICANT_RATIO}x their "
                 "noise floor) but ")
        if not ranked:
            return fails + "no candidate could be fitted"
        best = ranked[0]
        why = best.rejected or "; ".join(best.flags)
        return (fails + f"no candidate is accepted (the best ranked, {best.family_text()} "
                f"at {best.place}: {why})")
    b = usable[0]
    return (f"missing: {b.family_text()} at {b.place} -- held-out NRMSE "
            f"{100 * b.records[1][1]:.2f} % -> {100 * b.records[1][2]:.2f} % "
            f"(x{b.records[1][3]:.2f} the noise floor)")


def _reselected(factory: ModelFactory, found: list[FittedEffect], records: Sequence[Record],
                rec_c: Sequence[Record], noises: Sequence[np.ndarray],
                say: Callable[[str], None], **round_kw: Any
                ) -> tuple[list[FittedEffect], list[RoundRow]]:
    """``found`` with the law of each device effect found before the last chosen again.

    A law chosen in an early round was fitted while the effects found later were missing,
    and its fit bent to stand in for them (a friction law fitted as a stiff spring at one
    isolator while the other's friction was not yet in the model); the joint refit moves
    only its parameters. So each such site's laws are fitted again on the model with every
    other effect found (:func:`diagnose_round` with ``only`` that site, judged and ranked as
    in a round), and the best replaces the effect when the whitened information criterion
    over every record (:func:`.judge.information_criterion`) is lower with it.

    Returns the effects and, per site tried, a round for the tables
    (:data:`RoundRow`): its ranked fits and its decision, "law at SITE re-chosen: A ->
    B, criterion x -> y" or why the law was kept.
    """
    out = list(found)
    rows: list[RoundRow] = []

    ic = partial(whitened_criterion, factory, rec_c, noises)

    ic_out: float | None = None  # of ``out``, simulated once and again only when it changes
    for i, f in enumerate(found[:-1]):
        if kind_of(f.effect.law) is not KINDS["device"]:
            continue
        others = out[:i] + out[i + 1:]
        d = diagnose_round(apply_all(factory, others), records, only=f.effect.component,
                           **round_kw)
        with_ = ", ".join(f"{g.family} at {g.place} ({g.effect.law})" for g in others)
        title = (f"the law at {f.place} chosen again ({f.effect.law}, found in round "
                 f"{i + 1}), the model as given with {with_}")
        best, taken = d.best, None
        head = f"law at {f.place} kept: {f.effect.law}"
        if best is None:
            decision = f"{head} (no law there is usable with the others in place: {d.summary})"
        elif best.effect.law == f.effect.law:
            decision = f"{head} (the best law there with the others in place)"
        else:
            trial = [*out[:i], best, *out[i + 1:]]
            ic_out = ic(out) if ic_out is None else ic_out
            ic_trial = ic(trial)
            crit = (f"criterion {ic_out:.4f} -> {ic_trial:.4f} (whitened information "
                    "criterion over every record, lower is better)")
            if ic_trial < ic_out:
                decision = (f"law at {f.place} re-chosen: {f.effect.law} -> "
                            f"{best.effect.law}, {crit}")
                ic_out, taken = ic_trial, best
                say(f"{f.family} at {f.place}: with the other effects in place "
                    f"{best.effect.law} fits better than {f.effect.law}; taken instead")
                out = trial
            else:
                decision = f"{head} (the best fit there, {best.effect.law}: {crit}, not lower)"
        rows.append((title, d.fitted, decision, taken))
    return out, rows


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
    rounds = [first]
    while d.significant and d.best is not None and len(found) < max_effects:
        found.append(d.best)
        current = apply_effect(current, d.best)
        say(f"effect {len(found)}: {d.best.family} at {d.best.place}; looking for the next")
        exclude = {(f.effect.component, f.effect.law) for f in found}
        d = diagnose_round(current, records, n_fit=n_fit, gain_threshold=gain_threshold,
                           progress=progress, mapper=mapper, exclude=exclude)
        rounds.append(d)
    if not found:
        return first
    rec_c, _ = _common_channels(factory, records)
    noises = [f.noise for f in first.before]  # the floors of the model as given
    order = [(f.effect.component, f.effect.law) for f in found]  # as the rounds took them
    rec_c = with_noise_floors(rec_c, noises)
    titles = [_forward_title(i, found[:i]) for i in range(len(rounds))]  # as they ran
    table: list[RoundRow] = [(t, r.fitted, r.summary, r.best if i < len(found) else None)
                                for i, (t, r) in enumerate(zip(titles, rounds, strict=True))]
    if joint and d.significant and d.best is None and len(found) < max_effects:
        pairs, row = paired(factory, found, d.fitted, rec_c, noises, say, mapper)
        if row is not None:
            table.append((f"round {len(table) + 1}: {row[0]}", *row[1:]))
        if pairs:
            found, d = pairs, replace(d, significant=False)  # its failure is answered
    if joint and len(found) > 1:
        found, again = _reselected(factory, found, records, rec_c, noises, say, n_fit=n_fit,
                                   gain_threshold=gain_threshold, mapper=mapper)
        found, moved = places_rechosen(factory, found, rec_c, noises, say, mapper)
        again += moved
        table += [(f"round {len(table) + k + 1}: {t}", fits, why, took)
                  for k, (t, fits, why, took) in enumerate(again)]
        say("refitting all effects found jointly")
        found = _relabelled(factory, first, rec_c, noises,
                            refit_jointly(factory, found, fit_records(rec_c)))
    dropped: list[str] = []
    if len(found) > 1:
        found, dropped = without_idle(factory, found, rec_c, noises, say, refit=joint)
        if dropped and joint:  # the rest may have been refitted without the dropped
            found = _relabelled(factory, first, rec_c, noises, found)
        if dropped and joint and d.significant:
            found = _paired_after_drops(factory, first, found, rounds, order, rec_c, noises,
                                        say, mapper, table)
    after = figures_on(apply_all(factory, found).plant(), rec_c, noises)
    names = ", ".join(f"{f.family_text()} at {f.place}" for f in found)
    b, a = first.before[1], after[1]
    summary = (f"missing: {names} -- held-out NRMSE {100 * b.median_nrmse:.2f} % -> "
               f"{100 * a.median_nrmse:.2f} % median over channels (x{a.median_over_noise:.2f} "
               f"the noise floor; Eq. (8) of [004] median {100 * float(np.nanmedian(b.eq8)):.2f}"
               f" % -> {100 * float(np.nanmedian(a.eq8)):.2f} %)")
    if d.significant and d.best is None and len(found) + len(dropped) < max_effects:
        summary += f"; still above the noise after that: {d.summary}"
    if dropped:
        summary += "; dropped after the joint refit: " + ", ".join(
            w.split(":", 1)[0] for w in dropped)
    return replace(first, summary=summary, found=tuple(found), after=after,
                   rounds=len(rounds), dropped=tuple(dropped),
                   round_titles=tuple(t[0] for t in table),
                   round_fits=tuple(t[1] for t in table),
                   round_summaries=tuple(t[2] for t in table),
                   round_added=tuple(t[3] for t in table))


AFTER_DROPS_FALL = float(np.log(2.0))  # least criterion fall of a pairing after the drops


def _paired_after_drops(factory: ModelFactory, first: Diagnosis, kept: list[FittedEffect],
                        rounds: Sequence[Diagnosis], order: Sequence[tuple[str, str]],
                        records: Sequence[Record], noises: Sequence[np.ndarray],
                        say: Callable[[str], None], mapper: Mapper, table: list[RoundRow]
                        ) -> list[FittedEffect]:
    """``kept`` with a change its own round rejected, when both together say so.

    The backward elimination dropped effects found after ``kept`` (they stood in for
    something ``kept`` left, e.g. a stiffness for the damping a friction law fitted first
    had taken the part of) and the model still fails. The forward round that ran on the
    model of ``kept`` alone (when ``kept`` are the first effects found, in their order) had
    the missing change among its candidates, rejected beside ``kept``'s stand-in values:
    :func:`.refine.paired` takes its best parameter changes each beside ``kept``, all
    refitted jointly, and keeps the set only when the whitened criterion falls by more than
    its sampling tolerance and by :data:`AFTER_DROPS_FALL` (a large share: one record's RMS
    halved; a device law with a form gap leaves the model failing, and a small fall is
    then an extra change riding on that gap: an Iwan truth fitted as Bouc-Wen took a
    storey's stiffness by 0.12).
    """
    n = len(kept)
    if n >= len(rounds) or [(f.effect.component, f.effect.law) for f in kept] != list(
            order[:n]):
        return kept
    pairs, row = paired(factory, kept, rounds[n].fitted, records, noises, say, mapper,
                       devices=True, at_least=AFTER_DROPS_FALL)
    if row is not None:
        table.append((f"round {len(table) + 1}: {row[0]} (after the drops)", *row[1:]))
    return _relabelled(factory, first, records, noises, pairs) if pairs else kept


def _relabelled(factory: ModelFactory, first: Diagnosis, records: Sequence[Record],
                noises: Sequence[np.ndarray], found: Sequence[FittedEffect]
                ) -> list[FittedEffect]:
    """``found`` after the joint refit, each labelled by what its refitted law does.

    An effect with words from its behaviour (a device law) is read again along the training
    record (:func:`.judge.labelled`); the others keep their family.
    """
    if not any(f.behaviour for f in found):
        return list(found)
    rnd = Round(factory, records, factory.plant(), noises, (), [], lambda s: None,
                evidence_family={e.component: _top_family(e) for e in first.evidence})
    return [labelled(f, kind_of(f.effect.law).facts(rnd, f.effect)) if f.behaviour else f
            for f in found]
