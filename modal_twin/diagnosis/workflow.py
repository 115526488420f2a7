"""Whole-job helpers: diagnose a model file, add an effect as a new model version."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from modal_twin.diagnosis.attachments import MOUNT_LAW, fit_attachment
from modal_twin.diagnosis.fitting import (
    FittedEffect,
    fit_effect,
    record_nmse,
    simulate_record,
)
from modal_twin.diagnosis.parameters import (
    PARAMETER_LAWS,
    ParameterCandidate,
    fit_parameter,
)
from modal_twin.diagnosis.pipeline import Diagnosis, diagnose
from modal_twin.diagnosis.record import Record
from modal_twin.errors import OptionError
from modal_twin.models.loading import ModelFactory, load_model
from modal_twin.models.versions import ModelVersion, latest_version, read_version, write_version

__all__ = [
    "add_effect",
    "channel_errors",
    "diagnose_model",
]


def _factory(mv: ModelVersion) -> ModelFactory:
    return load_model(mv.structure, theta=mv.theta or None)


def channel_errors(mv: ModelVersion, rec: Record) -> dict[str, float]:
    """Held-out NMSE (percent) per channel of a model version on a record."""
    plant = _factory(mv).plant(mv.effects)
    keep = [c for c in rec.channel_names if c in plant.channel_names]
    sub = rec.with_channels(keep)
    nmse = record_nmse(simulate_record(plant, sub), sub)
    return dict(zip(keep, (float(v) for v in nmse), strict=True))


def diagnose_model(model_file: str | Path, train: Record, test: Record,
                   **kwargs: object) -> Diagnosis:
    """Diagnose a model file (structure or version) against two records."""
    mv = read_version(model_file)
    if mv.effects:
        msg = (f"{model_file}: diagnosing a model that already has effects "
               f"{[e.law for e in mv.effects]} is not supported yet; diagnose its parent")
        raise OptionError(msg)
    return diagnose(_factory(mv), train, test, **kwargs)  # type: ignore[arg-type]


def add_effect(
    model_file: str | Path,
    component: str,
    law: str,
    start: dict[str, float],
    train: Record,
    test: Record,
    folder: str | Path,
) -> tuple[ModelVersion, FittedEffect]:
    """Fit ``law`` at ``component`` on ``train`` and write it as the next model version in
    ``folder`` (the nominal model becomes version 0 first if the folder is empty). Each
    version stores its per-channel held-out NMSE, so the folder is the error history."""
    base = read_version(model_file)
    if latest_version(folder) is None:
        write_version(folder, replace(base, note="nominal", errors=channel_errors(base, test)))
    factory = _factory(base)
    if law in PARAMETER_LAWS:  # a parameter value, not a device law
        values = factory.parameters()
        if component not in values:
            msg = f"{law}: unknown parameter {component!r}; parameters: {sorted(values)}"
            raise OptionError(msg)
        nominal = values[component]
        cand = ParameterCandidate(component, law, nominal, float(start.get(component, nominal)),
                                  0.0)
        fitted = fit_parameter(factory, cand, train, test)
        new = replace(base, theta={**base.theta, **fitted.effect.params},
                      note=(f"{law}: {component} = {fitted.effect.params[component]:.6g} "
                            f"(held-out NMSE {fitted.test_nmse_nominal_pct:.3f} % -> "
                            f"{fitted.test_nmse_pct:.3f} %)"))
        new = replace(new, errors=channel_errors(new, test))
        return write_version(folder, new), fitted
    if law == MOUNT_LAW:
        fitted = fit_attachment(factory, component, start, train, test)
    else:
        fitted = fit_effect(factory, component, law, start, train, test)
    new = replace(base, effects=(*base.effects, fitted.effect),
                  note=(f"added {law} at {component} (held-out NMSE "
                        f"{fitted.test_nmse_nominal_pct:.3f} % -> {fitted.test_nmse_pct:.3f} %)"))
    new = replace(new, errors=channel_errors(new, test))
    return write_version(folder, new), fitted
