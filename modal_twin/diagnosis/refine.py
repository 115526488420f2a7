"""After the forward rounds of :mod:`.pipeline`: the whitened criterion and its refinements.

The forward rounds add one effect at a time, each fitted on a model still missing the
ones found after it. What follows judges the set on the whitened information criterion
over every record (:func:`.judge.information_criterion`), with a sampling tolerance
(:func:`sampling_tolerance`) so that nothing moves on a tie:

- :func:`paired`: a parameter change the last round rejected taken beside the effects found
  (two global changes stood in for by one);
- :func:`places_rechosen`: each parameter change fitted again at its rival places
  (:func:`.parameters.rival_places`), the clearest move first;
- :func:`without_idle`: backward elimination of the effects the data do not demand.

It also holds the few steps the rounds share (:func:`run_jobs`, :func:`judged`,
:func:`apply_all`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from functools import partial
from typing import Any

import numpy as np

from modal_twin.diagnosis.effect_kind import Job, Round
from modal_twin.diagnosis.fitting import FittedEffect, simulate_record
from modal_twin.diagnosis.joint import refit_jointly
from modal_twin.diagnosis.judge import (
    figures_on,
    information_criterion,
    judge,
    rank,
    unearned,
    worse_tolerance,
)
from modal_twin.diagnosis.kinds import KINDS, kind_of
from modal_twin.diagnosis.noise import ErrorFigures, effective_samples
from modal_twin.diagnosis.parameters import fit_parameter, rival_places
from modal_twin.diagnosis.record import Record
from modal_twin.errors import ModalTwinError
from modal_twin.models.loading import ModelFactory
from modal_twin.models.plant import Plant

__all__ = ["MAX_PLACE_MOVES", "N_PAIRED", "Mapper", "RoundRow", "apply_all", "apply_effect",
           "fit_records", "judged", "paired", "places_rechosen", "run_jobs",
           "sampling_tolerance", "sampling_tolerances", "whitened_criterion",
           "without_idle"]

Mapper = Callable[..., Iterable[Any]]


def fit_records(records: Sequence[Record]) -> tuple[Record, ...]:
    """Return the records effects are fitted on: all but the held-out one (``records[1]``)."""
    return (records[0], *records[2:])


def run_jobs(jobs: Sequence[Job], mapper: Mapper,
              skipped: list[str], say: Callable[[str], None]) -> list[FittedEffect]:
    """Run fit jobs through ``mapper``: the fits, each refused one's message in ``skipped``."""
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


def judged(rnd: Round, f: FittedEffect, before: Sequence[ErrorFigures], lower_by: float,
           earn: Sequence[float] = ()) -> FittedEffect:
    """``f`` judged on every record of ``rnd`` against the figures ``before`` it.

    :func:`.judge.judge` with the facts and the place its kind gives (``earn``: each
    record's sampling tolerance, :func:`.judge.unearned`).
    """
    kind = kind_of(f.effect.law)
    return judge(f, kind.plant(rnd.factory, f.effect), before, rnd.records, rnd.noise,
                 facts=kind.facts(rnd, f.effect), place=kind.place(f.effect, rnd.factory),
                 lower_by=lower_by, earn=earn)


def apply_effect(factory: ModelFactory, f: FittedEffect) -> ModelFactory:
    """Return ``factory`` with the fitted effect ``f`` in its model."""
    return kind_of(f.effect.law).apply(factory, f.effect)


def apply_all(factory: ModelFactory, found: Sequence[FittedEffect]) -> ModelFactory:
    """Return ``factory`` with every effect of ``found`` in its model, in order."""
    for f in found:
        factory = apply_effect(factory, f)
    return factory


_Trial = tuple[float, FittedEffect, list[FittedEffect], Any]


def whitened_criterion(factory: ModelFactory, records: Sequence[Record],
               noises: Sequence[np.ndarray], effects: Sequence[FittedEffect]) -> float:
    """Whitened information criterion over every record of the model with ``effects``.

    :func:`.judge.information_criterion` of :func:`.judge.figures_on`, a parameter per
    fitted coordinate of each effect.
    """
    figs = figures_on(apply_all(factory, effects).plant(), records, noises)
    return information_criterion(figs, sum(g.n_params for g in effects), records)


