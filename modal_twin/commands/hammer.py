"""``modal-twin hammer SCENARIO --out DIR``: a hammer test from the test to the updated model.

The scenario (``config/hammer_tests/*.yaml``) names a tracking frame
(:mod:`modal_twin.models.tracking_frame`), the truth's contact stiffnesses, the roving-hammer
test (hit points, sensors, hits, tip, noise: :mod:`modal_twin.rig.hammer_sim`), and the
processing, identification and updating settings. The command writes into ``DIR``, each a
file the other commands read:

1. ``test.uff``: the simulated test's time records (UFF 58: force and accelerations at
   their nodes and directions; ``modal-twin import`` + ``modal-twin impact`` read it), after
   the test geometry (UFF 164 SI, 15: the measured nodes at the model's coordinates, 82:
   one trace line around the frame;
   :func:`~modal_twin.io.impact_files.measured_points_geometry`), as ``frf.uff`` and
   ``modes.json`` carry it;
2. ``frf.uff`` and ``hits.yaml``: the FRF matrix from the accepted hits (double hits and
   overloads rejected and counted; :class:`~modal_twin.acquisition.hammer_test.HammerTest`);
3. ``modes.json``: PolyMAX + LSFD modes of the FRFs
   (:func:`~modal_twin.identification.frf_modes.modes_from_frf`);
4. ``nominal.npz``: the nominal model (``K_feet``, ``K_bearings``: the contact stiffness
   parameters); ``modal-twin update DIR/nominal.npz --modes DIR/modes.json`` updates it;
5. ``update.json``: the update made here (bounded Gauss-Newton, as ``update``), with the
   FOM of Eq. (1) of [000] and the MAC of every mode before and after.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin.errors import ConfigError
from modal_twin.exit_codes import ExitCode

__all__ = ["OUTPUTS", "register", "run"]

OUTPUTS = ("test.uff", "frf.uff", "hits.yaml", "modes.json", "nominal.npz", "update.json")
HELP = "a simulated hammer test of a frame: test, FRFs, PolyMAX + LSFD modes, updated model"
_KEYS = {"description", "frame", "truth", "test", "processing", "identification", "updating"}


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``hammer`` parser."""
    p = sub.add_parser("hammer", help=HELP, description=HELP)
    p.add_argument("scenario", type=Path, help="hammer test scenario (config/hammer_tests/)")
    p.add_argument("--out", type=Path, required=True, help="output folder")
    p.add_argument("--force", action="store_true", help="overwrite existing outputs")
    p.set_defaults(func=run)


def _read(path: Path) -> dict[str, Any]:
    from modal_twin.yaml_files import read_yaml

    doc = read_yaml(path, "hammer scenario")
    bad = sorted(set(doc) - _KEYS)
    if bad:
        msg = f"{path}: unknown keys {bad}; expected some of {sorted(_KEYS)}"
        raise ConfigError(msg)
    for key in ("truth", "test"):
        if not isinstance(doc.get(key), dict):
            msg = f"{path}: expected a mapping '{key}'"
            raise ConfigError(msg)
    return doc


def _channels(labels: list[str], quantity: str, dofs: list[str], where: str) -> list[Any]:
    from modal_twin.channels import ChannelSpec

    out = []
    for lab in labels:
        if lab not in dofs:
            msg = f"{where}: DOF {lab!r} is not in the frame (labels like '402:z')"
            raise ConfigError(msg)
        node, axis = lab.split(":")
        prefix = "hammer" if quantity == "force" else "a"
        out.append(ChannelSpec(f"{prefix}{node}{axis}", quantity, node=node, direction=axis,
                               role="input" if quantity == "force" else "output"))
    return out


