"""``modal-twin sdof RECORD``: which effect a single-DOF record shows, linear and Bouc-Wen fits.

For a single-DOF test record (a measured force and the displacement or acceleration it
drives; :mod:`modal_twin.commands.sdof_record` reads HDF5, .mat, CSV and NPZ):

1. fit the linear m-c-k model by simulation error
   (:func:`modal_twin.diagnosis.sdof.fit_linear_sdof`);
2. map its restoring force (Eq. (20) of [003]) and name the effect its residual shows --
   hysteresis, cubic stiffness or friction, with the variance fractions each explains
   (:func:`modal_twin.diagnosis.restoring_force.classify_residual`);
3. fit the Bouc-Wen model, Eqs. (1)-(2) of :mod:`modal_twin.diagnosis.sdof`
   (:func:`~modal_twin.diagnosis.sdof.fit_bouc_wen_sdof`);
4. print the parameters (with their standard deviations) and the NRMSE of each fit on the
   record, and on every held-out ``--test`` record (simulated as a steady state when it is
   whole ``--period`` periods, else from rest).

``--json FILE`` writes the same as one JSON document; ``--out DIR`` (new) writes it as
``sdof.json`` beside ``sdof_map.npz`` (the restoring-force map and the simulated responses).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin.errors import OptionError
from modal_twin.exit_codes import ExitCode

__all__ = ["register", "run"]


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``sdof`` parser."""
    p = sub.add_parser("sdof", help="single-DOF record: effect class, linear and Bouc-Wen fits")
    p.add_argument("record", help="force and response record: .h5[:GROUP], .mat, .csv, .npz")
    p.add_argument("--force-channel", default=None, help="force channel / variable (default: "
                   "by role and quantity; u in HDF5 / .mat)")
    p.add_argument("--response-channel", default=None, help="response channel / variable "
                   "(default: by role and quantity; y in HDF5 / .mat)")
    p.add_argument("--response-quantity", choices=("displacement", "acceleration"),
                   default=None, help="default: from the units, else displacement")
    p.add_argument("--fs", type=float, default=None, help="sample rate if the file lacks it")
    p.add_argument("--period", type=int, default=None,
                   help="samples per period when the record is whole periods of a steady "
                        "state (e.g. 8192 for the Bouc-Wen benchmark's multisine)")
    p.add_argument("--f-max", type=float, default=None,
                   help="differentiation band of the map and the Bouc-Wen starts, Hz "
                        "(default 0.4 fs)")
    p.add_argument("--f-min", type=float, default=None,
                   help="acceleration response: lowest line kept by the integration, Hz "
                        "(default: the lower edge of the force's band)")
    p.add_argument("--min-score", type=float, default=0.1,
                   help="smallest explained fraction that names an effect")
    p.add_argument("--test", action="append", default=[], metavar="RECORD",
                   help="held-out record (same channels) to report the fits' errors on; "
                        "repeatable")
    p.add_argument("--out", type=Path, default=None, help="folder to write (new)")
    p.add_argument("--json", type=Path, default=None, help="write the summary as JSON")
    p.add_argument("--force", action="store_true", help="overwrite an existing --json file")
    p.set_defaults(func=run)


def _displacement(a: argparse.Namespace, spec: str, period: int | None
                  ) -> tuple[Any, np.ndarray, np.ndarray, str]:
    """Record, its force and displacement (an acceleration integrated, both high-passed)."""
    from modal_twin.commands.sdof_record import (
        displacement_from_acceleration,
        force_band_edge,
        high_pass,
        read_sdof_record,
    )

    rec = read_sdof_record(spec, force=a.force_channel, response=a.response_channel,
                           fs_hz=a.fs,
                           quantity=a.response_quantity)
    if rec.quantity != "acceleration":
        return rec, rec.u, rec.y, ""
    periodic = period is not None and rec.u.size % period == 0
    f_min = a.f_min if a.f_min is not None else force_band_edge(rec.u, rec.fs_hz,
                                                                periodic=periodic)
    if not 0.0 < f_min < 0.5 * rec.fs_hz:
        msg = f"--f-min: expected 0 < f_min < fs / 2 = {0.5 * rec.fs_hz}, got {f_min}"
        raise OptionError(msg)
    y = displacement_from_acceleration(rec.y, rec.fs_hz, f_min, periodic=periodic)
    u = high_pass(rec.u, rec.fs_hz, f_min, periodic=periodic)
    return rec, u, y, f"acceleration integrated above {f_min:.4g} Hz (force high-passed alike)"


def _fit_dict(fit: Any) -> dict[str, Any]:
    vec = fit.model.vector()[: len(fit.names)]
    return {"parameters": {n: float(v) for n, v in zip(fit.names, vec, strict=True)},
            "std": {n: float(s) for n, s in zip(fit.names, fit.std, strict=True)},
            "f_n_hz": fit.model.f_n_hz, "zeta": fit.model.zeta, "rmse_m": fit.rmse_m,
            "nrmse": fit.nrmse, "converged": fit.converged, "simulations": fit.n_fev}


