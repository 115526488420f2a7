"""The diagnosis: where the model fails, which effect is missing, and how much it helps.

1. Run the nominal plant on the measured inputs of both records; break the held-out
   residual down by place, direction, band and level (:mod:`.where`).
2. Screen every candidate law at every component on the training record's force-state
   data (:mod:`.screening`).
3. Fit the best few by full simulation on the training record and rank them by the error
   on the held-out record (:mod:`.fitting`), with BIC against over-fitting.
4. Decide: nothing significant (the nominal error is at noise level and no candidate
   explains a meaningful share) or the top candidate with its evidence.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from modal_twin.diagnosis.attachments import (
    AttachmentCandidate,
    fit_attachment,
    screen_attachments,
)
from modal_twin.diagnosis.fitting import FittedEffect, fit_effect, simulate_record
from modal_twin.diagnosis.modal_view import ModalView, modal_view
from modal_twin.diagnosis.parameters import ParameterCandidate, fit_parameter, screen_parameters
from modal_twin.diagnosis.record import Record
from modal_twin.diagnosis.screening import ScreenedCandidate, screen_components
from modal_twin.diagnosis.where import WhereReport, where_it_fails
from modal_twin.errors import ModalTwinError
from modal_twin.models.loading import ModelFactory

__all__ = ["Diagnosis", "diagnose"]

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class Diagnosis:
    """Outcome of :func:`diagnose`."""

    significant: bool
    summary: str
    where: WhereReport
    screened: tuple[ScreenedCandidate, ...]
    parameters: tuple[ParameterCandidate, ...]
    fitted: tuple[FittedEffect, ...]  # best first (held-out error)
    skipped: tuple[str, ...]
    modal: ModalView | None = None  # identified vs model modes, held-out record
    attachments: tuple[AttachmentCandidate, ...] = ()  # rigid masses hung elastically

    @property
    def best(self) -> FittedEffect | None:
        """Top candidate, or None when nothing significant is missing."""
        return self.fitted[0] if self.significant and self.fitted else None

    def format(self) -> str:
        """Report text: where, candidates, decision."""
        out = ["WHERE THE MODEL FAILS (held-out record)", self.where.format(), ""]
        if self.modal is not None:
            out += ["MODAL VIEW (N4SID of the held-out record vs the model's modes)",
                    self.modal.format(), ""]
        out.append("CANDIDATES (screened on the training record: force-state maps of the "
                   "devices, simulated sensitivities of parameters and mounts)")
        for c in self.screened[:8]:
            out.append(f"  {c.component:<12} {c.law:<14} explains {100 * c.score:6.2f} % "
                       f"(+{100 * c.gain:5.2f} % over linear)")
        for pc in self.parameters[:4]:
            out.append(f"  {pc.name:<12} {pc.kind:<14} removes {100 * pc.gain:6.2f} % of the "
                       f"residual (start {pc.start:.4g}, nominal {pc.nominal:.4g})")
        for ac in self.attachments[:4]:
            out.append(f"  {ac.component:<12} {'elastic_mount':<14} removes {100 * ac.gain:6.2f} "
                       f"% of the residual (best mount frequency {ac.f_hz:.3g} Hz)")
        out.append("")
        out.append("FITTED BY SIMULATION (ranked by held-out error)")
        out.append(f"  {'component':<12} {'law':<20}{'train %':>9}{'held-out %':>11}"
                   f"{'nominal %':>10}{'x better':>9}{'BIC':>12}  parameters")
        for f in self.fitted:
            p = ", ".join(f"{k}={v:.4g}" + (f"±{f.std[k]:.2g}" if k in f.std else "")
                          for k, v in f.effect.params.items())
            out.append(f"  {f.effect.component:<12} {f.effect.law:<20}{f.train_nmse_pct:9.3f}"
                       f"{f.test_nmse_pct:11.3f}{f.test_nmse_nominal_pct:10.3f}"
                       f"{f.error_ratio:9.1f}{f.bic:12.1f}  {p}")
        for s in self.skipped:
            out.append(f"  skipped: {s}")
        out += ["", f"DECISION: {self.summary}"]
        return "\n".join(out)


def _device_data(rec: Record, names: list[str]) -> tuple[dict, dict]:  # type: ignore[type-arg]
    drifts, forces = {}, {}
    for n in names:
        cols_d, cols_f = [f"{n}_dx", f"{n}_dy"], [f"{n}_fx", f"{n}_fy"]
        if all(c in rec.channel_names for c in cols_d + cols_f):
            drifts[n], forces[n] = rec.channels(cols_d), rec.channels(cols_f)
    return drifts, forces


def diagnose(
    factory: ModelFactory,
    train: Record,
    test: Record,
    *,
    n_fit: int = 3,
    nmse_threshold_pct: float = 2.0,
    gain_threshold: float = 0.01,
    progress: Callable[[str], None] | None = None,
) -> Diagnosis:
    """Diagnose the nominal plant of ``factory`` against two records (module docstring).

    Parameters
    ----------
    n_fit : int
        Candidates fitted by simulation (best screened, distinct components and laws).
    nmse_threshold_pct : float
        NMSE of the worst place (mean over its channels) below which the nominal model's
        error counts as insignificant.
    gain_threshold : float
        Share of force variance a candidate must explain beyond linear terms to count.
    """
    say = progress or (lambda s: None)
    nominal = factory.plant()
    plant_names = set(nominal.channel_names)
    skipped = [f"channel {c}: not in the model" for c in test.channel_names
               if c not in plant_names]
    if skipped:
        keep = [c for c in test.channel_names if c in plant_names]
        train, test = train.with_channels(keep), test.with_channels(keep)
    say("simulating the nominal model on both records")
    pred_test = simulate_record(nominal, test)
    specs = {c.name: c for c in nominal.channels}
    where = where_it_fails(test.scored, pred_test[:, test.skip:],
                           tuple(specs[c] for c in test.channel_names), test.fs_hz,
                           inputs=test.inputs[:, test.skip:])
    nominal_nmse = float(np.nanmean(where.nmse_pct))
    modal: ModalView | None = None
    try:
        modal = modal_view(nominal, test)
    except (ModalTwinError, ValueError, np.linalg.LinAlgError) as err:
        skipped.append(f"modal view: {err}")
    worst = where.worst("location", 1)[0]
    say("screening candidate effects on the force-state maps")
    drifts, forces = _device_data(train, list(factory.sites))
    screened = screen_components(drifts, forces, factory.sites,
                                 {n: factory.weight(n) for n in factory.sites}, train.fs_hz)
    if not drifts:
        skipped.append("screening: no component has measured drift and force")
    picks: list[ScreenedCandidate] = []
    for c in screened:
        if c.law == "linear" or c.gain < gain_threshold / 10:
            continue
        if any(p.component == c.component and p.law == c.law for p in picks):
            continue
        picks.append(c)
        if len(picks) >= n_fit:
            break
    lin = [c for c in screened if c.law == "linear"]
    if lin and lin[0].score > gain_threshold:
        picks.append(lin[0])
    fitted: list[FittedEffect] = []

    def fit(label: str, run: Callable[[], FittedEffect]) -> None:
        say(f"fitting {label} by simulation")
        try:
            fitted.append(run())
        except (ModalTwinError, ValueError) as err:
            skipped.append(f"{label}: {err}")

    say("screening parameter changes (added mass, moduli) by simulated sensitivities")
    params = screen_parameters(factory, train)
    for pc in params[:n_fit]:
        if pc.gain >= gain_threshold:
            fit(f"{pc.kind} {pc.name}", lambda pc=pc: fit_parameter(factory, pc, train, test))
    attachments: list[AttachmentCandidate] = []
    if tuple(factory.attachments()):
        say("screening elastic mounts of the rigidly attached masses by simulation")
        attachments = screen_attachments(factory, train)
    for ac in attachments[:n_fit]:
        if ac.gain >= gain_threshold:
            fit(f"elastic_mount at {ac.component}", lambda ac=ac: fit_attachment(
                factory, ac.component, {"f_hz": ac.f_hz}, train, test))
    for c in picks:
        fit(f"{c.law} at {c.component}", lambda c=c: fit_effect(
            factory, c.component, c.law, c.params, train, test))
    fitted.sort(key=lambda f: (f.test_nmse_pct, f.bic))
    top_gain = max((c.gain for c in screened if c.law != "linear"), default=0.0)
    significant = worst.nmse_pct > nmse_threshold_pct or top_gain > gain_threshold
    if not significant:
        fitted = []
        summary = (f"nothing significant is missing: worst place {worst.key} has "
                   f"{worst.nmse_pct:.3f} % NMSE (threshold {nmse_threshold_pct} %), no "
                   f"candidate explains more than {100 * top_gain:.2f} % of a device force "
                   "beyond a linear law")
    elif fitted:
        b = fitted[0]
        summary = (f"missing: {b.effect.law} at {b.effect.component} -- held-out error "
                   f"{b.test_nmse_nominal_pct:.3f} % -> {b.test_nmse_pct:.3f} % NMSE "
                   f"({b.error_ratio:.1f}x better); worst place {worst.key} "
                   f"({worst.nmse_pct:.2f} % NMSE)")
    else:
        summary = (f"the model fails (nominal error {nominal_nmse:.2f} % NMSE) but no "
                   "candidate could be fitted")
    return Diagnosis(significant, summary, where, tuple(screened), tuple(params),
                     tuple(fitted), tuple(skipped), modal, tuple(attachments))
