"""Benchmark of the modal twin: real-time factor of a building-sized partially nonlinear model.

Synthetic system: 36 mass-normalised modes (0.4-35 Hz, 2 % damping, 3 isolation modes with
zero linear stiffness as in Eq. (12) of [004]), six bidirectional isolators placed at the
corners of a 10 m x 12 m plan (2 bilinear RB, 2 Bouc-Wen ESB, 2 Bouc-Wen SDP with the
Table 10 parameters of [004]), 6-DOF random table input at 1 kHz for 60 s, 42 outputs.
Reports the real-time factor (simulated s / wall s, one core, best of ``--repeat`` runs;
the ``_cpu`` figures divide by the process CPU time instead, which a loaded machine inflates
less) of
``Simulator.step_block`` on the whole record (outputs y, drifts and forces), with q, q', q''
too, and streamed in 100-sample blocks.

Where the time goes: the same run with every device replaced by a linear k-c of its
reference stiffness and damping (``rtf_linear_devices_cpu``: the laws cost nothing and the
Newton converges at once, so this is the floor of the linear part, outputs included) and
with one output instead of 42 (``rtf_one_output_cpu``).
The numpy reference (:func:`numpy_reference`) is the same scheme written as a per-step
numpy loop: input projection, diagonal first-order-hold propagation, drift projection
P xi_p (the kernel predicts the same drift as Q xi_p,k + Ua0 a_k + Ua1 a_k+1 + Hf ft_k, so
the comparison checks that rearrangement too),
force predictor, the device laws (the jitted law functions called one device at a time from
Python), the Newton correction with the kept inverse Jacobian and its error bound, the
commit and the output row y_k = W z_k. It runs on the first ``--ref-seconds`` of the record
in the same process; its drifts are compared with the kernel's.
Compile time is printed separately: "warm" loads the numba cache, ``--cold`` compiles into
an empty temporary cache directory. Timings on a shared 2-core machine vary by up to a
factor 2 between runs. Last line: one JSON object.

Run: ``.venv/bin/python test/benchmarks/bench_twin.py [--cold] [--repeat 3]``
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import replace

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

if "--cold" in sys.argv:  # before numba is imported: compile into an empty cache
    os.environ["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="bench_twin_numba_")

import numpy as np

from modal_twin.models.devices import (
    table10_esb,
    table10_rubber_bearing,
    table10_sdp,
)
from modal_twin.models.devices._dispatch import evaluate_law
from modal_twin.models.devices.linear import LinearDevice
from modal_twin.models.reduced import DeviceAttachment, ReducedSystem
from modal_twin.twin.simulator import Simulator


def building(n: int = 36, seed: int = 1) -> ReducedSystem:
    """Return the synthetic 36-mode base-isolated building."""
    rng = np.random.default_rng(seed)
    m_tot = 686e3
    f = np.concatenate([[0.0, 0.0, 0.0], np.geomspace(2.0, 35.0, n - 3)])
    w = 2 * np.pi * f
    K = np.diag(w**2)
    C = np.diag(2 * 0.02 * w)
    # isolation modes: rigid x, y, torsion of the base (mass-normalised shapes)
    J = m_tot * (10.0**2 + 12.0**2) / 12.0
    pos = [(-5, -6), (5, 6), (5, -6), (-5, 6), (0, -6), (0, 6)]
    devs = [
        table10_rubber_bearing("RB1"),
        table10_rubber_bearing("RB2"),
        table10_esb("ESB1", W=1.1e6),
        table10_esb("ESB2", W=1.1e6),
        table10_sdp("SDP1"),
        table10_sdp("SDP2"),
    ]
    att = []
    for dev, (px, py) in zip(devs, pos, strict=True):
        B = np.zeros((2, n))
        B[0, 0] = 1 / np.sqrt(m_tot)
        B[1, 1] = 1 / np.sqrt(m_tot)
        B[0, 2] = -py / np.sqrt(J)
        B[1, 2] = px / np.sqrt(J)
        B[:, 3:] = 0.05 * rng.standard_normal((2, n - 3)) / np.sqrt(m_tot)
        att.append(DeviceAttachment(dev, B))
    Gamma = rng.standard_normal((n, 6)) * np.sqrt(m_tot) * 0.2
    Gamma[0, :] = 0.0
    Gamma[1, :] = 0.0
    Gamma[2, :] = 0.0
    Gamma[0, 0] = np.sqrt(m_tot)
    Gamma[1, 1] = np.sqrt(m_tot)
    Gamma[2, 5] = np.sqrt(J)
    n_out = 42
    C_out = np.hstack([np.zeros((n_out, 2 * n)), rng.standard_normal((n_out, n)) * 1e-3])
    D_out = rng.standard_normal((n_out, 6)) * 0.1
    return ReducedSystem(np.eye(n), C, K, Gamma, tuple(att), C_out, D_out)


def with_linear_devices(system: ReducedSystem) -> ReducedSystem:
    """The same system with every device replaced by a linear k-c of its initial tangent."""
    att = []
    for a in system.devices:
        k = np.diag(a.device.reference_stiffness())[: a.device.n_dir]
        c = np.diag(a.device.reference_damping())[: a.device.n_dir]
        att.append(DeviceAttachment(LinearDevice(list(k), list(c), name=a.device.name), a.B))
    return replace(system, devices=tuple(att))


def numpy_reference(sim: Simulator, ag: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Same scheme as the kernel, one numpy step at a time; returns drifts (nf, nt) and y."""
    law = evaluate_law.py_func
    nd = sim.kinds.size
    nf = 2 * nd
    ns = sim._ns
    lam = sim._coef[0] + 1j * sim._coef[1]
    e0 = sim._coef[2] + 1j * sim._coef[3]
    e1 = sim._coef[4] + 1j * sim._coef[5]
    Ga = sim._GaT.T[:ns] + 1j * sim._GaT.T[ns:]
    Gf = sim._GfT.T[:ns] + 1j * sim._GfT.T[ns:]
    P, H, W = sim._P, sim._HT.T, sim._Wy
    Kr = np.zeros((nf, nf))
    Cr = np.zeros((nf, nf))
    for d in range(nd):
        Kr[2 * d : 2 * d + 2, 2 * d : 2 * d + 2] = sim.Kr[d]
        Cr[2 * d : 2 * d + 2, 2 * d : 2 * d + 2] = sim.Cr[d]
    kj = np.repeat(sim._kjump, 2)
    cj = np.repeat(sim._cjump, 2)
    xi = np.zeros(ns, dtype=complex)
    ft = np.zeros(nf)
    ft_old = np.zeros(nf)
    Jinv = None
    states = np.array([a.device.initial_state() for a in sim.system.devices])
    w_prev = Ga @ ag[:, 0]
    nt = ag.shape[1]
    out_u = np.zeros((nf, nt))
    y = np.zeros((W.shape[0], nt))
    y[:, 0] = W @ np.concatenate([np.zeros(2 * ns), ag[:, 0], np.zeros(nf)])
    f = np.zeros(2)
    Kt = np.zeros((2, 2))
    Ct = np.zeros((2, 2))
    s_tr = np.zeros_like(states)
    for k in range(1, nt):
        ga = Ga @ ag[:, k]
        xp = lam * xi + e0 * w_prev + e1 * ga
        uvp = P @ np.concatenate([xp.real, xp.imag])
        ft, ft_old = 2.0 * ft - ft_old, ft
        uv = uvp + H @ ft
        for _ in range(sim.max_iter):
            u, v = uv[:nf], uv[nf:]
            fful = np.zeros(nf)
            DK = np.zeros((nf, nf))
            DC = np.zeros((nf, nf))
            for d in range(nd):
                sl = slice(2 * d, 2 * d + 2)
                law(sim.kinds[d], sim.params[d], states[d], u[sl], v[sl], f, Kt, Ct, s_tr[d])
                fful[sl] = f
                DK[sl, sl] = Kt
                DC[sl, sl] = Ct
            DK -= Kr
            DC -= Cr
            R = ft - (fful - Kr @ u - Cr @ v)
            tol = sim.rtol * np.abs(fful).max()
            if np.abs(R).max() <= tol:
                break
            for attempt in range(2):  # kept inverse, rebuilt when its linear residual is big
                if Jinv is None or attempt == 1:
                    Jinv = np.linalg.inv(np.eye(nf) - DK @ H[:nf] - DC @ H[nf:])
                dft = -Jinv @ R
                duv = H @ dft
                lin1 = R + dft - DK @ duv[:nf] - DC @ duv[nf:]
                if attempt == 1 or np.abs(lin1).max() <= 0.25 * tol:
                    break
            bound = (np.abs(lin1) + 2.0 * (np.abs(DK) @ np.abs(duv[:nf])
                     + np.abs(DC) @ np.abs(duv[nf:])) + kj * np.abs(duv[:nf])
                     + cj * np.abs(duv[nf:]))  # fmt: skip
            ft = ft + dft
            uv = uv + duv
            if bound.max() <= tol:
                fful = ft + Kr @ uv[:nf] + Cr @ uv[nf:]
                break
        states[:] = s_tr
        gf = Gf @ ft
        xi = xp + e1 * gf
        w_prev = ga + gf
        out_u[:, k] = uv[:nf]
        y[:, k] = W @ np.concatenate([xi.real, xi.imag, ag[:, k], fful])
    return out_u, y


