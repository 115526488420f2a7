"""Update a building model from identified modes and write it as a model version.

The wiring the updating node (and scripts) call: identified modes at named channels ->
mode targets on the model's sensor rows -> two-stage update (superstructure, then the
isolation layer, [004]) -> a new model version (parameters and the update summary).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from modal_twin.errors import OptionError
from modal_twin.identification.modal_model import ModalModel
from modal_twin.models.building import build_building
from modal_twin.models.versions import (
    ModelVersion,
    latest_version,
    read_version,
    write_version,
)
from modal_twin.updating.problem import ModeTargets
from modal_twin.updating.stages import StagedResult, building_stages, staged_update

__all__ = ["ModelUpdate", "pairs_table", "update_model"]


@dataclass(frozen=True, slots=True)
class ModelUpdate:
    """A staged update and the model version it wrote."""

    result: StagedResult
    version: ModelVersion
    channels: tuple[str, ...]


def update_model(
    model_file: str | Path,
    modes: ModalModel,
    channel_names: tuple[str, ...],
    versions_dir: str | Path,
    *,
    f_split_hz: float = 2.0,
    use_std: bool = True,
) -> ModelUpdate:
    """Run the two stages of [004] on ``modes`` (shapes at ``channel_names``) and write the
    updated parameters as the next version in ``versions_dir`` (v0 = the start, first).

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
    sup, iso = building_stages(par, f_split_hz=f_split_hz, prior_weight_devices=1.0,
                               global_stage=False)
    stages = [replace(sup, use_std=use_std), replace(iso, use_std=use_std)]
    out = staged_update(par, bld.S[rows], targets, stages, theta=theta0)
    if latest_version(versions_dir) is None:
        write_version(versions_dir, replace(mv, note="start of updating"))
    last = out.stages[-1]
    new = replace(mv, theta={**mv.theta, **out.theta_dict()},
                  note=(f"updated from {modes.f_hz.size} {modes.method} modes: max |df| "
                        f"{last.max_abs_df_pct:.2f} %, min MAC {last.min_mac:.3f}"))
    used = tuple(channel_names[i] for i in cols)
    return ModelUpdate(out, write_version(versions_dir, new), used)


def pairs_table(upd: ModelUpdate) -> list[tuple[int, int, float, float, float, float, float]]:
    """(identified, model, f_id, f_before, f_after, MAC before, MAC after) per mode, over
    all stages (each stage matches its own band of identified modes)."""
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