def _effective_samples(plant: Plant, records: Sequence[Record]) -> list[float]:
    """Return what each record's residual under ``plant`` is worth in independent samples.

    :func:`.noise.effective_samples` of the residual on the scored part of each record.
    """
    return [effective_samples(r.scored - simulate_record(plant, r)[:, r.skip:])
            for r in records]


def sampling_tolerances(plant: Plant, records: Sequence[Record]) -> list[float]:
    """Return each record's sampling tolerance of an RMS under ``plant``.

    :func:`.judge.worse_tolerance` of what the residual of ``plant`` on that record is worth
    in independent samples (:func:`_effective_samples`): the tolerances of the per-record
    rule :func:`.judge.unearned`.
    """
    return [worse_tolerance(r, n) for r, n in
            zip(records, _effective_samples(plant, records), strict=True)]


def sampling_tolerance(factory: ModelFactory, found: Sequence[FittedEffect],
                        records: Sequence[Record]) -> tuple[list[float], float]:
    """Return each record's effective samples and the criterion's sampling tolerance.

    :func:`_effective_samples` of the residual of the model with ``found``, and
    ``ln(1 + tol)``, ``tol`` the mean over the records of :func:`.judge.worse_tolerance`
    (one record's RMS that much higher is within what another record of the test gives).
    """
    n_eff = _effective_samples(apply_all(factory, found).plant(), records)
    return n_eff, float(np.log1p(np.mean([worse_tolerance(r, n)
                                          for r, n in zip(records, n_eff, strict=True)])))


def without_idle(factory: ModelFactory, found: list[FittedEffect], records: Sequence[Record],
                  noises: Sequence[np.ndarray], say: Callable[[str], None], *,
                  refit: bool = True) -> tuple[list[FittedEffect], list[str]]:
    """Backward elimination after the joint refit: (effects kept, why each other was dropped).

    Each effect in turn is set back to its nominal (the others keep their joint fit) and the
    whitened information criterion over every record compared
    (:func:`.judge.information_criterion`: training, held-out and other levels alike, a
    penalty per parameter). The effect whose removal worsens it least is dropped when that
    is no more than the sampling tolerance of an RMS (``ln(1 + tol)``: one record's figure
    ``tol`` higher, ``tol`` the mean over the records of :func:`.judge.worse_tolerance`,
    three standard errors, at least 1 %). Both count each record's samples by what the
    residual of the model with every effect found is worth
    (:func:`.noise.effective_samples`): as many as it has when that residual is the noise,
    fewer when it is smooth model error (then small gains are within what another record
    of the same test would change, and an extra effect riding on them is dropped);
    the search repeats on the rest. An effect found early can stand in for one found later
    (a column line for the storey it belongs to), and a small change that helped the
    training record only can ride along with the real ones: after the joint refit either is
    dropped, and the reason said.

    An effect is also dropped when, though the criterion (a sum over the records) demands
    it, the training or the held-out record alone does not rise beyond its sampling
    tolerance without it (:func:`.judge.unearned`, :func:`_idle`): the rule a later forward
    round applies to a candidate, so an effect enters and stays on the same evidence (a
    like share of a form gap taken on every record adds up in the sum, not on any record).

    The others' joint fit may lean on the effect under trial (an extra one soaks up what a
    law fitted beside it left, e.g. a dashpot elsewhere taking over the viscous part of a
    friction law, which the joint refit then moved to it): when even the weakest effect
    seems needed, the rest without each in turn (weakest first) is refitted jointly
    (:func:`_refitted_trial`, from their values in the joint fit) and compared again
    (``refit``); the first one whose rest so refitted is back within the tolerance is
    dropped, the rest kept at its refitted values.
    """
    keep = list(found)
    dropped: list[str] = []
    n_eff, tol = sampling_tolerance(factory, found, records)

    def criterion(effects: Sequence[FittedEffect]) -> tuple[float, tuple[ErrorFigures, ...]]:
        figs = figures_on(apply_all(factory, effects).plant(), records, noises)
        return information_criterion(figs, sum(f.n_params for f in effects), records,
                                     n_eff), figs

    while len(keep) > 1:
        ic_all, figs_all = criterion(keep)
        trials = []
        for f in keep:
            rest = [g for g in keep if g is not f]
            ic_rest, figs_rest = criterion(rest)
            trials.append((ic_rest - ic_all, f, rest, figs_rest))
        trials.sort(key=lambda t: t[0])
        idle = partial(_idle, factory, records, figs_all, tol)
        trial = next((t for t in trials if idle(t)), None)
        refitted = ""
        if trial is None and refit:
            trial = _refitted_trial(factory, trials, records, criterion, ic_all, idle)
            refitted = ", the rest refitted"
        if trial is None:
            break
        delta, f, rest, figs_rest = trial
        rms = ", ".join(f"{a.record or 'record'} x{a.score:.2f} -> x{b.score:.2f}"
                        for a, b in zip(figs_all, figs_rest, strict=True))
        why = (f"{f.family} at {f.place} ({f.effect.law}): without it{refitted} the "
               f"information criterion changes by {delta:+.4f} (drop at <= {tol:.4f}; "
               f"whitened RMS {rms})"
               + ("" if delta <= tol else f"; above that, but it {idle(trial)}"))
        say(f"dropped {why}")
        dropped.append(why)
        keep = rest
    return keep, dropped


