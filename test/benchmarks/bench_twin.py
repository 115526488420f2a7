"""Benchmark of the modal twin: real-time factor of a building-sized partially nonlinear model.

Synthetic system: 36 mass-normalised modes (0.4-35 Hz, 2 % damping, 3 isolation modes with
zero linear stiffness as in Eq. (12) of [004]), six bidirectional isolators placed at the
corners of a 10 m x 12 m plan (2 bilinear RB, 2 Bouc-Wen ESB, 2 Bouc-Wen SDP with the
Table 10 parameters of [004]), 6-DOF random table input at 1 kHz for 60 s. Reports the
real-time factor (simulated s / wall s, one core) of the numba kernel and of a plain-numpy
loop of the same algorithm on a shorter record (numpy linear algebra per step; the device
dispatch runs as Python via ``py_func`` but the individual laws stay jitted, so this
reference is, if anything, optimistic for numpy). Timings on a shared 2-core machine vary
by about a factor 2 between runs.
Compile time is measured separately. Last line: one JSON object.

Run: ``.venv/bin/python test/benchmarks/bench_twin.py``
"""

from __future__ import annotations

import json
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import numpy as np

from modal_twin.models.devices import (
    table10_esb,
    table10_rubber_bearing,
    table10_sdp,
)
from modal_twin.models.devices._dispatch import evaluate_law
from modal_twin.twin.simulator import (
    DeviceAttachment,
    ReducedSystem,
    Simulator,
)


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


def numpy_reference(sim: Simulator, ag: np.ndarray) -> np.ndarray:
    """Same algorithm as the kernel in plain numpy (laws run as Python), returns drifts."""
    law = evaluate_law.py_func
    nd = sim.kinds.size
    nf = 2 * nd
    lam = sim._lr + 1j * sim._li
    e0 = sim._e0r + 1j * sim._e0i
    e1 = sim._e1r + 1j * sim._e1i
    Ga = sim._GaR + 1j * sim._GaI
    Gf = sim._GfR + 1j * sim._GfI
    xi = np.zeros(sim._ns, dtype=complex)
    ft = np.zeros(nf)
    states = np.array([a.device.initial_state() for a in sim.system.devices])
    w_prev = Ga @ ag[:, 0]
    out = np.zeros((nf, ag.shape[1]))
    f = np.zeros(2)
    Kt = np.zeros((2, 2))
    Ct = np.zeros((2, 2))
    s_tr = np.zeros_like(states)
    for k in range(1, ag.shape[1]):
        ga = Ga @ ag[:, k]
        xp = lam * xi + e0 * w_prev + e1 * ga
        uv = sim._P @ np.concatenate([xp.real, xp.imag])
        for _ in range(sim.max_iter):
            uvk = uv + sim._H @ ft
            u, v = uvk[:nf], uvk[nf:]
            R = np.empty(nf)
            DK = np.zeros((nf, nf))
            DC = np.zeros((nf, nf))
            scale = 0.0
            for d in range(nd):
                sl = slice(2 * d, 2 * d + 2)
                law(sim.kinds[d], sim.params[d], states[d], u[sl], v[sl], f, Kt, Ct, s_tr[d])
                R[sl] = ft[sl] - (f - sim.Kr[d] @ u[sl] - sim.Cr[d] @ v[sl])
                DK[sl, sl] = Kt - sim.Kr[d]
                DC[sl, sl] = Ct - sim.Cr[d]
                scale = max(scale, np.abs(f).max())
            if np.abs(R).max() <= sim.rtol * scale:
                break
            Jm = np.eye(nf) - DK @ sim._H[:nf] - DC @ sim._H[nf:]
            ft = ft + np.linalg.solve(Jm, -R)
        states[:] = s_tr
        gf = Gf @ ft
        xi = xp + e1 * gf
        w_prev = ga + gf
        out[:, k] = u
    return out


def main() -> None:
    """Run the benchmark and print the JSON summary line."""
    dt = 1e-3
    T = 60.0
    rng = np.random.default_rng(7)
    nt = int(T / dt) + 1
    ag = rng.standard_normal((6, nt)) * np.array([[1.5], [1.5], [0.5], [0.05], [0.05], [0.05]])
    system = building()
    t0 = time.perf_counter()
    sim = Simulator(system, dt, modal_histories=False)
    sim.step_block(ag[:, :50])  # compiles (or loads the cache) and warms up
    t_compile = time.perf_counter() - t0
    sim.reset()
    t0 = time.perf_counter()
    res = sim.step_block(ag)
    t_run = time.perf_counter() - t0
    rtf = T / t_run
    sim_q = Simulator(system, dt)
    sim_q.step_block(ag[:, :50])
    sim_q.reset()
    t0 = time.perf_counter()
    sim_q.step_block(ag)
    rtf_q = T / (time.perf_counter() - t0)
    sim.reset()
    t0 = time.perf_counter()
    blocks = [sim.step_block(ag[:, i : i + 100]) for i in range(0, nt, 100)]
    t_stream = time.perf_counter() - t0
    same = np.array_equal(np.hstack([b.drift for b in blocks]), res.drift)
    n_ref = 2001
    t0 = time.perf_counter()
    ref = numpy_reference(sim, ag[:, :n_ref])
    t_ref = time.perf_counter() - t0
    rtf_ref = (n_ref - 1) * dt / t_ref
    ri = sim._row_index
    err = np.abs(ref[ri] - res.drift[:, :n_ref]).max() / np.abs(res.drift[:, :n_ref]).max()
    print(f"compile (or cache load) + warm-up: {t_compile:.2f} s (cond V = {sim.cond_V:.2e})")
    print(f"numba kernel: {T:.0f} s simulated in {t_run:.3f} s -> RTF {rtf:.0f}")
    print(f"  (y, drifts, forces; with q, q', q'' too: RTF {rtf_q:.0f}; "
          f"streaming in 100-sample blocks: {T / t_stream:.0f}, bitwise same: {same})")
    print(f"  Newton evaluations per step: mean {res.newton_iterations[1:].mean():.2f}, "
          f"max {res.newton_iterations.max()}; peak drift {np.abs(res.drift).max():.3f} m")
    print(f"numpy reference: {(n_ref - 1) * dt:.1f} s in {t_ref:.2f} s -> RTF {rtf_ref:.2f}"
          f" (max rel. drift difference {err:.1e})")
    print(f"ratio: {rtf / rtf_ref:.0f}")
    print(json.dumps({
        "rtf_building": round(rtf, 1),
        "rtf_streaming_100": round(T / t_stream, 1),
        "rtf_with_modal_histories": round(rtf_q, 1),
        "rtf_numpy_reference": round(rtf_ref, 3),
        "ratio": round(rtf / rtf_ref, 1),
        "compile_s": round(t_compile, 2),
        "n_modes": system.n,
        "n_devices": len(system.devices),
        "fs_hz": 1.0 / dt,
        "simulated_s": T,
    }))


if __name__ == "__main__":
    main()