def main() -> None:
    """Run the benchmark and print the JSON summary line."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cold", action="store_true", help="compile into an empty numba cache")
    ap.add_argument("--repeat", type=int, default=3, help="timed runs (the best is kept)")
    ap.add_argument("--ref-seconds", type=float, default=2.0, help="numpy reference length")
    args = ap.parse_args()
    dt = 1e-3
    T = 60.0
    rng = np.random.default_rng(7)
    nt = int(T / dt) + 1
    ag = rng.standard_normal((6, nt)) * np.array([[1.5], [1.5], [0.5], [0.05], [0.05], [0.05]])
    system = building()
    t0 = time.perf_counter()
    sim = Simulator(system, dt, modal_histories=False)
    sim.step_block(ag[:, :50])  # compiles (or loads the cache)
    t_compile = time.perf_counter() - t0

    def best_of(s: Simulator, run: Callable[[], object]) -> tuple[float, float]:
        """Best wall time and best CPU time (time.process_time) of ``args.repeat`` runs."""
        walls, cpus = [], []
        for _ in range(args.repeat):
            s.reset()
            t0, c0 = time.perf_counter(), time.process_time()
            run()
            walls.append(time.perf_counter() - t0)
            cpus.append(time.process_time() - c0)
        return min(walls), min(cpus)

    sim.reset()
    res = sim.step_block(ag)
    t_run, c_run = best_of(sim, lambda: sim.step_block(ag))
    rtf = T / t_run
    sim_q = Simulator(system, dt)
    sim_q.step_block(ag[:, :50])
    t_q, c_q = best_of(sim_q, lambda: sim_q.step_block(ag))
    sim.reset()
    blocks = [sim.step_block(ag[:, i : i + 100]) for i in range(0, nt, 100)]
    same = np.array_equal(np.hstack([b.drift for b in blocks]), res.drift)
    starts = range(0, nt, 100)
    t_stream, c_stream = best_of(
        sim, lambda: [sim.step_block(ag[:, i : i + 100]) for i in starts]
    )
    # where the time goes: the same kernel with linear devices (the laws cost nothing, the
    # Newton converges at once) and with one output instead of 42 (no output product)
    floor = {}
    for key, variant in (("linear_devices", with_linear_devices(system)),
                         ("one_output", replace(system, C_out=system.C_out[:1],
                                                D_out=system.D_out[:1]))):
        sv = Simulator(variant, dt, modal_histories=False)
        sv.step_block(ag[:, :50])
        floor[key] = T / best_of(sv, lambda sv=sv: sv.step_block(ag))[1]
    n_ref = int(args.ref_seconds / dt) + 1
    t0 = time.perf_counter()
    ref_u, ref_y = numpy_reference(sim, ag[:, :n_ref])
    t_ref = time.perf_counter() - t0
    rtf_ref = (n_ref - 1) * dt / t_ref
    ri = sim._row_index
    err = np.abs(ref_u[ri] - res.drift[:, :n_ref]).max() / np.abs(res.drift[:, :n_ref]).max()
    err_y = np.abs(ref_y - res.y[:, :n_ref]).max() / np.abs(res.y[:, :n_ref]).max()
    it = res.newton_iterations[1:]
    cache = "cold (empty cache dir)" if args.cold else "warm (numba cache loaded if present)"
    print(f"compile, {cache}: {t_compile:.2f} s (cond V = {sim.cond_V:.2e})")
    print(f"numba kernel: {T:.0f} s simulated in {t_run:.3f} s -> RTF {rtf:.0f} "
          f"(best of {args.repeat}; y, drifts, forces); CPU time {c_run:.3f} s -> "
          f"RTF {T / c_run:.0f} ({c_run / (nt - 1) * 1e6:.2f} us per step)")
    print(f"  with q, q', q'' too: RTF {T / t_q:.0f} (CPU {T / c_q:.0f}); streaming in "
          f"100-sample blocks: {T / t_stream:.0f} (CPU {T / c_stream:.0f}), bitwise same "
          f"drifts: {same}")
    print(f"  law evaluations per step: mean {it.mean():.3f}, max {it.max()}, "
          f"rtol {sim.rtol:g}; peak drift {np.abs(res.drift).max():.3f} m")
    print(f"numpy reference: {(n_ref - 1) * dt:.1f} s in {t_ref:.2f} s -> RTF {rtf_ref:.2f} "
          f"(max rel. difference drift {err:.1e}, y {err_y:.1e})")
    print(f"speed-up vs numpy: {rtf / rtf_ref:.0f}")
    print(f"where the time goes (CPU RTF): all devices linear {floor['linear_devices']:.0f}, "
          f"one output instead of {system.C_out.shape[0]}: {floor['one_output']:.0f}")
    print(json.dumps({
        "rtf_building": round(rtf, 1),
        "rtf_building_cpu": round(T / c_run, 1),
        "rtf_streaming_100": round(T / t_stream, 1),
        "rtf_streaming_100_cpu": round(T / c_stream, 1),
        "rtf_with_modal_histories": round(T / t_q, 1),
        "rtf_with_modal_histories_cpu": round(T / c_q, 1),
        "rtf_numpy_reference": round(rtf_ref, 3),
        "speedup_vs_numpy": round(rtf / rtf_ref, 1),
        "rtf_linear_devices_cpu": round(floor["linear_devices"], 1),
        "rtf_one_output_cpu": round(floor["one_output"], 1),
        "evals_per_step": round(float(it.mean()), 4),
        "rtol": sim.rtol,
        "compile_s": round(t_compile, 2),
        "compile_cache": "cold" if args.cold else "warm",
        "n_modes": system.n,
        "n_devices": len(system.devices),
        "fs_hz": 1.0 / dt,
        "simulated_s": T,
    }))


if __name__ == "__main__":
    main()
