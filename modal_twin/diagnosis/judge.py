"""Decisions a test engineer can trust: every candidate judged on every record given.

- The figure is the normalised RMS of the residual (:mod:`.noise`) per channel, whitened by
  the noise model (each channel in units of its noise and the model-form tolerance) and
  pooled as the RMS over the channels (:attr:`.noise.ErrorFigures.score`), on every record
  (training, held-out, and any other level). Channels of very different noise (noisy
  accelerometers beside near-noise-free drift and force channels) thus weigh by what they
  can tell, and no single channel's median decides.
- A candidate must **lower** that figure on the training and the held-out record (by 1 %
  at least) and must **not raise** it on any other record (by more than three standard
  errors of an RMS estimated from its samples, 3 / sqrt(2 N), at least 1 %, either way: a
  record at a level where the effect does not engage, such as a low-level record for a
  friction effect, cannot be improved); otherwise it is rejected, naming the record it
  failed on and the figure before and after. A record already at its noise floor (whitened
  figure at most 1) is not made worse by a rise that stays within the noise: the rise is
  counted from the larger of its figure before and the floor (a residual below the noise
  estimate moving within it is noise, not a misfit).
- A fit that ends on a bound of its parameters, or with an implausible value (an added mass
  below 1 % of the floor mass it joins, or negative), is flagged; flagged candidates are
  reported but never chosen (nor written by ``effects add --auto``).
- Ranking: accepted and unflagged first; among them, those whose held-out figure is within
  5 % of the best are ranked by the Bayesian information criterion (simpler wins), with the
  family the evidence named at that place preferred; the rest follow by held-out error.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np

from modal_twin.diagnosis.behaviour import behaviour_label
from modal_twin.diagnosis.effect_kind import Facts
from modal_twin.diagnosis.fitting import FittedEffect, simulate_record
from modal_twin.diagnosis.kinds import kind_of
from modal_twin.diagnosis.noise import (
    RESOLUTION,
    ErrorFigures,
    channel_noise,
    coloured_noise_sd,
    error_figures,
    noise_floor,
)
from modal_twin.diagnosis.record import Record
from modal_twin.errors import ModalTwinError
from modal_twin.models.plant import Plant

__all__ = ["figures_on", "information_criterion", "judge", "labelled", "rank",
           "record_noise_floor", "record_noise_floors", "unearned", "verdict",
           "with_noise_floors", "worse_tolerance"]

LOWER_BY = 0.01  # training and held-out: at least 1 % lower
WORSE_BY = 0.01  # other records: at most 1 % higher
TIED = 0.05  # held-out errors within 5 % of the best are ranked by BIC
AT_FLOOR = 1.0  # whitened figure of a record at its noise floor (residual = noise)


def record_noise_floor(plant: Plant, rec: Record, *, seed: int = 0,
                       sensor_sd: Mapping[str, float] | None = None,
                       input_sd: Mapping[str, float] | None = None) -> np.ndarray:
    """Noise floor of a model-versus-record comparison, per channel (fraction of RMS).

    Two parts, added in quadrature: the sensors' own noise and the response of the model to
    the noise of the measured inputs (their floor, as white noise of the same RMS, driven
    through ``plant``): a model driven by noisy inputs can do no better than that either.
    Without ``sensor_sd`` / ``input_sd`` (absolute standard deviations by channel name, the
    noise model of :func:`record_noise_floors`) both come from this record alone
    (:func:`.noise.noise_floor`); with them, a channel that shows no noise has the floor
    of its resolution (:data:`.noise.RESOLUTION`).
    """
    rms = np.sqrt(np.mean(rec.scored**2, axis=1))
    if sensor_sd is None:
        sensors = noise_floor(rec.scored, rec.fs_hz)
    else:
        sd = np.array([sensor_sd.get(c, np.inf) for c in rec.channel_names])
        with np.errstate(divide="ignore", invalid="ignore"):
            sensors = np.clip(np.where(rms > 0, sd / rms, 1.0), RESOLUTION, 1.0)
    if input_sd is None:
        sd_in = noise_floor(rec.inputs, rec.fs_hz) * np.sqrt(np.mean(rec.inputs**2, axis=1))
    else:
        sd_in = np.array([input_sd.get(c, 0.0) for c in rec.input_names])
        sd_in = np.where(np.isfinite(sd_in), sd_in, 0.0)
    if not np.any(sd_in > 0):
        return sensors
    rng = np.random.default_rng(seed)
    white = sd_in[:, None] * rng.standard_normal(rec.inputs.shape)
    noisy = Record(rec.fs_hz, rec.input_names, white, rec.channel_names,
                   np.zeros_like(rec.data), rec.source, rec.skip)
    try:
        y = simulate_record(plant, noisy)[:, rec.skip:]
    except ModalTwinError:
        return sensors
    from_inputs = np.sqrt(np.mean(y**2, axis=1)) / np.maximum(rms, 1e-300)
    return np.clip(np.sqrt(sensors**2 + from_inputs**2), 0.0, 1.0)


def record_noise_floors(plant: Plant, records: Sequence[Record], *, seed: int = 0
                        ) -> list[np.ndarray]:
    """Noise floors of every record, each from its own quiet stretches.

    Each channel's (and each input's) noise is the flat-top level of the record's quiet
    stretches (:func:`.noise.noise_sd`: robust to a response that fills the top of the band
    only while it is strong), then turned into a floor by :func:`record_noise_floor`. Each
    record keeps its own: a sensor's noise need not be the same at another level (a
    conditioner's range set for the level, noise stated relative to the signal). Noise
    that is not white is told by its independence between sensors in the residual of
    ``plant`` (:func:`.noise.coloured_noise_sd`).
    """
    out = []
    for r in records:
        sensors = _sensor_noise(plant, r)
        inputs = channel_noise([(r.input_names, r.inputs, r.fs_hz)])
        out.append(record_noise_floor(plant, r, seed=seed, sensor_sd=sensors,
                                      input_sd=inputs))
    return out


def with_noise_floors(records: Sequence[Record], noises: Sequence[np.ndarray]
                      ) -> list[Record]:
    """Each record with its noise model (:func:`record_noise_floors`) attached.

    The fits then count each channel's residual in the unit the verdict does
    (:func:`.fitting.channel_scale`): the noise model is estimated once per record and
    shared by the judge and the fits.
    """
    return [r.with_noise_floor(n) for r, n in zip(records, noises, strict=True)]


def _sensor_noise(plant: Plant, rec: Record) -> dict[str, float]:
    """Noise standard deviation of each channel of ``rec``.

    The flat top of its quiet stretches, raised where the residual of ``plant`` shows the
    noise coloured (:func:`.noise.coloured_noise_sd`).
    """
    try:
        resid = rec.scored - simulate_record(plant, rec)[:, rec.skip:]
    except ModalTwinError:
        return channel_noise([(rec.channel_names, rec.scored, rec.fs_hz)])
    sd = coloured_noise_sd(rec.scored, resid, rec.fs_hz)
    return {c: float(v) for c, v in zip(rec.channel_names, sd, strict=True)}


def figures_on(plant: Plant, records: Sequence[Record], noises: Sequence[np.ndarray]
               ) -> tuple[ErrorFigures, ...]:
    """:class:`ErrorFigures` of ``plant`` on each record (scored samples)."""
    out = []
    for rec, nz in zip(records, noises, strict=True):
        pred = simulate_record(plant, rec)[:, rec.skip:]
        out.append(error_figures(pred, rec.scored, rec.channel_names, nz, rec.source))
    return tuple(out)


def worse_tolerance(rec: Record, n_samples: float | None = None) -> float:
    """How much higher an error may come out on a record before it counts as worse.

    Three standard errors of an RMS estimated from its samples, 3 / sqrt(2 N), at least 1 %
    (``N`` the record's scored samples, or ``n_samples``: :func:`.noise.effective_samples`).
    """
    n = rec.scored.shape[-1] if n_samples is None else n_samples
    return max(WORSE_BY, 3.0 / np.sqrt(2.0 * max(n, 1.0)))


def information_criterion(figures: Sequence[ErrorFigures], n_params: int,
                          records: Sequence[Record],
                          n_samples: Sequence[float] | None = None) -> float:
    """Whitened information criterion of a model over every record (lower is better).

    The Bayesian information criterion of Gaussian residuals of unknown scale on every
    record together, in the whitened figure ``s_r`` the verdict uses
    (:attr:`.noise.ErrorFigures.score`: each channel in units of its noise, RMS over the
    channels), ``sum_r N_r ln(s_r^2) + p ln(sum_r N_r)`` with ``N_r`` the scored samples of
    a channel of record ``r``, divided by ``2 N`` (``N`` their mean)::

        IC = sum_r (N_r / N) ln s_r + p ln(sum_r N_r) / (2 N)

    so that a change of ``ln(1 + tol)`` is an RMS ``tol`` higher on one record. The
    training record, the held-out one and every other level count alike; ``n_params`` is
    the number of fitted parameters of the model's effects. ``n_samples`` replaces ``N_r``
    by what each record's residual is worth (:func:`.noise.effective_samples`).
    """
    n_r = np.array([r.scored.shape[-1] for r in records] if n_samples is None
                   else n_samples, float)
    n = float(np.mean(n_r))
    logs = np.log(np.maximum([f.score for f in figures], 1e-300))
    return float(np.sum(n_r / n * logs) + n_params * np.log(np.sum(n_r)) / (2.0 * n))


def verdict(before: Sequence[ErrorFigures], after: Sequence[ErrorFigures],
            tolerances: Sequence[float], lower_by: float = LOWER_BY,
            earn: Sequence[float] = ()) -> str:
    """Why a candidate is rejected ("" when it is not), on the whitened figures.

    ``before[0]`` / ``after[0]`` are the training record and ``[1]`` the held-out one: both
    must fall by ``lower_by``; no other record may rise by more than its tolerance above
    the larger of its figure before and the noise floor (:data:`AT_FLOOR`, module
    docstring). With ``earn`` (each record's sampling tolerance), both must also fall by
    more than it (:func:`unearned`).
    """
    for i, (b, a) in enumerate(zip(before, after, strict=True)):
        name = b.record or f"record {i}"
        vb, va = b.score, a.score
        if i < 2 and not va < (1 - lower_by) * vb:
            return (f"does not lower the error on {name} (whitened RMS x{vb:.2f} -> "
                    f"x{va:.2f}; NRMSE {100 * b.total:.2f} % -> {100 * a.total:.2f} %)")
        if i >= 2 and va > (1 + tolerances[i]) * max(vb, AT_FLOOR):
            return (f"makes {name} worse (whitened RMS x{vb:.2f} -> x{va:.2f}; NRMSE "
                    f"{100 * b.total:.2f} % -> {100 * a.total:.2f} %)")
    return unearned(before, after, earn) if len(earn) else ""


def unearned(without: Sequence[ErrorFigures], with_: Sequence[ErrorFigures],
             tolerances: Sequence[float]) -> str:
    """Why an effect beside others is not earned record by record ("" when it is).

    The rule for every effect beside another one, entering (a later forward round) or
    staying (backward elimination): on the training record and on the held-out one
    (``[0]``, ``[1]``: the records a candidate must lower, :func:`verdict`) **each**, the
    whitened figure without the effect must exceed the figure with it by more than that
    record's sampling tolerance ``tolerances[r]`` (:func:`worse_tolerance` of the samples
    the residual is worth, :func:`.noise.effective_samples`: three standard errors of its
    RMS).

    Why per record and not only in the sum over records
    (:func:`information_criterion`): a law with a form gap (a fitted law near, but not of,
    the truth's form) leaves a smooth residual on every record, and any global parameter
    takes a like share of it on each (a mass on any floor lowers each record's figure by
    some 10 %). Summed over the records, three such shares pass a tolerance meant for one
    record's RMS, though on the held-out record alone the share is within what another
    record of the same test would change, and the parameter's place is not determined. A
    real effect lowers the held-out record beyond its sampling spread. The low level and
    other records are not asked to fall (an effect with a threshold does not engage there).
    """
    for i in range(min(2, len(without), len(with_))):
        b, a = without[i], with_[i]
        if not b.score > (1.0 + tolerances[i]) * a.score:
            return (f"lowers {b.record or f'record {i}'} only within its sampling tolerance "
                    f"(whitened RMS x{b.score:.2f} -> x{a.score:.2f}, "
                    f"{100 * (b.score / max(a.score, 1e-300) - 1):.1f} % against "
                    f"{100 * tolerances[i]:.1f} %)")
    return ""


def _flags(f: FittedEffect, facts: Facts) -> tuple[str, ...]:
    # a radius of gyration at 0 is a point mass, not a fit stopped by its bound
    flags = [f"{n} at its bound" for n in f.at_bound
             if not (n.endswith("_r") and abs(f.effect.params.get(n, 1.0)) < 1e-6)]
    return (*flags, *kind_of(f.effect.law).flags(f.effect, facts))


def judge(f: FittedEffect, plant: Plant, before: Sequence[ErrorFigures],
          records: Sequence[Record], noises: Sequence[np.ndarray], *,
          facts: Facts | None = None, place: str = "",
          lower_by: float = LOWER_BY, earn: Sequence[float] = ()) -> FittedEffect:
    """``f`` with its family, place, per-record errors, flags and rejection filled in.

    ``records[0]`` is the training record and ``records[1]`` the held-out one. The effect's
    kind (:func:`modal_twin.diagnosis.kinds.kind_of`) gives its family and flags from
    ``facts`` (what is known of its model and place: a law that can be friction or
    hysteresis takes the family the evidence named there), and its place unless ``place``
    is given.
    """
    try:
        after = figures_on(plant, records, noises)
    except ModalTwinError as err:
        return replace(f, rejected=f"does not simulate: {err}")
    rows = tuple((b.record, b.total, a.total, a.median_over_noise, b.score, a.score)
                 for b, a in zip(before, after, strict=True))
    rejected = verdict(before, after, [worse_tolerance(r) for r in records], lower_by, earn)
    kind, facts = kind_of(f.effect.law), facts or Facts()
    return replace(labelled(f, facts), place=place or kind.place(f.effect), records=rows,
                   rejected=rejected, flags=_flags(f, facts))


def labelled(f: FittedEffect, facts: Facts) -> FittedEffect:
    """``f`` with its family and the words beside it (:func:`.behaviour.behaviour_label`).

    The family is what its kind reports from ``facts`` (for a device law: what the fit does
    on the training record, ``facts.behaviour``); beside it the law fitted, what it does and,
    where the law's own family differs, that the behaviour won.
    """
    kind = kind_of(f.effect.law)
    family = kind.family(f.effect, facts)
    own = kind.family(f.effect, replace(facts, behaviour=None))
    return replace(f, family=family, behaviour=behaviour_label(
        f.effect.law, f.effect.params, facts.behaviour, own))


def held_out(f: FittedEffect) -> float:
    """Held-out figure after (whitened RMS over channels); inf when not judged."""
    return f.records[1][5] if len(f.records) > 1 else float("inf")


def rank(fits: Sequence[FittedEffect], evidence_family: Mapping[str, str] | None = None
         ) -> list[FittedEffect]:
    """Order of the module docstring: usable first, then ties on held-out error by BIC."""
    ev = evidence_family or {}
    usable = [f for f in fits if not f.rejected and not f.flags]
    rest = [f for f in fits if f.rejected or f.flags]
    best = min((held_out(f) for f in usable), default=float("inf"))

    def key(f: FittedEffect) -> tuple[float, ...]:
        h = held_out(f)
        tied = h <= (1 + TIED) * best
        mismatch = float(ev.get(f.place, f.family) != f.family)
        return (0.0, mismatch, f.bic, h) if tied else (1.0, h, 0.0, f.bic)

    return sorted(usable, key=key) + sorted(rest, key=held_out)