# a round of the tables: its heading, its ranked fits, its decision and the fit it took
# (None: none; a round that chose a device law again: the law taken in place of the first)
RoundRow = tuple[str, tuple[FittedEffect, ...], str, FittedEffect | None]



MAX_PLACE_MOVES = 4  # moves of parameter changes' places per diagnosis at most


def places_rechosen(factory: ModelFactory, found: list[FittedEffect],
                     records: Sequence[Record], noises: Sequence[np.ndarray],
                     say: Callable[[str], None], mapper: Mapper
                     ) -> tuple[list[FittedEffect], list[RoundRow]]:
    """``found`` with the place of each parameter change chosen again among its rivals.

    A parameter change is placed by the screening's linear sensitivities at the model of
    its round, on a residual still bent by the laws fitted before it (a friction fitted
    while a storey's stiffness was wrong takes part of it): a column line can be chosen for
    its storey. So each is fitted again at every rival place (:func:`.parameters.rival_places`:
    the same law at the same level, from the same change) with the other effects in place
    and judged as in a round. The move that lowers the whitened information criterion over
    every record (:func:`.judge.information_criterion`) most is made when it lowers it by
    more than the sampling tolerance (:func:`sampling_tolerance`: a place is moved on
    evidence, not on a tie), every effect is refitted jointly, and every change is tried
    again (a wrong place beside a right one bends the right one's rivals too: the clearest
    move first; at most :data:`MAX_PLACE_MOVES`).

    Returns the effects and the rounds for the tables (:data:`RoundRow`): one per move, then
    each change's last trial.
    """
    out = list(found)
    movable = [i for i, f in enumerate(found) if kind_of(f.effect.law) is KINDS["parameter"]]
    rows: list[RoundRow] = []
    fit_on = fit_records(records)

    ic = partial(whitened_criterion, factory, records, noises)

    for n_moves in range(MAX_PLACE_MOVES + 1):
        ic_out = ic(out)
        _, tol = sampling_tolerance(factory, out, records)
        trials = [t for i in movable if (t := _rival_trial(factory, out, i, records, noises,
                                                            say, mapper, ic)) is not None]
        best_trial = min(trials, key=lambda t: t[0], default=None)
        best = None if best_trial is None else best_trial[1]
        if (best_trial is None or best is None or best_trial[0] >= ic_out - tol
                or n_moves == MAX_PLACE_MOVES):
            rows += [_place_row(out[t[2]], t, ic_out, tol, moved=False) for t in trials]
            break
        i = best_trial[2]
        rows.append(_place_row(out[i], best_trial, ic_out, tol, moved=True))
        say(f"{out[i].family}: {best.place} fits better than {out[i].place}; taken instead")
        # the others were fitted beside the place left: refitted with the new one before
        # their rivals are tried again (each move lowers the criterion: no cycle)
        out = refit_jointly(factory, best_trial[4], fit_on, min_free=1)
    return out, rows


_RivalTrial = tuple[float, FittedEffect | None, int, tuple[FittedEffect, ...],
                    list[FittedEffect]]


