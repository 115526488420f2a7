"""``modal-twin update MODEL --modes FILE``: update a model to identified modes.

MODEL is a building structure or version file, or a ``.mat`` / ``.npz`` matrix model with
substructure stiffnesses ``K_<name>`` (:mod:`modal_twin.models.matrix_model`); its
parameters are the substructure factors ``theta_j`` of ``K(theta) = K0 + sum_j theta_j
K_j``. FILE holds the identified modes (:func:`modal_twin.io.modes_file.read_modes`). The
measured DOFs come from ``--measured-dofs``, else the modes file (``measDOFs``, or the
channels' node and direction matched to the model's DOF labels ``"node:x"`` /
``"node:ux"``), else the model file (``measDOFs``).

The settings are those of the bridge benchmark (test/benchmarks/bench_updating.py):
bounded Gauss-Newton from the nominal model with the analytic Jacobian (no global
stage, ``--max-nfev`` 60), frequencies weighted by their identified standard deviations
where the file gives them, shapes by theirs, and a weak pull towards the nominal values
(``--prior-weight`` 0.3). Prints df / MAC before and after and which parameters the data
determine; ``--out DIR`` receives the new model version ``model_vN.npz`` and its report
``update_vN.json``.

A structure or version file is updated the way the updating node does it (the two stages
of [004]: the superstructure's moduli on the modes above the isolation layer's, then the
isolators on the modes below, :func:`modal_twin.updating.run.update_model`) on the modes of
an identify JSON, whose channels meet the model's sensors by name or by node / location
and direction; ``--out DIR`` (default ``runs/models``) receives the next model version.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from modal_twin.errors import ConfigError, ShapeError
from modal_twin.exit_codes import ExitCode
from modal_twin.progress import step

if TYPE_CHECKING:
    from modal_twin.io.modes_file import ModesFile

__all__ = ["register", "run"]


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``update`` to the sub-commands."""
    p = sub.add_parser("update", help="update a matrix model (.mat / .npz) to identified modes")
    p.add_argument("model", type=Path, help="structure / version file, or a matrix model "
                                            "with K_<name> substructures")
    p.add_argument("--modes", type=Path, required=True,
                   help="identified modes: identify JSON, UFF 55 or .mat")
    p.add_argument("--measured-dofs", default=None,
                   help="0-based model DOFs of the shape entries, comma list")
    p.add_argument("--rules", type=Path, default=None,
                   help="matrix model: YAML of the data set's parameter order and bounds "
                        "(e.g. config/matrix_models/pedestrian_bridge.yaml)")
    p.add_argument("--bounds", default="-0.5,1.0",
                   help="bounds of every theta_j when the model gives none (default -0.5,1.0)")
    p.add_argument("--prior-weight", type=float, default=0.3)
    p.add_argument("--max-nfev", type=int, default=60)
    p.add_argument("--out", type=Path, default=None, help="folder of model versions")
    p.set_defaults(func=run)


def _by_label(dofs: tuple[dict[str, object], ...], labels: tuple[str, ...]
              ) -> np.ndarray | None:
    """Model DOFs of the shape entries from their node and direction.

    (``"12:z"`` or ``"12:uz"`` labels), or None when any entry has no match.
    """
    index = {lab: k for k, lab in enumerate(labels)}
    out = []
    for d in dofs:
        node, axis = str(d.get("node_label") or ""), str(d.get("direction") or "")
        k = index.get(f"{node}:{axis}", index.get(f"{node}:u{axis}"))
        if not node or k is None:
            return None
        out.append(k)
    return np.array(out, dtype=np.int64) if out else None