def _fom_mac(pr: Any, pairing: Any, theta: np.ndarray, f_id: np.ndarray
             ) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
    """FOM of Eq. (1) of [000] over every mode at its partner, each mode's df and MAC.

    An unmatched mode is at its nearest model mode (flagged in the last array;
    :func:`~modal_twin.updating.matching.nearest_partners`).
    """
    from modal_twin.updating.matching import nearest_partners
    from modal_twin.updating.objectives import frequency_figure_of_merit

    md = pr.modes(theta)
    _, df, mc, near = nearest_partners(pairing, f_id, pr.targets.shapes, md.f_hz, md.Phi_s)
    ok = np.isfinite(df)
    fom = frequency_figure_of_merit(f_id[ok] * (1 + df[ok]), f_id[ok]) if ok.any() else np.inf
    return fom, df, mc, near


def run(a: argparse.Namespace) -> int:
    """Run the scenario (module docstring)."""
    from modal_twin.acquisition.hammer_test import HammerTest
    from modal_twin.identification.frf_modes import modes_from_frf
    from modal_twin.io.impact_files import frf_modes_document, write_hammer_result
    from modal_twin.io.impact_files import measured_points_geometry as points_geometry
    from modal_twin.io.uff import write_uff58_time
    from modal_twin.models.frame_file import spec_fields
    from modal_twin.models.tracking_frame import JOINTS, FrameSpec, frame_matrices, frame_outline
    from modal_twin.paths import check_new_in
    from modal_twin.rig.hammer_sim import HammerTestPlan, simulate_roving_hammer
    from modal_twin.signal_block import SignalBlock
    from modal_twin.updating.optimize import update
    from modal_twin.updating.problem import ModeTargets, UpdatingProblem

    doc = _read(a.scenario)
    check_new_in(a.out, OUTPUTS, a.force)
    spec = FrameSpec(**spec_fields(FrameSpec, dict(doc.get("frame") or {}),
                                   f"{a.scenario}: frame"))
    theta_true = dict(doc["truth"].get("theta") or {})
    truth, nominal = frame_matrices(spec, theta_true), frame_matrices(spec)
    dofs = [str(v) for v in nominal["dofs"]]
    test = dict(doc["test"])
    hit, resp = list(test.pop("hit", [])), list(test.pop("responses", []))
    plan = HammerTestPlan(**spec_fields(HammerTestPlan, test, f"{a.scenario}: test"))
    forces = _channels(hit, "force", dofs, f"{a.scenario}: test.hit")
    outputs = _channels(resp, "acceleration", dofs, f"{a.scenario}: test.responses")
    if not forces or not outputs:
        msg = f"{a.scenario}: expected test.hit and test.responses (DOF labels)"
        raise ConfigError(msg)
    print(f"hammer: {doc.get('description', a.scenario.name)}: {len(dofs)} DOFs, "
          f"{len(forces)} hit points x {plan.hits_per_point} hits, {len(outputs)} sensors")
    F, A = simulate_roving_hammer(truth["M"], truth["K0"], [dofs.index(h) for h in hit],
                                  [dofs.index(r) for r in resp], plan)
    a.out.mkdir(parents=True, exist_ok=True)
    chans = [*forces, *outputs]
    geo = points_geometry(nominal["node_xyz"], [c.node for c in chans], frame_outline(spec))
    write_uff58_time(a.out / "test.uff", chans, plan.fs_hz, np.vstack([F, A]), geometry=geo)
    proc = dict(doc.get("processing") or {})
    ht = HammerTest(chans, block_s=float(proc.get("block_s", 4.0)),
                    estimator=str(proc.get("estimator", "H1")))  # type: ignore[arg-type]
    ht.add(SignalBlock(tuple(c.name for c in chans), plan.fs_hz, 0, np.vstack([F, A])))
    res = ht.finish()
    write_hammer_result(a.out, res, geometry=geo)
    for line in res.lines():
        print(line)
    ident = dict(doc.get("identification") or {})
    band = tuple(float(v) for v in ident.get("band_hz", (1.0, 0.4 * plan.fs_hz)))
    mm = modes_from_frf(res.H, res.f_hz, band_hz=(band[0], band[1]),
                        order_max=int(ident.get("order_max", 30)))
    doc_modes = frf_modes_document(mm.f_hz, mm.zeta, mm.shapes,
                                   [(c.name, c.node, c.direction) for c in outputs],
                                   "modal-twin hammer", geometry=geo)
    (a.out / "modes.json").write_text(json.dumps(doc_modes, indent=1))
    print(f"PolyMAX + LSFD: {mm.f_hz.size} modes in {band[0]:g}-{band[1]:g} Hz: "
          + ", ".join(f"{f:.2f}" for f in mm.f_hz) + " Hz")
    arrays: dict[str, Any] = {k: nominal[k] for k in ("M", "K0", "dofs")}
    arrays.update({f"K_{j}": nominal[f"K_{j}"] for j in JOINTS})
    arrays["measured_dofs"] = np.array([dofs.index(r) for r in resp])
    np.savez(a.out / "nominal.npz", **arrays)
    upd = dict(doc.get("updating") or {})
    lo, hi = (float(v) for v in upd.get("bounds", (-0.7, 1.5)))
    p = len(JOINTS)
    pr = UpdatingProblem(nominal["K0"], nominal["M"], [nominal[f"K_{j}"] for j in JOINTS],
                         None, np.zeros(p), JOINTS, np.full(p, lo), np.full(p, hi),
                         np.array([dofs.index(r) for r in resp]),
                         ModeTargets.create(mm.f_hz, mm.shapes),
                         prior_weight=float(upd.get("prior_weight", 0.0)),
                         r_f=float(upd.get("r_f", 0.10)), r_mac=float(upd.get("r_mac", 0.15)))
    out = update(pr, global_stage=False, max_nfev=int(upd.get("max_nfev", 60)))
    fom0, df0, mac0, near0 = _fom_mac(pr, out.pairing_before, out.theta_start, mm.f_hz)
    fom1, df1, mac1, near1 = _fom_mac(pr, out.pairing_after, out.theta, mm.f_hz)
    print(f"{'mode':>4} {'f test':>9} {'df before %':>11} {'MAC':>6} {'df after %':>10} "
          f"{'MAC':>6}")
    for k, f in enumerate(mm.f_hz):
        print(f"{k + 1:>4} {f:9.3f} {100 * df0[k]:10.3f}{'*' if near0[k] else ' '} "
              f"{mac0[k]:6.3f} {100 * df1[k]:9.3f}{'*' if near1[k] else ' '} {mac1[k]:6.3f}")
    if near0.any() or near1.any():
        print("  * unmatched (no model mode within the pairing windows of Eq. (4) of [004]): "
              "its nearest partner, the cheapest model mode no pair uses")
    print(f"FOM (Eq. (1) of [000]): before {fom0:.3e}, after {fom1:.3e}; sqrt(FOM) "
          f"{np.sqrt(fom0):.4f} -> {np.sqrt(fom1):.4f}")
    for j, th in zip(JOINTS, out.theta, strict=True):
        print(f"  {j:>9}: theta {th:+.4f} (stiffness x {1 + th:.4f}); "
              f"the scenario's truth {theta_true.get(j, 0.0):+.4f}")
    report = {"theta": dict(zip(JOINTS, map(float, out.theta), strict=True)),
              "truth_theta": {j: float(theta_true.get(j, 0.0)) for j in JOINTS},
              "fom_before": fom0, "fom_after": fom1,
              "f_test_hz": mm.f_hz.tolist(), "zeta_test": mm.zeta.tolist(),
              "df_pct_before": (100 * df0).tolist(), "df_pct_after": (100 * df1).tolist(),
              "mac_before": mac0.tolist(), "mac_after": mac1.tolist(),
              "hits_averaged": res.n_accepted, "hits_rejected": res.n_rejected}
    (a.out / "update.json").write_text(json.dumps(report, indent=1))
    print(f"wrote {', '.join(str(a.out / n) for n in OUTPUTS)}")
    return ExitCode.OK
