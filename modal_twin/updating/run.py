"""Update a building model from identified modes and write it as a model version.

The wiring the updating node (and scripts) call: identified modes at named channels ->
mode targets on the model's sensor rows -> two-stage update (superstructure, then the
isolation layer, [004]) -> a new model version (parameters and the update summary).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.errors import OptionError
from modal_twin.identification.modal_model import ModalModel
from modal_twin.models.building import BuildingModel, build_building
from modal_twin.models.fe import ParametricMatrices, solve_modes
from modal_twin.models.versions import (
    ModelVersion,
    latest_version,
    read_version,
    write_version,
)
from modal_twin.updating.matching import nearest_partners
from modal_twin.updating.problem import Matrix, ModeTargets
from modal_twin.updating.stages import (
    R_F,
    R_MAC,
    Stage,
    StagedResult,
    building_stages,
    stage_problem,
    staged_update,
)

__all__ = ["ModelUpdate", "accepted_theta", "pairs_table", "update_model"]


@dataclass(frozen=True, slots=True)
class ModelUpdate:
    """A staged update and the model version it wrote.

    ``partners``: per stage and identified mode, (stage name, index in the stage, f id,
    before, after), before (the model as given) / after (the estimate of all stages) each
    the model mode, df, MAC and unmatched flag of
    :func:`~modal_twin.updating.matching.nearest_partners` (an unmatched mode at its
    nearest model mode, so every mode shows how far off the model is).
    """

    result: StagedResult
    version: ModelVersion
    channels: tuple[str, ...]
    partners: tuple[tuple[str, int, float, tuple[Any, ...], tuple[Any, ...]], ...] = ()


def update_model(
    model_file: str | Path,
    modes: ModalModel,
    channel_names: tuple[str, ...],
    versions_dir: str | Path,
    *,
    f_split_hz: float | None = None,
    use_std: bool = True,
) -> ModelUpdate:
    """Run the two stages of [004] on ``modes`` and write the updated parameters.

    Shapes are at ``channel_names``; the parameters go as the next version in
    ``versions_dir`` (v0 = the start, first).

    ``f_split_hz`` (isolation modes below, superstructure modes above) defaults to the gap
    of the model itself (:func:`isolation_split_hz`).

    Raises
    ------
    OptionError
        No identified mode, or no channel shared with the model's sensors.
    """
    mv = read_version(model_file)
    bld = build_building(mv.structure)
    rows = [bld.channel_names.index(c) for c in channel_names if c in bld.channel_names]
    cols = [i for i, c in enumerate(channel_names) if c in bld.channel_names]
    if not rows:
        msg = (f"identified shapes share no channel with the model's sensors "
               f"({list(bld.channel_names[:4])} ...); got {list(channel_names[:4])} ...")
        raise OptionError(msg)
    if modes.f_hz.size == 0:
        msg = "no identified modes to update against"
        raise OptionError(msg)
    targets = ModeTargets.create(modes.f_hz, modes.shapes[cols], zeta=modes.zeta,
                                 std_f_hz=modes.std_f_hz)
    par = bld.assembly.parametric
    theta0 = par.theta_vector(mv.theta) if mv.theta else None
    if not f_split_hz:
        f_split_hz = isolation_split_hz(bld, theta0)
    sup, iso = building_stages(par, f_split_hz=f_split_hz, prior_weight_devices=1.0,
                               global_stage=False)
    stages = [replace(sup, use_std=use_std), replace(iso, use_std=use_std)]
    out = staged_update(par, bld.S[rows], targets, stages, theta=theta0)
    theta, rejected = accepted_theta(out)
    if latest_version(versions_dir) is None:
        write_version(versions_dir, replace(mv, note="start of updating"))
    kept = [s for s, n in zip(out.stages, out.stage_names, strict=True) if n not in rejected]
    if not kept:
        msg = f"every stage was rejected ({', '.join(rejected)}); the model stays as it was"
        raise OptionError(msg)
    df = max(s.max_abs_df_pct for s in kept)
    note = (f"updated from {modes.f_hz.size} {modes.method} modes: max |df| {df:.2f} % "
            f"over the accepted stages")
    if rejected:
        note += f"; rejected (fewer matches or higher cost): {', '.join(rejected)}"
    new = replace(mv, theta={**mv.theta, **theta}, note=note)
    used = tuple(channel_names[i] for i in cols)
    return ModelUpdate(out, write_version(versions_dir, new), used,
                       _partners(out, par, bld.S[rows], targets, stages))


def _partners(out: StagedResult, par: ParametricMatrices, S: Matrix, targets: ModeTargets,
              stages: list[Stage]) -> tuple[tuple[str, int, float, tuple[Any, ...],
                                                tuple[Any, ...]], ...]:
    """Every stage's modes at their partners before and after (:class:`ModelUpdate`).

    Before: the model as given (every parameter at its start); after: the estimate of all
    the stages. Each stage's modes and pairing windows as
    :func:`~modal_twin.updating.stages.staged_update` posed them.
    """
    rows = []
    for st, res, name in zip(stages, out.stages, out.stage_names, strict=True):
        cols = []
        for full, theta in ((out.theta_start, res.theta_start), (out.theta, res.theta)):
            pr = stage_problem(par, S, targets, st, np.array(full, dtype=float),
                               n_modes=None, r_f=R_F, r_mac=R_MAC)
            md = pr.modes(theta)
            cols.append(nearest_partners(pr.pairing(theta), pr.targets.f_hz,
                                         pr.targets.shapes, md.f_hz, md.Phi_s))
        rows += [(name, k, float(f), cols[0], cols[1]) for k, f in enumerate(res.f_id)]
    return tuple(rows)


def accepted_theta(out: StagedResult) -> tuple[dict[str, float], list[str]]:
    """Return the parameter changes of the stages that improved the fit.

    A stage that matched fewer modes or ended at a higher cost than it started is rejected
    (its parameters stay).
    """
    theta = dict(zip(out.names, out.theta_start, strict=True))
    rejected = []
    for name, st in zip(out.stage_names, out.stages, strict=True):
        worse = (st.pairing_after.n_matched < st.pairing_before.n_matched
                 or st.pairing_after.n_matched == 0 or st.cost_after > st.cost_before)
        if worse:
            rejected.append(name)
            continue
        theta.update(zip(st.names, (float(v) for v in st.theta), strict=True))
    changed = {n for st, nm in zip(out.stages, out.stage_names, strict=True)
               if nm not in rejected for n in st.names}
    return {n: v for n, v in theta.items() if n in changed}, rejected


def pairs_table(upd: ModelUpdate) -> list[tuple[int, int, float, float, float, float, float]]:
    """Tabulate each mode over all stages.

    Rows: (identified, model, f_id, f_before, f_after, MAC before, MAC after) per mode (each
    stage matches its own band of identified modes).
    """
    out = []
    for stage in upd.result.stages:
        b, a = stage.pairing_before, stage.pairing_after
        for i, f in enumerate(stage.f_id):
            j = int(a.fem_index[i])
            fb = f * (1 + b.df_rel[i]) if b.fem_index[i] >= 0 else np.nan
            fa = f * (1 + a.df_rel[i]) if j >= 0 else np.nan
            out.append((i, j, float(f), float(fb), float(fa), float(b.mac[i]),
                        float(a.mac[i])))
    return out


def isolation_split_hz(bld: BuildingModel, theta: FloatArray | None = None) -> float:
    """Return the frequency between a building's isolation modes and its superstructure modes.

    The geometric mean of the model's last isolation mode and first superstructure mode
    (``damping.n_isolation_modes`` of the structure file).

    """
    n = int(bld.spec.damping.n_isolation_modes)
    par = bld.assembly.parametric
    f = solve_modes(par.K(theta), par.M(theta), n + 1).f_hz
    return float(np.sqrt(f[n - 1] * f[n]))
