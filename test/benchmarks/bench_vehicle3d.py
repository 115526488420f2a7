"""Benchmark of the 3D vehicle (issue 23, step 2): real-time factor and the hunting sweep.

The 3D trailer car (config/vehicles/trailer_car_3d.yaml, rigid carbody, 26 DOFs and 10
Maxwell states) on 60 s of low-interference German track at 300 km/h, sampled at 400 Hz:
the real-time factor of ``Vehicle3D.simulate`` (simulated s / process CPU s, best of
``--repeat``; ``_wall`` on wall time), of a whole ``ride_run`` (track drawn, simulated,
Sperling indices and Welch PSDs), and the time of the eigenvalue sweep that finds the
hunting critical speed (10-300 m/s in 5 m/s steps, then Brent). Then the same car with
the Craig-Bampton shell carbody (``carbody.model: shell``, :mod:`modal_twin.models.
carbody_shell`): its assembly time (shell FE built, CB-reduced, coupled: wall and process
CPU; and the coupling alone from the reduction in memory), the real-time factor of
``simulate`` and ``ride_run`` and its hunting sweep (``shell_*`` keys; ``--no-shell``
skips it). Last line: one JSON object.

Run: ``OMP_NUM_THREADS=1 python test/benchmarks/bench_vehicle3d.py [--repeat 5] [--no-shell]``.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from modal_twin.models.hunting import critical_speed
from modal_twin.models.track3d import random_track_3d, track_inputs_3d
from modal_twin.models.vehicle3d import build_vehicle3d
from modal_twin.models.vehicle3d_ride import ride_run
from modal_twin.models.vehicle3d_spec import load_vehicle3d


def _best(fn, repeat: int) -> tuple[float, float]:
    cpu, wall = [], []
    for _ in range(repeat):
        c0, w0 = time.process_time(), time.perf_counter()
        fn()
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - w0)
    return min(cpu), min(wall)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--no-shell", action="store_true", help="skip the shell carbody")
    a = ap.parse_args()
    spec = load_vehicle3d()
    t0 = time.perf_counter()
    veh = build_vehicle3d(spec)
    t_build = time.perf_counter() - t0
    V, fs, T = 300.0 / 3.6, 400.0, 60.0
    w = track_inputs_3d(random_track_3d(V * T + 150.0, rng=0), spec.axle_x, V, fs, T)
    cpu, wall = _best(lambda: veh.simulate(w, fs, V), a.repeat)
    rcpu, _ = _best(lambda: ride_run(veh, 300.0, duration_s=T, fs_hz=fs), a.repeat)
    t0 = time.perf_counter()
    hunt = critical_speed(veh, np.arange(10.0, 300.01, 5.0))
    t_hunt = time.perf_counter() - t0
    print(f"3D vehicle: {veh.n_dof} DOFs, {veh.n_state} states, built in {t_build:.3f} s")
    print(f"simulate 60 s at 400 Hz: {cpu * 1e3:.0f} ms CPU ({T / cpu:.0f}x real time), "
          f"{wall * 1e3:.0f} ms wall ({T / wall:.0f}x)")
    print(f"ride_run (track, simulation, Sperling, PSD): {T / rcpu:.0f}x real time on CPU")
    print(f"hunting sweep: {hunt.v_critical * 3.6:.0f} km/h at {hunt.f_critical_hz:.2f} Hz "
          f"in {t_hunt:.2f} s")
    out = {"rtf_simulate_cpu": round(T / cpu, 1), "rtf_simulate_wall": round(T / wall, 1),
           "rtf_ride_run_cpu": round(T / rcpu, 1),
           "critical_speed_kmh": round(hunt.v_critical * 3.6, 1),
           "hunting_f_hz": round(hunt.f_critical_hz, 3),
           "hunting_sweep_s": round(t_hunt, 3), "build_s": round(t_build, 4)}
    if not a.no_shell:
        out |= _shell(spec, w, V, fs, T, a.repeat)
    print(json.dumps(out))


def _shell(spec, w, V: float, fs: float, T: float, repeat: int) -> dict[str, float]:
    sspec = spec.with_carbody("shell")
    t0, c0 = time.perf_counter(), time.process_time()
    veh = build_vehicle3d(sspec)  # shell FE, Craig-Bampton, coupling
    t_build, c_build = time.perf_counter() - t0, time.process_time() - c0
    t0 = time.perf_counter()
    veh = build_vehicle3d(sspec)  # the reduction is kept in memory: coupling only
    t_couple = time.perf_counter() - t0
    cpu, wall = _best(lambda: veh.simulate(w, fs, V), repeat)
    rcpu, _ = _best(lambda: ride_run(veh, 300.0, duration_s=T, fs_hz=fs), repeat)
    t0 = time.perf_counter()
    hunt = critical_speed(veh, np.arange(10.0, 300.01, 5.0))
    t_hunt = time.perf_counter() - t0
    cb = veh.carbody
    print(f"\nshell carbody: {cb.n} carbody coordinates ({cb.name}), vehicle {veh.n_dof} DOFs, "
          f"{veh.n_state} states; assembled in {t_build:.1f} s ({c_build:.1f} s CPU; FE + CB + "
          f"coupling), coupled in {t_couple:.2f} s from the reduction in memory")
    print(f"simulate 60 s at 400 Hz: {cpu * 1e3:.0f} ms CPU ({T / cpu:.0f}x real time), "
          f"{wall * 1e3:.0f} ms wall ({T / wall:.0f}x); ride_run {T / rcpu:.0f}x on CPU")
    print(f"hunting sweep: {hunt.v_critical * 3.6:.0f} km/h at {hunt.f_critical_hz:.2f} Hz "
          f"in {t_hunt:.2f} s")
    return {"shell_n_dof": veh.n_dof, "shell_n_state": veh.n_state,
            "shell_assembly_s": round(t_build, 2),
            "shell_assembly_cpu_s": round(c_build, 2), "shell_couple_s": round(t_couple, 3),
            "shell_rtf_simulate_cpu": round(T / cpu, 1),
            "shell_rtf_simulate_wall": round(T / wall, 1),
            "shell_rtf_ride_run_cpu": round(T / rcpu, 1),
            "shell_critical_speed_kmh": round(hunt.v_critical * 3.6, 1),
            "shell_hunting_f_hz": round(hunt.f_critical_hz, 3),
            "shell_hunting_sweep_s": round(t_hunt, 2)}


if __name__ == "__main__":
    main()
