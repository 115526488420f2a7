"""Carbody updating as [002] Sec. 3-4 on a simulated modal test of a car whose zones are off.

1. Truth (``_truth/carbody.py``): the in-service carbody with zone moduli / densities off by
   known factors (``TRUTH_FACTORS``), FRFs (accelerance) at 81 floor / side-wall / roof-corner
   channels (nine per section, nine sections: ``sensor_layout``) and the three driving points
   (two floor shakers, one lateral on a side wall), 0-32 Hz at 0.0625 Hz ([002] Sec. 3.1),
   1 % noise.
2. Test modes: PolyMAX + LSFD band by band (``identify_test_modes``), the AutoMAC and MPC of
   the identified modes ([002] Eqs. (6)-(9), Fig. 7a-b) and the reciprocity of the two
   floor shakers (Fig. 7c); the six lowest modes with MPC >= 0.9 are the test modes.
3. Screening: Latin hypercube (``--samples``, 500 as [002]) of the twelve zone factors
   (E and rho of six zones, bounds 0.6-1.5), Spearman of the MAC-paired frequencies and MACs,
   samples with a MAC < 0.5 dropped, |r| >= 0.5 kept ([002] Sec. 4.1).
4. Differential evolution on Eq. (11) of [002] (alpha 1, beta 0.25, gamma 1) over the kept
   factors (``--params table2``: over the eight of [002] Table 2 instead); the model's
   modes paired to the test modes by MAC (Hungarian assignment).
5. The table beside [002] Fig. 12 (every |df| < 5 %, MAC > 0.8) and the factors recovered vs
   the truth's.
6. The updated carbody in the vehicle ([002] Sec. 5, ride before / after): the 3D car with
   the shell carbody (config/vehicles/trailer_car_3d.yaml, this mesh) on the nominal zones,
   on the updated factors (written to ``--factors-out`` as a zone-factor file, the file
   ``modal-twin ride --carbody-params`` reads) and on the truth's zones (built by
   ``_truth``), at ``--speed`` over the same random track: the Sperling indices Wz / Wy at
   the floor points and the mid-floor vertical PSD peak at the first vertical bending
   (spectral theory, fine grid).

The candidates are solved on a Ritz basis of the model (``ZoneModel``); the before / after
figures come from the full sparse model. Mesh: ``--mesh 16,2,2`` (about 2600 DOF, the
coarse mesh used for speed) by default; ``30,4,4`` is the default carbody mesh (about 6800
DOF; each sparse solve about 4 s here, only the basis points use it).

usage: python test/benchmarks/bench_carbody_update.py [--mesh 16,2,2] [--samples 500]
       [--maxiter 40] [--popsize 10] [--noise 0.01] [--executor 1]
       [--params screened|table2] [--bands 7-13.8,15-21] [--speed 300]
       [--factors-out FILE]
Last line: JSON with the figures (units in the keys).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from dataclasses import replace

import numpy as np

from modal_twin.identification.metrics import automac, mpc
from modal_twin.models.carbody3d import CarbodyParams, build_carbody
from modal_twin.models.carbody3d_file import load_zone_factors, save_zone_factors
from modal_twin.models.vehicle3d import build_vehicle3d
from modal_twin.models.vehicle3d_ride import bending_peak, ride_run
from modal_twin.models.vehicle3d_spec import load_vehicle3d
from modal_twin.updating.carbody import (
    ZoneModel,
    driving_points,
    identify_test_modes,
    reciprocity,
    screen_zones,
    sensor_layout,
    update_zones,
)

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _truth.carbody import TRUTH_FACTORS, modal_test, truth_params

BANDS = "7-13.8,15-21"  # around the body modes (both meshes); two equipment modes between
TABLE2 = tuple(f"{k}_{z}" for z in ("underframe", "side_wall", "roof", "end_wall")
               for k in ("E", "rho"))  # [002] Table 2
PAPER = "[002] Fig. 12 after updating: every |df| < 5 %, every MAC > 0.8"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--mesh", default="16,2,2")
    ap.add_argument("--samples", type=int, default=500)
    ap.add_argument("--maxiter", type=int, default=40)
    ap.add_argument("--popsize", type=int, default=10)
    ap.add_argument("--noise", type=float, default=0.01)
    ap.add_argument("--bands", default=BANDS, help="PolyMAX bands, Hz: lo-hi,lo-hi")
    ap.add_argument("--executor", default="1")
    ap.add_argument("--params", choices=("screened", "table2"), default="screened",
                    help="update the screened factors, or the eight of [002] Table 2")
    ap.add_argument("--speed", type=float, default=300.0, help="ride speed, km/h")
    ap.add_argument("--factors-out", default=None,
                    help="zone-factor file of the updated carbody (default: a temporary one)")
    a = ap.parse_args()
    t_start = time.perf_counter()
    nl, nw, nh = (int(v) for v in a.mesh.split(","))
    base = CarbodyParams(n_length=nl, n_width=nw, n_height=nh)
    car = build_carbody(base)
    drives = driving_points(car)
    channels = sensor_layout(car) + drives
    test = modal_test(base, channels, drives, noise=a.noise)
    print(f"truth: mesh {a.mesh} ({car.asm.n_dof} DOF), factors {TRUTH_FACTORS}")
    print("truth flexible modes, Hz: " + ", ".join(f"{f:.2f}" for f in test.f_true[:12]))

    # 2. the modal test
    t0 = time.perf_counter()
    bands = [tuple(float(v) for v in b.split("-")) for b in a.bands.split(",")]
    ident = identify_test_modes(test.H, test.f_hz, bands)  # type: ignore[arg-type]
    t_ident = time.perf_counter() - t0
    q = mpc(ident.shapes)
    keep = np.flatnonzero(q >= 0.9)[:6]
    f_t, phi_t = ident.f_hz[keep], ident.shapes[:, keep]
    am = automac(phi_t)
    off = float(np.max(am - np.diag(np.diag(am))))
    n_s = len(channels) - len(drives)
    band = (test.f_hz >= 5.0) & (test.f_hz <= 25.0)
    rel, frac = reciprocity(test.H[n_s, 1, band], test.H[n_s + 1, 0, band])
    print(f"\nidentified ({t_ident:.1f} s): " + ", ".join(
        f"{f:.2f} Hz ({100 * z:.2f} %, MPC {m:.3f})" for f, z, m in
        zip(ident.f_hz, ident.zeta, q, strict=True)))
    print(f"test modes: {len(keep)}; AutoMAC largest off-diagonal {off:.3f} ([002]: < 0.1); "
          f"MPC min {float(q[keep].min()):.3f} ([002]: > 0.9)")
    print("AutoMAC of the test modes ([002] Eq. (6), Fig. 7a):")
    for row in am:
        print("  " + " ".join(f"{v:5.2f}" for v in row))
    print("MPC ([002] Eqs. (7)-(9), Fig. 7b): " + " ".join(f"{v:.3f}" for v in q[keep]))
    print(f"reciprocity H_12 vs H_21 (5-25 Hz): relative difference {rel:.4f}, FRAC {frac:.5f}")

    # 3. screening
    t0 = time.perf_counter()
    model = ZoneModel.build(car, channels)
    t_basis = time.perf_counter() - t0
    t0 = time.perf_counter()
    sc = screen_zones(model, f_t, phi_t, n_samples=a.samples, executor=a.executor)
    t_screen = time.perf_counter() - t0
    print(f"\nRitz basis: {model.V.shape[1]} vectors ({t_basis:.1f} s); screening: "
          f"{a.samples} LHS samples, {int(sc.kept.sum())} kept (MAC >= 0.5), "
          f"{t_screen:.1f} s")
    rows = [f"f{i + 1}" for i in range(f_t.size)] + [f"MAC{i + 1}" for i in range(f_t.size)]
    print(f"{'Spearman r':>10} " + " ".join(f"{n[:10]:>10}" for n in model.names))
    for name, r in zip(rows, sc.r, strict=True):
        print(f"{name:>10} " + " ".join(f"{v:10.2f}" for v in r))
    print(f"selected (|r| >= 0.5): {', '.join(sc.selected)}")

    # 4. global search
    t0 = time.perf_counter()
    names = sc.selected if a.params == "screened" else TABLE2
    up = update_zones(model, f_t, phi_t, names, maxiter=a.maxiter, popsize=a.popsize,
                      executor=a.executor)
    t_de = time.perf_counter() - t0
    print(f"\ndifferential evolution: {up.nfev} evaluations, {t_de:.1f} s, "
          f"Eq. (11) = {up.cost:.3f}")

    # 5. table beside [002]
    df0 = 100 * (up.f_before - f_t) / f_t
    df1 = 100 * (up.f_after - f_t) / f_t
    print(f"\n{'#':>2} {'test Hz':>8} | {'before Hz':>9} {'df %':>6} {'MAC':>5} | "
          f"{'after Hz':>8} {'df %':>6} {'MAC':>5}")
    for i in range(f_t.size):
        print(f"{i + 1:>2} {f_t[i]:8.2f} | {up.f_before[i]:9.2f} {df0[i]:6.2f} "
              f"{up.mac_before[i]:5.3f} | {up.f_after[i]:8.2f} {df1[i]:6.2f} "
              f"{up.mac_after[i]:5.3f}")
    print(PAPER)
    fac = dict(zip(model.names, up.factors, strict=True))
    print(f"\n{'parameter':<16} {'truth':>6} {'updated':>8} {'error %':>8}")
    errors = {}
    for name in sorted(set(TRUTH_FACTORS) | set(up.names)):
        tr = TRUTH_FACTORS.get(name, 1.0)
        err = 100 * (fac[name] - tr) / tr
        errors[name] = round(err, 2)
        note = "" if name in up.names else "  (not selected: stays 1)"
        print(f"{name:<16} {tr:6.3f} {fac[name]:8.3f} {err:8.2f}{note}")
    ride = vehicle_ride(base, {n: float(fac[n]) for n in up.names}, a.speed, a.factors_out)
    figures = {
        "ride": ride,
        "mesh": a.mesh, "params": a.params, "n_dof": car.asm.n_dof, "n_samples": a.samples,
        "f_test_hz": [round(float(v), 3) for v in f_t],
        "f_before_hz": [round(float(v), 3) for v in up.f_before],
        "f_after_hz": [round(float(v), 3) for v in up.f_after],
        "max_abs_df_before_pct": round(float(np.nanmax(np.abs(df0))), 3),
        "max_abs_df_after_pct": round(float(np.nanmax(np.abs(df1))), 3),
        "min_mac_before": round(float(np.nanmin(up.mac_before)), 4),
        "min_mac_after": round(float(np.nanmin(up.mac_after)), 4),
        "selected": list(up.names),
        "param_error_pct": errors,
        "reciprocity_rel_diff": round(rel, 4), "mpc_min": round(float(q[keep].min()), 4),
        "automac_offdiag_max": round(off, 4),
        "ident_s": round(t_ident, 2), "basis_s": round(t_basis, 2),
        "screen_s": round(t_screen, 2), "de_s": round(t_de, 2), "de_nfev": up.nfev,
        "wall_time_s": round(time.perf_counter() - t_start, 2),
    }
    print(json.dumps(figures))


def vehicle_ride(base: CarbodyParams, factors: dict[str, float], speed_kmh: float,
                 out: str | None) -> dict[str, dict]:
    """Step 6: the 3D car on the nominal, updated and truth carbodies (module docstring)."""
    spec = load_vehicle3d().with_carbody("shell")
    mesh = {k: getattr(base, k) for k in ("n_length", "n_width", "n_height")}
    spec = replace(spec, shell=replace(spec.shell, params=replace(spec.shell.params, **mesh)))
    with tempfile.TemporaryDirectory() as tmp:
        path = out or os.path.join(tmp, "carbody_zone_factors.yaml")
        save_zone_factors(path, factors)  # what `modal-twin ride --carbody-params` reads
        cases = {
            "before": spec,
            "after": spec.with_zone_factors(load_zone_factors(path)),
            "truth": replace(spec, shell=replace(spec.shell, params=truth_params(
                spec.shell.params, TRUTH_FACTORS))),
        }
    rows: dict[str, dict] = {}
    for name, sp_ in cases.items():
        veh = build_vehicle3d(sp_)
        r = ride_run(veh, speed_kmh, duration_s=60.0, fs_hz=400.0, seed=0)
        pk = bending_peak(veh, speed_kmh / 3.6)
        assert pk is not None
        rows[name] = {"sperling": {c[len("floor_"):]: round(float(w), 4)
                                   for c, w in zip(r.channels, r.W, strict=True)},
                      "vertical_bending_hz": round(pk.f_mode_hz, 4),
                      "psd_peak_hz": round(pk.f_peak_hz, 3),
                      "psd_peak_m2s4_per_hz": float(f"{pk.psd_peak:.4g}")}
    chans = list(rows["truth"]["sperling"])
    print(f"\nthe 3D car with the shell carbody at {speed_kmh:g} km/h, low-interference track "
          f"(seed 0, 60 s at 400 Hz), mesh {base.n_length},{base.n_width},{base.n_height}; "
          f"updated factors {', '.join(f'{k} {v:.3f}' for k, v in factors.items())}")
    print(f"{'carbody':<8} " + " ".join(f"{'W ' + c:>10}" for c in chans)
          + f" {'f_vb Hz':>8} {'PSD peak Hz':>11} {'mid_z PSD (m/s^2)^2/Hz':>24}")
    for name, row in rows.items():
        print(f"{name:<8} " + " ".join(f"{row['sperling'][c]:10.3f}" for c in chans)
              + f" {row['vertical_bending_hz']:8.3f} {row['psd_peak_hz']:11.3f} "
              f"{row['psd_peak_m2s4_per_hz']:24.4g}")
    for name in ("before", "after"):
        d = [abs(rows[name]["sperling"][c] - rows["truth"]["sperling"][c]) for c in chans]
        rows[name]["sum_abs_dW_vs_truth"] = round(float(sum(d)), 4)
    print(f"sum over channels |W - W_truth|: before {rows['before']['sum_abs_dW_vs_truth']:.4f}, "
          f"after {rows['after']['sum_abs_dW_vs_truth']:.4f}")
    return rows


if __name__ == "__main__":
    main()
