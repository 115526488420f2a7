"""3D shell carbody: mesh convergence, the mode table beside [002], Craig-Bampton figures.

For each mesh (``n_length, n_width, n_height``; break lines at pivots, seats, belt, doors
and hangers are added) the empty shell and the car in service are built, assembled and
solved free-free; the table lists the empty shell's first flexible mode and the first six
flexible carbody modes in service (equipment modes, named after the equipment, are
counted apart), named from their shapes (:mod:`modal_twin.models.carbody_modes`). Then the
default mesh's modes beside [002] (Sec. 2 and Fig. 8; only mode 1's frequency is in the
text) and its Craig-Bampton reduction on the seats, centre pins and hangers.

Peer: when OpenSeesPy imports (requirements/bench.txt; see peer_opensees.py), a simply
supported square plate (16 x 16, the mesh of test_fe_shell.py) in our shell and in
OpenSees' ShellMITC4, beside Leissa's closed form; otherwise a line says it was skipped.

usage: python test/benchmarks/bench_carbody3d.py [--meshes 15,2,2 30,4,4 45,6,6 60,8,8]
       [--f-cut 60]
Last line: JSON with the figures (units in the keys).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from dataclasses import replace

import numpy as np

from modal_twin.models.carbody3d import CarbodyParams, build_carbody
from modal_twin.models.carbody_modes import CarbodyMode, name_modes
from modal_twin.models.carbody_reduction import reduce_carbody, reduced_modes
from modal_twin.models.craig_bampton import cb_check
from modal_twin.models.fe import solve_modes
from modal_twin.models.fe.shell import ShellModel

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import peer_opensees

PAPER = (  # [002] Fig. 8 (measured in service); Sec. 2: empty shell 13.03 Hz
    (1, "diamond", 8.73),
    (2, "floor and roof bending (breathing)", None),
    (3, "vertical bending 1", None),
    (4, "lateral bending 2 + side-wall bending", None),
    (5, "torsion 1 + lateral bending 1", None),
    (6, "torsion 2 + lateral bending 2", None),
)


def _solve(p: CarbodyParams, n_modes: int) -> tuple[int, float, float, list[CarbodyMode]]:
    t0 = time.perf_counter()
    car = build_carbody(p)
    t1 = time.perf_counter()
    sol = solve_modes(car.asm.K, car.asm.M, n_modes)
    t2 = time.perf_counter()
    modes = [m for m in name_modes(car, sol.f_hz, sol.Phi) if m.kind != "rigid"]
    return car.asm.n_dof, t1 - t0, t2 - t1, modes


def plate_peer(n: int = 16) -> dict[str, list[float]] | None:
    """SS square plate (1 m, 10 mm, aluminium): ours, OpenSees ShellMITC4, Leissa (Hz)."""
    E, nu, rho, t = 70e9, 0.3, 2700.0, 0.01
    ok, info = peer_opensees.available()
    if not ok:
        print(f"OpenSees plate peer skipped: {info}")
        return None
    h = 1.0 / n
    fix = {}
    fem = ShellModel()
    for i in range(n + 1):
        for j in range(n + 1):
            fem.add_node(i * (n + 1) + j + 1, (i * h, j * h, 0.0))
            dofs = ["ux", "uy", "rz"] + (["uz", "rx"] if i in (0, n) else []) \
                + (["uz", "ry"] if j in (0, n) else [])
            fem.fix(i * (n + 1) + j + 1, dofs)
            fix[i * (n + 1) + j + 1] = [int(d in dofs) for d in
                                        ("ux", "uy", "uz", "rx", "ry", "rz")]
    quads = [(i * (n + 1) + j + 1, (i + 1) * (n + 1) + j + 1, (i + 1) * (n + 1) + j + 2,
              i * (n + 1) + j + 2) for i in range(n) for j in range(n)]
    fem.add_shells(quads, E=E, nu=nu, rho=rho, t=t)
    asm = fem.assemble()
    ours = solve_modes(asm.K, asm.M, 4).f_hz
    ops = peer_opensees._ops()
    ops.wipe()
    ops.model("basic", "-ndm", 3, "-ndf", 6)
    for node, xyz in zip(asm.nodes, asm.xyz, strict=True):
        ops.node(int(node), *map(float, xyz))
        ops.fix(int(node), *fix[int(node)])
    ops.section("ElasticMembranePlateSection", 1, E, nu, t, rho)
    for e, q in enumerate(quads):
        ops.element("ShellMITC4", e + 1, *q, 1)
    theirs = np.sqrt(np.array(ops.eigen(4))) / (2 * np.pi)
    ops.wipe()
    D = E * t**3 / (12 * (1 - nu**2))
    leissa = [np.pi / 2 * (m**2 + k**2) * np.sqrt(D / (rho * t))
              for m, k in ((1, 1), (1, 2), (2, 1), (2, 2))]
    print(f"SS plate {n} x {n}: ours " + ", ".join(f"{f:.2f}" for f in ours)
          + " Hz; OpenSees ShellMITC4 " + ", ".join(f"{f:.2f}" for f in theirs)
          + " Hz; Leissa " + ", ".join(f"{f:.2f}" for f in leissa) + " Hz")
    return {"ours_hz": [round(float(f), 3) for f in ours],
            "opensees_hz": [round(float(f), 3) for f in theirs],
            "leissa_hz": [round(float(f), 3) for f in leissa]}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--meshes", nargs="+", default=["15,2,2", "30,4,4", "45,6,6", "60,8,8"])
    ap.add_argument("--f-cut", type=float, default=60.0)
    a = ap.parse_args()
    base = CarbodyParams()
    rows = []
    print(f"{'mesh':>9} {'DOF':>6} {'build s':>7} {'solve s':>7} {'empty f1':>9} "
          "in service: first six flexible carbody modes [Hz]")
    default_modes: list[CarbodyMode] = []
    for spec in a.meshes:
        nl, nw, nh = (int(v) for v in spec.split(","))
        p = replace(base, n_length=nl, n_width=nw, n_height=nh)
        _, _, _, e_modes = _solve(p.empty(), 10)
        n_dof, t_build, t_solve, s_modes = _solve(p, 30)
        body = [m for m in s_modes if m.kind != "equipment"][:6]
        if (nl, nw, nh) == (base.n_length, base.n_width, base.n_height):
            default_modes = s_modes
        rows.append({"mesh": spec, "n_dof": n_dof, "build_s": round(t_build, 3),
                     "solve_s": round(t_solve, 3), "empty_f1_hz": round(e_modes[0].f_hz, 3),
                     "empty_mode1": e_modes[0].label,
                     "service_hz": [round(m.f_hz, 3) for m in body],
                     "service_modes": [m.label for m in body]})
        print(f"{spec:>9} {n_dof:>6} {t_build:7.2f} {t_solve:7.2f} {e_modes[0].f_hz:9.2f} "
              + " | ".join(f"{m.f_hz:.2f} {m.label}" for m in body))
    if not default_modes:
        _, _, _, default_modes = _solve(base, 30)
    body = [m for m in default_modes if m.kind != "equipment"][:6]
    print("\nbeside [002] (default mesh), paired by order, not by shape; [002]'s text gives "
          "mode 1's frequency only (Fig. 8 holds the shapes; 13.03 Hz empty):")
    print(f"{'#':>2} {'[002] Fig. 8':<40} {'[002] Hz':>8} | {'model':<34} {'Hz':>6} {'all #':>5}")
    for (k, name, f), m in zip(PAPER, body, strict=True):
        fs = f"{f:8.2f}" if f is not None else f"{'-':>8}"
        print(f"{k:>2} {name:<40} {fs} | {m.label:<34} {m.f_hz:6.2f} {m.number:>5}")
    eq = [m for m in default_modes if m.kind == "equipment" and m.f_hz < body[-1].f_hz]
    print("equipment modes in that band: "
          + ", ".join(f"{m.f_hz:.2f} {m.label}" for m in eq))
    car = build_carbody(base)
    t0, c0 = time.perf_counter(), time.process_time()
    cb = reduce_carbody(car, f_cut_hz=a.f_cut)
    t_cb, c_cb = time.perf_counter() - t0, time.process_time() - c0
    chk = cb_check(cb, car.asm.M, car.asm.K, rb=car.asm.rigid_body_modes(),
                   f_compare_hz=a.f_cut / 2)
    f_red, _, rigid = reduced_modes(car, cb)
    print(f"\nCraig-Bampton (default mesh, cut-off {a.f_cut:g} Hz): {cb.n_boundary} boundary "
          f"DOFs + {cb.n_modes} modes in {t_cb:.1f} s ({c_cb:.1f} s CPU); rigid-body mass error "
          f"{chk.rb_mass_rel_err:.1e}; max |f_red - f_full| / f_full below {a.f_cut / 2:g} Hz "
          f"{100 * chk.max_f_rel_err:.2f} % ({chk.f_full_hz.size} modes); rigid modes found "
          f"by projection: {int(rigid.sum())}")
    peer = plate_peer()
    figures = {
        "plate_peer": peer,
        "meshes": rows,
        "default_n_dof": car.asm.n_dof,
        "default_mass_t": round(car.asm.total_mass() / 1e3, 3),
        "empty_f1_hz": next(r["empty_f1_hz"] for r in rows if r["mesh"] == "30,4,4")
        if any(r["mesh"] == "30,4,4" for r in rows) else None,
        "service_f1_hz": round(body[0].f_hz, 3),
        "paper_empty_f1_hz": 13.03, "paper_service_f1_hz": 8.73,
        "cb_boundary_dof": cb.n_boundary, "cb_modes": cb.n_modes,
        "cb_reduce_s": round(t_cb, 2), "cb_reduce_cpu_s": round(c_cb, 2),
        "cb_rb_mass_rel_err": chk.rb_mass_rel_err,
        "cb_max_f_rel_err_pct": round(100 * chk.max_f_rel_err, 3),
        "cb_f_compare_hz": a.f_cut / 2, "cb_rigid_modes": int(rigid.sum()),
        "cb_first_flexible_hz": round(float(f_red[~rigid][0]), 3),
    }
    print(json.dumps(figures))
    return 0


if __name__ == "__main__":
    sys.exit(main())