def _measured(a: argparse.Namespace, file_dofs: np.ndarray | None,
              model_dofs: np.ndarray, n_ch: int) -> np.ndarray:
    if a.measured_dofs:
        try:
            dofs = np.array([int(v) for v in a.measured_dofs.split(",")], dtype=np.int64)
        except ValueError as err:
            msg = f"--measured-dofs: expected integers, got {a.measured_dofs!r}"
            raise ConfigError(msg) from err
    elif file_dofs is not None:
        dofs = file_dofs
    elif model_dofs.size:
        dofs = model_dofs
    else:
        msg = (f"{a.modes}: cannot tell which model DOFs the {n_ch} shape entries are; "
               f"give --measured-dofs or measDOFs in the model file")
        raise ConfigError(msg)
    if dofs.size != n_ch:
        msg = (f"{a.modes}: shapes have {n_ch} entries but {dofs.size} measured DOFs are "
               f"given; the modes do not fit the model's sensor list")
        raise ShapeError(msg)
    return dofs


def _measured_modes(md: ModesFile, path: Path) -> ModesFile:
    """Return the modes of ``md`` whose every shape entry was measured (said if some are not).

    Merged setups leave empty (NaN) the entries of a mode at channels no setup that saw it
    measured; such a mode has no shape to compare at every sensor, so it is left out.

    Raises
    ------
    ConfigError
        No mode is left.
    """
    from dataclasses import replace

    ok = np.all(np.isfinite(md.shapes), axis=0)
    if ok.all():
        return md
    if not ok.any():
        msg = (f"{path}: every mode has shape entries that were not measured (merged setups "
               "that each saw only some modes); nothing to update on")
        raise ConfigError(msg)
    print(f"update: {path.name}: left out {int((~ok).sum())} mode(s) with shape entries not "
          f"measured (seen in some setups only): "
          + ", ".join(f"{f:.4f} Hz" for f in md.f_hz[~ok]), file=sys.stderr, flush=True)
    return replace(md, f_hz=md.f_hz[ok], zeta=md.zeta[ok], std_f_hz=md.std_f_hz[ok],
                   shapes=md.shapes[:, ok], std_shapes=md.std_shapes[:, ok])


def _version(out: Path) -> int:
    out.mkdir(parents=True, exist_ok=True)
    nums = [int(p.stem.removeprefix("model_v")) for p in out.glob("model_v*.npz")
            if p.stem.removeprefix("model_v").isdigit()]
    return max(nums, default=0) + 1


Partners = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
"""Model mode, df, MAC and unmatched flag of each identified mode (``nearest_partners``)."""


def _print_pairs(rows: list[tuple[int, float, Partners, Partners]],
                 stage_of: list[str] | None = None) -> None:
    """Print the df / MAC table: per identified mode, its partner before and after.

    ``rows``: (index in the partners, f id, before, after); ``stage_of``: a heading before
    the first row of each stage.
    """
    print(f"{'mode':>4} {'f id [Hz]':>10} {'model':>5} {'df before %':>11} {'MAC before':>10} "
          f"{'model':>5} {'df after %':>10} {'MAC after':>9}")

    def cell(c: Partners, k: int, w: int) -> str:
        idx, df, mc, near = c
        mark = "*" if near[k] else " "
        return f"{idx[k] + 1:>4}{mark} {100 * df[k]:{w}.3f} {mc[k]:{w - 1}.3f}"

    for n, (k, f, before, after) in enumerate(rows):
        if stage_of is not None and (n == 0 or stage_of[n] != stage_of[n - 1]):
            print(f"stage {stage_of[n]}:")
        print(f"{k + 1:>4} {f:10.4f} {cell(before, k, 11)} {cell(after, k, 10)}")
    if any(c[3][k] for k, _, *cs in rows for c in cs):
        print("  * unmatched (no model mode within the pairing windows of Eq. (4) of [004]): "
              "its nearest partner, the cheapest model mode no pair uses")


