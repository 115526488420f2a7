"""Whole-job helpers: diagnose a model file, choose an effect's start, write new versions.

A model file is any version (:mod:`modal_twin.models.versions`): its effects stay in place
while the diagnosis looks for the next one, and an effect added to it joins them. Nothing
is written that makes any record given worse (:mod:`.judge`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

from modal_twin.diagnosis.fitting import FittedEffect, simulate_record
from modal_twin.diagnosis.judge import figures_on, judge, record_noise_floors, with_noise_floors
from modal_twin.diagnosis.kinds import kind_of
from modal_twin.diagnosis.noise import nrmse
from modal_twin.diagnosis.pipeline import Diagnosis, diagnose
from modal_twin.diagnosis.record import Record
from modal_twin.errors import OptionError
from modal_twin.models.effects import EffectSpec
from modal_twin.models.loading import ModelFactory, load_model
from modal_twin.models.versions import ModelVersion, latest_version, read_version, write_version

__all__ = [
    "add_diagnosed",
    "add_effect",
    "channel_errors",
    "choose_start",
    "diagnose_model",
]


def _factory(mv: ModelVersion) -> ModelFactory:
    """Return the factory of a version held in memory (its effects are passed to ``plant``)."""
    return load_model(mv.structure, theta=mv.theta or None)


def channel_errors(mv: ModelVersion, rec: Record) -> dict[str, float]:
    """Held-out NRMSE (percent) per channel of a model version on a record."""
    plant = _factory(mv).plant(mv.effects)
    keep = [c for c in rec.channel_names if c in plant.channel_names]
    sub = rec.with_channels(keep)
    e = 100.0 * nrmse(simulate_record(plant, sub)[:, sub.skip:], sub.scored)
    return dict(zip(keep, (float(v) for v in e), strict=True))


def diagnose_model(model_file: str | Path, train: Record, test: Record,
                   **kwargs: object) -> Diagnosis:
    """Diagnose a model file (structure or any version) against the records."""
    return diagnose(load_model(model_file), train, test, **kwargs)  # type: ignore[arg-type]


def choose_start(factory: ModelFactory, component: str, law: str, train: Record
                 ) -> dict[str, float]:
    """Return starting parameters of ``law`` at ``component`` from the training record.

    As the law's effect kind chooses them (:mod:`modal_twin.diagnosis.kinds`): the best
    mount frequency of the screening grid, a parameter's current value, or the middle of a
    device law's grid scaled to the measured drift and force. One rule for the command line
    and the diagnosis node.

    Raises
    ------
    OptionError
        Unknown law, component or parameter; a record without the device's channels.
    """
    return kind_of(law).start(factory, component, law, train)


def _version_with(base: ModelVersion, found: Sequence[FittedEffect]) -> ModelVersion:
    theta = dict(base.theta)
    effects: tuple[EffectSpec, ...] = tuple(base.effects)
    for f in found:
        theta, effects = kind_of(f.effect.law).into_version(theta, effects, f.effect)
    return replace(base, theta=theta, effects=effects)


def _write(base: ModelVersion, found: Sequence[FittedEffect], test: Record,
           folder: str | Path, note: str) -> ModelVersion:
    if latest_version(folder) is None:
        write_version(folder, replace(base, note="as given", errors=channel_errors(base, test)))
    new = replace(_version_with(base, found), note=note)
    return write_version(folder, replace(new, errors=channel_errors(new, test)))


def add_effect(model_file: str | Path, component: str, law: str, start: dict[str, float],
               train: Record, test: Record, folder: str | Path, *,
               levels: Sequence[Record] = ()) -> tuple[ModelVersion, FittedEffect]:
    """Fit ``law`` at ``component`` with the model's own effects in place and write the result.

    As the next version in ``folder`` (the model as given becomes the first version if the
    folder is empty). Each version stores its per-channel held-out NRMSE.

    Raises
    ------
    OptionError
        Unknown component / law, or the fitted effect does not lower the error on the
        training and held-out records or makes another record worse (nothing is written).

    """
    base = read_version(model_file)
    factory = load_model(model_file)
    kind = kind_of(law)
    records = [train, test, *levels]
    noises = record_noise_floors(factory.plant(), records)
    train, test = with_noise_floors(records, noises)[:2]  # fitted in the judge's units
    fitted = kind.fit(factory, component, law, start, train, test)
    before = figures_on(factory.plant(), records, noises)
    fitted = judge(fitted, kind.plant(factory, fitted.effect), before, records, noises)
    if fitted.rejected:
        msg = f"{law} at {component} not written: it {fitted.rejected}"
        raise OptionError(msg)
    b, a = fitted.records[1][1], fitted.records[1][2]
    note = (f"added {law} at {component} (held-out NRMSE {100 * b:.3f} % -> {100 * a:.3f} %)")
    return _write(base, [fitted], test, folder, note), fitted


def add_diagnosed(model_file: str | Path, d: Diagnosis, test: Record, folder: str | Path
                  ) -> ModelVersion | None:
    """Write every effect the diagnosis ``d`` found.

    (accepted, unflagged, jointly refitted) as the next version; None when it found nothing to
    add.
    """
    if not d.found:
        return None
    base = read_version(model_file)
    names = ", ".join(f"{f.effect.law} at {f.effect.component}" for f in d.found)
    b, a = d.before[1], d.after[1]
    note = (f"added {names} (held-out NRMSE median {100 * b.median_nrmse:.3f} % -> "
            f"{100 * a.median_nrmse:.3f} %)")
    return _write(base, d.found, test, folder, note)
