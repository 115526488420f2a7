"""Diagnosis results -> ``DiagnosisReport`` / ``ModelParameters`` messages."""

from __future__ import annotations

from typing import Any

from modal_twin.io.convert import to_float_array
from modal_twin.updating.run import pairs_table

__all__ = ["diagnosis_to_msg", "update_to_msgs", "version_to_parameters_msg"]


def diagnosis_to_msg(d: Any, model_version: str, msg_cls: Any, place_cls: Any,
                     cand_cls: Any, *, n_places: int = 12) -> Any:
    """:class:`~modal_twin.diagnosis.pipeline.Diagnosis` -> ``DiagnosisReport``."""
    msg = msg_cls()
    msg.model_version = model_version
    msg.significant = bool(d.significant)
    msg.summary = d.summary
    w = d.where
    order = sorted(range(len(w.channels)), key=lambda i: -float(w.nmse_pct[i]))[:n_places]
    total = float(sum(v for v in w.nmse_pct if v == v)) or 1.0
    for i in order:
        p = place_cls()
        c = w.channels[i]
        p.channel, p.location, p.direction = c.name, c.location, c.direction
        band = max(range(len(w.bands_hz)), key=lambda b: w.band_share[b])
        p.band_low_hz, p.band_high_hz = w.bands_hz[band]
        p.rms_error = float(w.rms_error_pct[i])
        p.error_share = float(w.nmse_pct[i]) / total
        p.amplitude_slope = float(w.level_slope[i])
        msg.places.append(p)
    for f in d.fitted:
        c = cand_cls()
        c.effect, c.component = f.effect.law, f.effect.component
        c.score = float(f.error_ratio)
        c.heldout_error_before = float(f.test_nmse_nominal_pct)
        c.heldout_error_after = float(f.test_nmse_pct)
        c.information_criterion = float(f.bic)
        c.parameter_names = list(f.effect.params)
        c.parameter_values = to_float_array(list(f.effect.params.values()))
        c.evidence = (f"{f.family_text()}: held-out NMSE {f.test_nmse_nominal_pct:.3f} % -> "
                      f"{f.test_nmse_pct:.3f} % (train {f.train_nmse_pct:.3f} %)")
        msg.candidates.append(c)
    return msg


def version_to_parameters_msg(mv: Any, msg_cls: Any) -> Any:
    """:class:`~modal_twin.models.versions.ModelVersion` -> ``ModelParameters``."""
    msg = msg_cls()
    msg.structure = str(mv.structure)
    msg.model_version = mv.label
    msg.parent_version = "" if mv.parent is None else f"v{mv.parent}"
    msg.model_file = str(mv.path or "")
    msg.names = list(mv.theta)
    msg.values = to_float_array(list(mv.theta.values()))
    nan = [float("nan")] * len(mv.theta)
    msg.lower = to_float_array(nan)
    msg.upper = to_float_array(nan)
    msg.std = to_float_array(nan)
    msg.units = [""] * len(mv.theta)
    return msg


def update_to_msgs(upd: Any, report_cls: Any, pair_cls: Any, params_cls: Any
                   ) -> tuple[Any, Any]:
    """(UpdateReport, ModelParameters) of a :class:`~modal_twin.updating.run.ModelUpdate`.

    The parameters carry the last stage's standard deviations (NaN where not estimated).
    """
    r = report_cls()
    v = upd.version
    r.model_version_before = "" if v.parent is None else f"v{v.parent}"
    r.model_version_after = v.label
    r.stages = list(upd.result.stage_names)
    for i, j, f, fb, fa, mb, ma in pairs_table(upd):
        p = pair_cls()
        p.identified_index, p.model_index = i, j
        p.identified_frequency_hz = f
        p.model_frequency_hz_before, p.model_frequency_hz_after = fb, fa
        p.mac_before, p.mac_after = mb, ma
        r.pairs.append(p)
    r.cost_before = float(upd.result.stages[0].cost_before)
    r.cost_after = float(upd.result.stages[-1].cost_after)
    r.converged = all(s.converged for s in upd.result.stages)
    r.message = f"{v.label} written to {v.path}: {v.note}"
    params = version_to_parameters_msg(v, params_cls)
    last = upd.result.stages[-1]
    if last.uncertainty is not None:
        std = dict(zip(last.uncertainty.names, last.uncertainty.std, strict=True))
        params.std = to_float_array([std.get(n, float("nan")) for n in params.names])
    return r, params