def _table(res: object, pr: object
           ) -> tuple[float, float, float, float, tuple[Partners, Partners]]:
    """Print df / MAC before and after for every mode.

    Return max |df| before, min MAC before, the FOM of Eq. (1) of [000] before and after,
    over every mode at its partner, and the partners before and after.
    """
    from modal_twin.updating.matching import nearest_partners
    from modal_twin.updating.objectives import frequency_figure_of_merit

    f_id = np.asarray(res.f_id)  # type: ignore[attr-defined]
    shapes = pr.targets.shapes  # type: ignore[attr-defined]
    cols = []
    for pairing, theta in ((res.pairing_before, res.theta_start),  # type: ignore[attr-defined]
                           (res.pairing_after, res.theta)):  # type: ignore[attr-defined]
        md = pr.modes(theta)  # type: ignore[attr-defined]
        cols.append(nearest_partners(pairing, f_id, shapes, md.f_hz, md.Phi_s))
    _print_pairs([(k, float(f), cols[0], cols[1]) for k, f in enumerate(f_id)])
    b = cols[0]
    fom = [frequency_figure_of_merit(f_id * (1 + c[1]), f_id) for c in cols]
    return (float(100 * np.nanmax(np.abs(b[1]))), float(np.nanmin(b[2])), fom[0], fom[1],
            (cols[0], cols[1]))


def run(a: argparse.Namespace) -> int:
    """Update the model (module docstring)."""
    from modal_twin.commands.model_matrix import check_model_kind
    from modal_twin.io.modes_file import read_modes
    from modal_twin.models.matrix_model import load_matrix_model
    from modal_twin.updating.optimize import update
    from modal_twin.updating.problem import ModeTargets, UpdatingProblem

    if check_model_kind(a.model) != "matrix":
        return _update_structure(a)
    mm = load_matrix_model(a.model, rules=a.rules)
    if not mm.names:
        msg = f"{a.model}: no substructure stiffness K_<name> to update"
        raise ConfigError(msg)
    md = _measured_modes(read_modes(a.modes), a.modes)
    file_dofs = md.measured_dofs if md.measured_dofs is not None else _by_label(md.dofs,
                                                                                mm.dofs)
    dofs = _measured(a, file_dofs, mm.measured_dofs, md.shapes.shape[0])
    p = len(mm.names)
    if mm.lower is not None and mm.upper is not None:
        lo, hi = mm.lower, mm.upper
    else:
        b = [float(v) for v in a.bounds.split(",")]
        lo, hi = np.full(p, b[0]), np.full(p, b[1])
    t = ModeTargets.create(md.f_hz, md.shapes, std_f_hz=md.std_f_hz,
                           std_shapes=md.std_shapes)
    f_scale = md.std_f_hz / md.f_hz if np.all(np.isfinite(md.std_f_hz)) else 1.0
    pr = UpdatingProblem(mm.K0, mm.M, list(mm.K_j), None, np.zeros(p), mm.names, lo, hi,
                         dofs, t, f_scale=f_scale, prior_weight=a.prior_weight)
    print(f"update: {a.model.name}: {mm.n_dof} DOFs, {p} parameters; {md.f_hz.size} modes "
          f"at {dofs.size} DOFs; Gauss-Newton (max {a.max_nfev} evaluations)",
          file=sys.stderr, flush=True)
    with step("update: Gauss-Newton"):
        res = update(pr, global_stage=False, max_nfev=a.max_nfev)
    df0, mac0, fom0, fom1, partners = _table(res, pr)
    print(f"before: max |df| {df0:.3f} %, min MAC {mac0:.3f} (every mode, unmatched ones at "
          f"their nearest model mode); after: max |df| {res.max_abs_df_pct:.3f} %, "
          f"min MAC {res.min_mac:.3f}, "
          f"{res.n_eigen_solves} eigen-solves, {res.seconds:.1f} s, at bounds "
          f"{list(res.at_bounds)}")
    print(f"FOM (Eq. (1) of [000], every mode at its partner): before {fom0:.4g}, after "
          f"{fom1:.4g}")
    u = res.uncertainty
    if u is not None:
        det = [n for n, d in zip(u.names, u.determined, strict=True) if d]
        print(f"determined by the data: {det}; the others rest on the prior "
              f"(std / bound range >= {u.fraction:g})")
    for n, th in zip(mm.names, res.theta, strict=True):
        print(f"  {n:>10} {th:+.4f}")
    if a.out is not None:
        _write(a.out, mm, res, partners)
    return ExitCode.OK