def _fit_line(title: str, d: dict[str, Any]) -> str:
    pars = ", ".join(f"{n} = {v:.5g} +- {d['std'][n]:.2g}" for n, v in d["parameters"].items())
    return (f"{title}: {pars}\n  f_n = {d['f_n_hz']:.3f} Hz, zeta = {100 * d['zeta']:.2f} %; "
            f"on the record RMSE {d['rmse_m']:.3e} m, NRMSE {d['nrmse']:.4f}"
            + ("" if d["converged"] else " (not converged)"))


def run(a: argparse.Namespace) -> int:
    """Classify, fit and print (module docstring)."""
    from modal_twin.diagnosis.restoring_force import classify_residual, restoring_force_map
    from modal_twin.diagnosis.sdof import fit_bouc_wen_sdof, fit_linear_sdof, simulate_sdof
    from modal_twin.errors import ModelError
    from modal_twin.paths import atomic_dir, atomic_file, check_new

    if a.json is not None:
        check_new(a.json, a.force)
    if a.out is not None:
        check_new(a.out, False)
    period = a.period
    rec, u, y, note = _displacement(a, a.record, period)
    fs = rec.fs_hz
    print(f"sdof: {rec.source}; {u.size} samples at {fs:g} Hz"
          + (f", {u.size // period} periods of {period}" if period else ", from rest"))
    if note:
        print(f"  {note}")
    lin = fit_linear_sdof(u, y, fs, period=period)
    m = lin.model
    rf = restoring_force_map(u, y, fs, m=m.m, c=m.c, k=m.k, period=period, f_max_hz=a.f_max)
    dg = classify_residual(rf, min_score=a.min_score)
    out: dict[str, Any] = {
        "record": rec.source, "fs_hz": fs, "n_samples": int(u.size), "period": period,
        "response_quantity": rec.quantity,
        "classifier": {"top": dg.top, "significant": dg.significant,
                       "ranking": list(dg.ranking), "explained": dg.explained,
                       "unique": dg.unique, "unexplained": dg.unexplained,
                       "loop_energy_ratio": dg.loop_energy_ratio,
                       "odd_index": dg.odd_index, "jump_index": dg.jump_index,
                       "min_score": dg.min_score},
        "linear": _fit_dict(lin)}
    print("residual of the linear model (variance fractions explained):")
    for g in dg.ranking:
        print(f"  {g:16s} explained {dg.explained[g]:.3f}  unique {dg.unique[g]:.3f}")
    print(f"  unexplained {dg.unexplained:.3f}, loop energy ratio {dg.loop_energy_ratio:.3f}, "
          f"odd index {dg.odd_index:.3f}, jump index {dg.jump_index:.3f}")
    print(f"  -> effect: {dg.top}")
    print(_fit_line("linear fit", out["linear"]))
    models = {"linear": m}
    try:
        bw = fit_bouc_wen_sdof(u, y, fs, period=period, f_max_hz=a.f_max)
    except ModelError as err:
        out["bouc_wen"] = {"error": str(err)}
        print(f"Bouc-Wen fit: none ({err})")
    else:
        out["bouc_wen"] = _fit_dict(bw)
        models["bouc_wen"] = bw.model
        print(_fit_line("Bouc-Wen fit", out["bouc_wen"]))
    sims = {f"y_{k}": simulate_sdof(mo, u, fs, period=period) for k, mo in models.items()}
    out["tests"] = []
    for spec in a.test:
        trec, tu, ty, _ = _displacement(a, spec, period)
        steady = period is not None and tu.size % period == 0
        row: dict[str, Any] = {"record": trec.source, "steady_state": steady}
        for k, mo in models.items():
            e = simulate_sdof(mo, tu, trec.fs_hz, period=period if steady else None) - ty
            row[f"rmse_{k}_m"] = float(np.sqrt(np.mean(e**2)))
            row[f"nrmse_{k}"] = row[f"rmse_{k}_m"] / float(np.std(ty))
        out["tests"].append(row)
        print(f"test {trec.source} ({'steady state' if steady else 'from rest'}): "
              + ", ".join(f"{k} RMSE {row[f'rmse_{k}_m']:.3e} m (NRMSE {row[f'nrmse_{k}']:.2e})"
                          for k in models))
    text = json.dumps(out, indent=1)
    if a.json is not None:
        with atomic_file(a.json, force=a.force) as tmp:
            tmp.write_text(text, encoding="utf-8")
        print(f"sdof: wrote {a.json}")
    if a.out is not None:
        with atomic_dir(a.out) as d:
            d.mkdir()
            (d / "sdof.json").write_text(text, encoding="utf-8")
            arrays: dict[str, Any] = {
                "fs_hz": fs, "u": u, "y": y, **sims, "map_y": rf.y, "map_v": rf.v,
                "map_r": rf.r, "map_e": rf.e, "surface": rf.surface, "y_edges": rf.y_edges,
                "v_edges": rf.v_edges}
            np.savez(d / "sdof_map.npz", **arrays)
        print(f"sdof: wrote {a.out}/sdof.json, sdof_map.npz")
    return ExitCode.OK