def _place_row(f: FittedEffect, trial: _RivalTrial, ic_out: float, tol: float, *,
               moved: bool) -> RoundRow:
    """Return the round of the tables for the rival places of ``f``: fits, decision, reason."""
    ic_best, best, _, ranked, _ = trial
    title = (f"the place of {f.family} at {f.place} chosen again among its rival places, "
             "the other effects in place")
    if best is None:
        return title, ranked, f"{f.family} kept at {f.place} (no rival place is usable)", None
    crit = (f"criterion {ic_out:.4f} -> {ic_best:.4f} at {best.place} (whitened information "
            f"criterion over every record; moved when lower by more than {tol:.4f})")
    if moved:
        return title, ranked, f"{f.family} moved: {f.place} -> {best.place}, {crit}", best
    return title, ranked, f"{f.family} kept at {f.place} ({crit})", None


def _rival_trial(factory: ModelFactory, out: Sequence[FittedEffect], i: int,
                 records: Sequence[Record], noises: Sequence[np.ndarray],
                 say: Callable[[str], None], mapper: Mapper,
                 ic: Callable[[Sequence[FittedEffect]], float]) -> _RivalTrial | None:
    """Return the best rival place of ``out[i]``: (criterion, it, i, ranked fits, effects).

    The effects: ``out`` with it in place (:func:`_beside_others`). None when the change
    has no rival; the fit None (criterion inf) when no rival is usable.
    """
    f = out[i]
    base = apply_all(factory, [*out[:i], *out[i + 1:]])
    rivals = rival_places(base, f.effect)
    if len(rivals) < 2:
        return None
    say(f"{f.family} at {f.place}: fitting it at {len(rivals) - 1} rival places")
    rnd = Round(base, records, base.plant(), noises, (), [], say)
    before = figures_on(rnd.nominal, records, noises)
    jobs: list[Job] = [(f"{pc.kind} {pc.name}", partial(fit_parameter, base, pc, rnd.fit_on,
                                                        rnd.test)) for pc in rivals]
    ranked = tuple(rank([judged(rnd, g, before, 0.01)
                         for g in run_jobs(jobs, mapper, [], say)]))
    fit_on = fit_records(records)
    scored = [(ic(t), g, t) for g in ranked
              if not g.rejected and not g.flags and g.effect.component != f.effect.component
              for t in [_beside_others(factory, out, i, g, fit_on)]]
    if not scored:
        return float("inf"), None, i, ranked, list(out)
    ic_best, best, trial = min(scored, key=lambda t: t[0])
    return ic_best, best, i, ranked, trial


def _beside_others(factory: ModelFactory, out: Sequence[FittedEffect], i: int,
                   g: FittedEffect, fit_on: Sequence[Record]) -> list[FittedEffect]:
    """``out`` with ``g`` in place of ``out[i]``, the other parameter changes refitted with it.

    Two parameter changes trade off (a mass on a floor and the stiffness of the storey
    below it): a rival place fitted with the other held where it sat beside the place left
    is judged at a wrong partner. So the parameter changes are refitted jointly with the
    rival (:func:`.joint.refit_jointly`), the device laws held as found (their joint refit
    follows a move).
    """
    trial = [*out[:i], g, *out[i + 1:]]
    params = [k for k, e in enumerate(trial) if kind_of(e.effect.law) is KINDS["parameter"]]
    if len(params) < 2:
        return trial
    held = apply_all(factory, [e for k, e in enumerate(trial) if k not in params])
    for k, e in zip(params, refit_jointly(held, [trial[k] for k in params], fit_on,
                                          min_free=1), strict=True):
        trial[k] = e
    return trial


N_PAIRED = 2  # parameter candidates of a last round tried with the effects found moved