def _update_structure(a: argparse.Namespace) -> int:
    """Two-stage update of a structure or version file (module docstring)."""
    from modal_twin.channels import ChannelSpec
    from modal_twin.identification.modal_model import ModalModel
    from modal_twin.io.modes_file import read_modes
    from modal_twin.models.loading import load_model
    from modal_twin.models.sensors import match_outputs
    from modal_twin.updating.run import update_model

    md = _measured_modes(read_modes(a.modes), a.modes)
    if not md.dofs or not all(d.get("channel") for d in md.dofs):
        msg = (f"{a.modes}: a structure file is updated on an identify JSON (its shapes name "
               "their channels)")
        raise ConfigError(msg)
    plant = load_model(a.model).plant()
    specs = [ChannelSpec(str(d["channel"]), "acceleration", str(d.get("node_label") or ""),
                         str(d.get("direction") or "")) for d in md.dofs]
    rename = match_outputs(specs, plant.channels)
    names = tuple(rename.get(c.name, c.name) for c in specs)
    n = md.f_hz.size
    modes = ModalModel(md.f_hz, md.zeta, md.shapes, md.std_f_hz, np.full(n, np.nan), "file",
                       0, np.zeros(n, np.int64), np.zeros(n, np.int64))
    out = a.out if a.out is not None else Path("runs") / "models"
    print(f"update: {a.model.name}: two stages of [004] on {n} modes at {len(rename)} of "
          f"{len(specs)} channels", file=sys.stderr, flush=True)
    with step("update: two stages"):
        upd = update_model(a.model, modes, names, out)
    rows = [(k, f, before, after) for _, k, f, before, after in upd.partners]
    _print_pairs(rows, [st for st, *_ in upd.partners])
    b = [(before[1][k], before[2][k]) for _, k, _, before, _ in upd.partners]
    print(f"before: max |df| {100 * np.nanmax(np.abs([d for d, _ in b])):.3f} %, min MAC "
          f"{np.nanmin([m for _, m in b]):.3f} (every mode, unmatched ones at their nearest "
          "model mode)")
    print(f"update: wrote {upd.version.path} ({upd.version.note})")
    return ExitCode.OK


def _write(out: Path, mm: object, res: object,
           partners: tuple[Partners, Partners]) -> None:
    """Write ``model_vN.npz`` and ``update_vN.json``.

    The JSON's df / MAC before and after are the table's: an unmatched mode at its nearest
    model mode (``model_before`` / ``model_after``, 1-based, and ``unmatched_before`` /
    ``unmatched_after`` say which), so no mode's error is hidden as null.
    """
    from modal_twin.io.imported import atomic_file
    from modal_twin.models.matrix_model import sparse_members

    v = _version(out)
    arrays = sparse_members(mm.to_arrays(res.theta))  # type: ignore[attr-defined]
    with atomic_file(out / f"model_v{v}.npz") as tmp, tmp.open("wb") as fh:
        np.savez_compressed(fh, **arrays)
    doc = res.as_dict()  # type: ignore[attr-defined]
    for when, (idx, df, mc, near) in zip(("before", "after"), partners, strict=True):
        doc[f"df_pct_{when}"] = (100 * df).tolist()
        doc[f"mac_{when}"] = mc.tolist()
        doc[f"model_{when}"] = (idx + 1).tolist()
        doc[f"unmatched_{when}"] = near.tolist()
    with atomic_file(out / f"update_v{v}.json") as tmp:
        tmp.write_text(json.dumps(doc, indent=1, default=float).replace("NaN", "null"))
    print(f"update: wrote {out}/model_v{v}.npz and update_v{v}.json")
