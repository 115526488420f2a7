"""Whole-job helpers: records from bags, diagnose, add an effect as a new model version."""

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
from modal_twin.diagnosis.record import Record, record_from_blocks
from modal_twin.errors import OptionError
from modal_twin.io.bag import read_blocks
from modal_twin.models.versions import ModelVersion, latest_version, read_version, write_version
from modal_twin.twin.plants import PlantFactory, factory_for
from modal_twin.twin.vehicle_plants import VehicleFactory

__all__ = [
    "add_effect",
    "channel_errors",
    "diagnose_model",
    "force_state_plots",
    "model_factory",
    "record_from_bag",
]


def record_from_bag(bag: str | Path, topic: str = "/measurement/frames") -> Record:
    """The measurement frames of a bag as one :class:`Record`."""
    return record_from_blocks(read_blocks(bag, topic), source=str(bag))


def _factory(mv: ModelVersion) -> PlantFactory | VehicleFactory:
    return factory_for(mv.structure, theta=mv.theta or None)


def model_factory(model_file: str | Path) -> PlantFactory | VehicleFactory:
    """The plant factory of a model file (structure, vehicle or version file)."""
    return _factory(read_version(model_file))


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


def force_state_plots(model_file: str | Path, diag: Diagnosis, rec: Record,
                      folder: str | Path, *, n: int = 2) -> list[Path]:
    """Residual force-state maps (before / after) at the components of the top ``n``
    fitted candidates, as PNG files in ``folder``."""
    from modal_twin.viz.force_state import plot_force_state

    mv = read_version(model_file)
    factory = _factory(mv)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    out: list[Path] = []
    for f in diag.fitted[:n]:
        comp = f.effect.component
        cols = [f"{comp}_d{a}" for a in "xy"], [f"{comp}_f{a}" for a in "xy"]
        if not all(c in rec.channel_names for c in cols[0] + cols[1]):
            continue
        plant = factory.plant([*mv.effects, f.effect])
        fitted = simulate_record(plant, rec.with_channels(cols[1]))
        spec = factory.sites[comp]
        out.append(plot_force_state(
            rec.channels(cols[0]), rec.channels(cols[1]), spec.k, spec.c, rec.fs_hz,
            folder / f"force_state_{comp}_{f.effect.law}.png",
            title=f"{comp}: residual of the nominal law and with {f.effect.law}",
            fitted_force=fitted))
    return out