def paired(factory: ModelFactory, found: list[FittedEffect], last_fits: Sequence[FittedEffect],
            records: Sequence[Record], noises: Sequence[np.ndarray],
            say: Callable[[str], None], mapper: Mapper, *, devices: bool = False,
            at_least: float = 0.0
            ) -> tuple[list[FittedEffect] | None, RoundRow | None]:
    """``found`` with a parameter change the last round rejected, when both together say so.

    Two global changes (a mass on one floor and a storey's stiffness) can be stood in for by
    one change elsewhere (a mass on the roof with a large radius): the first round takes it,
    and then no second change lowers every record's error alone, for the first holds the
    model where each of them is only half right. So the best :data:`N_PAIRED` parameter
    changes of the last round (by BIC, rejected or not; none flagged) are each taken beside
    the effects found, all refitted jointly, every parameter change's place chosen again
    among its rivals (:func:`places_rechosen`) and refitted again; the best set replaces
    ``found`` when its whitened information criterion over every record is lower by more
    than its sampling tolerance. Only where ``found`` holds a parameter change (the one that
    may stand in for two), or with ``devices`` a device law too (a law fitted first that
    moved to stand in for a change as well: a friction's viscous part for a body's damping;
    see :func:`.pipeline._paired_after_drops`). ``at_least``: the least fall of the
    criterion that takes a set, when more than the tolerance.

    Returns the new effects (None: kept) and the round for the tables.
    """
    param = KINDS["parameter"]
    cands = sorted((g for g in last_fits if kind_of(g.effect.law) is param and not g.flags),
                   key=lambda g: g.bic)[:N_PAIRED]
    movable = (param, KINDS["device"]) if devices else (param,)
    if not cands or not any(kind_of(f.effect.law) in movable for f in found):
        return None, None
    fit_on = fit_records(records)

    ic = partial(whitened_criterion, factory, records, noises)

    ic_found = ic(found)
    _, tol = sampling_tolerance(factory, found, records)
    tol = max(tol, at_least)
    trials = []
    for g in cands:
        say(f"{g.family} at {g.place} beside the effects found, each refitted and re-placed")
        trial = refit_jointly(factory, [*found, g], fit_on, min_free=1)
        trial, _ = places_rechosen(factory, trial, records, noises, say, mapper)
        trial = refit_jointly(factory, trial, fit_on, min_free=1)
        trials.append((ic(trial), g, trial))
    ic_best, g, best = min(trials, key=lambda t: t[0])
    names = ", ".join(f"{f.family} at {f.place}" for f in best)
    crit = (f"criterion {ic_found:.4f} -> {ic_best:.4f} (whitened information criterion over "
            f"every record; taken when lower by more than {tol:.4f})")
    title = ("the best rejected parameter changes of the last round each beside the effects "
             "found, all refitted jointly and re-placed")
    if ic_best < ic_found - tol:
        say(f"taken together: {names}")
        return best, (title, tuple(c for _, c, _ in trials), f"taken together: {names}, {crit}",
                      g)
    return None, (title, tuple(c for _, c, _ in trials), f"kept as found ({crit})", None)


def _refitted_trial(factory: ModelFactory, trials: Sequence[_Trial],
                    records: Sequence[Record],
                    criterion: Callable[[Sequence[FittedEffect]], tuple[float, Any]],
                    ic_all: float, idle: Callable[[_Trial], str]) -> _Trial | None:
    """Return the first trial (weakest first) whose effect is idle with the rest refitted.

    Each rest is refitted jointly (:func:`.joint.refit_jointly`) on the training record and
    the other levels and the trial judged again by ``idle`` (:func:`_idle`); None when no
    effect is idle so.
    """
    for _, f, rest, _ in trials:
        rest = refit_jointly(factory, rest, fit_records(records), min_free=1)
        ic_rest, figs_rest = criterion(rest)
        out = (ic_rest - ic_all, f, rest, figs_rest)
        if idle(out):
            return out
    return None


def _idle(factory: ModelFactory, records: Sequence[Record],
          figs_all: Sequence[ErrorFigures], tol: float, trial: _Trial) -> str:
    """Why the effect of ``trial`` is not demanded by the data ("" when it is).

    Either the whitened information criterion rises by no more than ``tol`` without it, or
    the training or the held-out record does not rise beyond its sampling tolerance
    without it (:func:`.judge.unearned`, the rule a later forward round applies: the
    tolerances of the residual without it, :func:`sampling_tolerances`).
    """
    delta, _, rest, figs_rest = trial
    if delta <= tol:
        return "raises the criterion within its tolerance"
    return unearned(figs_rest, figs_all,
                    sampling_tolerances(apply_all(factory, rest).plant(), records))
