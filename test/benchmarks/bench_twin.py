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

The serial chain (``serial_chain_flops_per_step``, :func:`chain_flops`): the linear algebra
that stays in the per-sample loop because it feeds the device forces back (drift
prediction, force predictor, one Newton correction, force projection, diagonal commit; the
laws are not counted); ``serial_chain_gflops_achieved`` divides it by the loop's CPU time
per sample (the input block products subtracted, the laws included), and
``machine_gflops_limit`` is the same chain alone on this machine: a numba loop of the same
shapes and loop forms with a linear feedback in place of the laws
(:func:`machine_chain_gflops`). ``us_per_step`` = input block products + loop + output
product, CPU time.

The vehicle twin (``rtf_vehicle``): the S2 trailer car (config/vehicles/trailer_car.yaml)
at 400 Hz on 60 s of track at 300 km/h, CPU time; ``rtf_vehicle_devices`` with the
secondary suspension as devices.

The 3D car's twin (``rtf_vehicle3d_cpu``, ``rtf_vehicle3d_shell_cpu``): the plant of
config/vehicles/trailer_car_3d.yaml (rigid or shell carbody; floor accelerations and every
device site's stroke and force) at 400 Hz on 60 s of track at 300 km/h, CPU time.

The OpenSees peer (peer_opensees.py; skipped with a line saying so when openseespy is not
importable, ``pip install -r requirements/bench.txt``): a shear-building equivalent of the
same size (36 DOF, six bidirectional isolators at the same plan positions) simulated in
both codes on the first ``--peer-seconds`` of the record (x, y, rz rows). The time ratio
(``opensees_time_ratio``, CPU time of OpenSees' ``analyze`` / the twin's, one thread each)
is given only when the linear case agrees: NRMSE of the base acceleration below 5 %
(``opensees_nrmse_pct``); the bilinear-isolator case is reported beside it. The
difference is Newmark's time discretisation in OpenSees: with OpenSees at dt / 4 (input
interpolated linearly, as the twin's first-order hold assumes) it falls by ~10x
(``opensees_nrmse_quarter_dt_pct``, first 5 s).

Compile time is printed separately: "warm" loads the numba cache, ``--cold`` compiles into
an empty temporary cache directory. Timings on a shared 2-core machine vary by up to a
factor 2 between runs. Last line: one JSON object.

Run: ``.venv/bin/python test/benchmarks/bench_twin.py [--cold] [--repeat 3] [--peer-seconds 10]``
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
from numba import njit

from modal_twin.models.devices import (
    table10_esb,
    table10_rubber_bearing,
    table10_sdp,
)
from modal_twin.models.devices._dispatch import evaluate_law
from modal_twin.models.devices.linear import LinearDevice
from modal_twin.models.plant import Plant
from modal_twin.models.reduced import DeviceAttachment, ReducedSystem
from modal_twin.twin.kernels import BlockRows, gemv_dot4, gemv_t, project_inputs, run_block
from modal_twin.twin.simulator import Simulator

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import peer_opensees


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


def chain_flops(sim: Simulator) -> int:
    """Floating-point operations per sample of the loop's serial chain (the laws excluded).

    The linear algebra that stays in the per-sample loop because it feeds the device forces
    back: drift prediction (Hf ft, the (2 nf, 2 ns) product Q xi_p), force predictor and its
    drifts (H ft), one Newton correction (Jinv R, H dft, bound, force finishing), the force
    projection Gf ft and the diagonal first-order-hold commit of the modal state. The
    correction is counted on every sample (the predictor rarely meets rtol by itself).
    """
    ns, nf = sim._ns, sim._state.ft.size
    n2, nf2 = 2 * ns, 2 * nf
    predict = nf2 + 2 * nf * nf2 + 2 * nf2 * n2 + n2 + 2 * nf + 2 * nf * nf2
    residual = 8 * nf
    newton = 2 * nf * nf + 2 * nf * nf2 + 14 * nf + nf + nf2 + 8 * nf
    commit = 2 * nf * n2 + 24 * ns
    return predict + residual + newton + commit


@njit(cache=True, fastmath={"reassoc", "contract"})
def _same_shape_chain(nt, Q, GfT, HfT, HT, Jinv, coef, Xh, ft, out):  # pragma: no cover
    """The loop's linear algebra alone (same shapes, same loop forms, a linear feedback in
    place of the laws): what this machine does with that serial chain at best."""
    nf2, n2 = Q.shape
    ns = n2 // 2
    nf = GfT.shape[0]
    base = np.zeros(nf2)
    uv = np.empty(nf2)
    duv = np.empty(nf2)
    fg = np.empty(n2)
    R = np.empty(nf)
    Xp = np.empty(n2)
    for k in range(nt):
        for r in range(n2):
            Xp[r] = Xh[r] + 1e-9
        for i in range(nf2):
            uv[i] = base[i]
        gemv_t(uv, HfT, ft)
        for i in range(nf2):
            base[i] = 0.0
        gemv_dot4(base, Q, Xp)
        gemv_t(uv, HT, ft)
        for i in range(nf):  # linear "law" and its residual
            R[i] = ft[i] + 1e-3 * uv[i] + 1e-4 * uv[nf + i]
        for i in range(nf):  # Newton correction with the kept inverse
            acc = 0.0
            for j in range(nf):
                acc += Jinv[i, j] * R[j]
            ft[i] -= acc
        for i in range(nf2):
            duv[i] = 0.0
        gemv_t(duv, HT, ft)
        for r in range(n2):
            fg[r] = 0.0
        gemv_t(fg, GfT, ft)
        for r in range(ns):
            xr = Xp[r] + coef[4, r] * fg[r] - coef[5, r] * fg[ns + r]
            xi = Xp[ns + r] + coef[4, r] * fg[ns + r] + coef[5, r] * fg[r]
            Xh[r] = coef[0, r] * xr - coef[1, r] * xi + coef[2, r] * fg[r]
            Xh[ns + r] = coef[0, r] * xi + coef[1, r] * xr + coef[2, r] * fg[ns + r]
        out[k] = uv[0] + duv[0]


def machine_chain_gflops(sim: Simulator, repeat: int) -> float:
    """GFLOP/s of :func:`_same_shape_chain` with the simulator's matrices (best of repeat)."""
    nt = 20000
    nf = sim._state.ft.size
    Jinv = np.eye(nf) * 0.5
    out = np.empty(nt)
    _same_shape_chain(10, sim._Q, sim._GfT, sim._HfT, sim._HT, Jinv, sim._coef,
                      np.zeros(2 * sim._ns), np.zeros(nf), out)
    best = np.inf
    for _ in range(repeat):
        Xh = np.full(2 * sim._ns, 1e-3)
        c0 = time.process_time()
        _same_shape_chain(nt, sim._Q, sim._GfT, sim._HfT, sim._HT, Jinv, sim._coef, Xh,
                          np.zeros(nf), out)
        best = min(best, time.process_time() - c0)
    return chain_flops(sim) * nt / best / 1e9


def loop_seconds(sim: Simulator, ag: np.ndarray, repeat: int) -> tuple[float, float]:
    """CPU time of the input block products alone and of the kernel calls (per-sample loop
    and the input products it runs per sub-block before its samples), best of repeat."""
    nb = ag.shape[1]
    chunk = 1024
    m = sim._PinT.shape[1]
    ain_all = np.empty((chunk, m))
    nf = sim._state.ft.size
    rows = BlockRows(Ain=np.empty((64, m)), Z=np.empty((chunk, sim._Wy.shape[1])),
                     U=np.empty((chunk, nf)), out_it=np.empty(nb, dtype=np.int64))
    t_in = t_loop = np.inf
    for _ in range(repeat):
        c0 = time.process_time()
        for k0 in range(0, nb, 64):
            project_inputs(ag, k0, min(nb, k0 + 64), sim._PinT, ain_all)
        t_in = min(t_in, time.process_time() - c0)
        sim.reset()
        c0 = time.process_time()
        for k0 in range(0, nb, chunk):
            run_block(ag, k0, min(nb, k0 + chunk), sim._lin, sim._dev, sim._state, rows,
                      sim.rtol, sim.max_iter)
        t_loop = min(t_loop, time.process_time() - c0)
    return t_in, t_loop - t_in


def plant_rtf(plant: Plant, u: np.ndarray, fs_hz: float, repeat: int) -> float:
    """CPU real-time factor of a plant's twin on the inputs ``u`` (best of ``repeat``)."""
    sim = Simulator(plant.system, 1.0 / fs_hz, modal_histories=False)
    sim.step_block(u[:, :50])
    best = np.inf
    for _ in range(repeat):
        sim.reset()
        c0 = time.process_time()
        plant.measure(sim.step_block(u))
        best = min(best, time.process_time() - c0)
    return u.shape[1] / fs_hz / best


def vehicle_rtf(repeat: int, fs_hz: float, secondary_devices: bool) -> float:
    """CPU real-time factor of the trailer-car twin (S2) on 60 s of track at 300 km/h."""
    from modal_twin.models.track import random_profile, wheelset_inputs
    from modal_twin.models.vehicle import build_vehicle, load_vehicle

    T = 60.0
    spec = load_vehicle()
    u = wheelset_inputs(random_profile(spec.speed * T + 40.0, rng=1), spec.axle_x,
                        spec.speed, fs_hz, T)
    plant = build_vehicle(spec, secondary_devices=secondary_devices)
    return plant_rtf(plant, u, fs_hz, repeat)


def vehicle3d_rtf(repeat: int, fs_hz: float, carbody: str = "rigid") -> float:
    """CPU real-time factor of the 3D car's twin (the factory's plant of
    config/vehicles/trailer_car_3d.yaml with ``carbody``, its floor accelerations and every
    site's stroke and force) on 60 s of low-interference track at the file's speed."""
    from modal_twin.models.track3d import random_track_3d, track_inputs_3d
    from modal_twin.models.vehicle3d_factory import Vehicle3DFactory, build_vehicle3d_plant
    from modal_twin.models.vehicle3d_spec import DEFAULT_VEHICLE3D_YAML, load_vehicle3d

    T = 60.0
    spec = load_vehicle3d().with_carbody(carbody)
    v = spec.speed
    u = track_inputs_3d(random_track_3d(v * T + 60.0, rng=1), spec.axle_x, v, fs_hz, T,
                        start_m=30.0)
    sites = tuple(Vehicle3DFactory(DEFAULT_VEHICLE3D_YAML).sites)  # the same for both
    plant = build_vehicle3d_plant(spec, device_channels=sites)
    return plant_rtf(plant, u, fs_hz, repeat)


def opensees_peer(ag6: np.ndarray, dt: float, seconds: float) -> dict[str, float] | None:
    """Run the shear-building peer (see peer_opensees.py) in both codes; print and return
    the time ratio and the differences, or None (with a line saying why) without OpenSees."""
    ok, info = peer_opensees.available()
    if not ok:
        print(f"OpenSees peer: skipped, openseespy not importable ({info}); "
              "pip install -r requirements/bench.txt")
        return None
    nt = int(seconds / dt) + 1
    ag = ag6[list(peer_opensees.INPUT_ROWS), :nt]
    out: dict[str, float] = {}
    for label, nonlinear in (("linear", False), ("bilinear", True)):
        sim = Simulator(peer_opensees.twin_system(nonlinear), dt, modal_histories=False)
        sim.step_block(ag[:, :50])
        t_twin = np.inf
        for _ in range(5):
            sim.reset()
            t0 = time.process_time()
            res = sim.step_block(ag)
            t_twin = min(t_twin, time.process_time() - t0)
        y_ops, t_ops = peer_opensees.run_opensees(ag, dt, nonlinear)
        err = peer_opensees.nrmse_pct(y_ops, res.y)
        out[f"{label}_ratio"] = t_ops / t_twin
        out[f"{label}_nrmse_base_pct"] = float(err[:2].max())
        out[f"{label}_nrmse_roof_pct"] = float(err[2:].max())
        if not nonlinear:  # the difference is Newmark's: it falls as dt^2 in OpenSees
            n5 = min(nt, 5001)
            t = np.arange(n5) * dt
            t4 = np.arange(4 * (n5 - 1) + 1) * (dt / 4)
            ag4 = np.vstack([np.interp(t4, t, a) for a in ag[:, :n5]])
            y4, _ = peer_opensees.run_opensees(ag4, dt / 4, nonlinear)
            y1, _ = peer_opensees.run_opensees(ag[:, :n5], dt, nonlinear)
            e1 = peer_opensees.nrmse_pct(y1, res.y[:, :n5])[:2].max()
            e4 = peer_opensees.nrmse_pct(y4[:, ::4], res.y[:, :n5])[:2].max()
            out["linear_nrmse_quarter_dt_pct"] = float(e4)
            print(f"OpenSees peer, linear, first {(n5 - 1) * dt:.0f} s: NRMSE base acc. "
                  f"{e1:.3f} % at dt, {e4:.3f} % with OpenSees at dt / 4 (Newmark's error)")
        print(f"OpenSees {info} peer, {label} isolators, {seconds:.0f} s (peak drift "
              f"{np.abs(res.drift).max():.3f} m, yield {peer_opensees.UB_ISO} m): NRMSE base acc. "
              f"x / y {err[0]:.2f} / {err[1]:.2f} %, roof {err[2]:.2f} / {err[3]:.2f} % "
              f"(Newmark vs exact FOH); CPU OpenSees {t_ops:.2f} s, twin {t_twin:.4f} s "
              f"-> twin {t_ops / t_twin:.0f}x faster")
    return out


def main() -> None:
    """Run the benchmark and print the JSON summary line."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cold", action="store_true", help="compile into an empty numba cache")
    ap.add_argument("--repeat", type=int, default=3, help="timed runs (the best is kept)")
    ap.add_argument("--ref-seconds", type=float, default=2.0, help="numpy reference length")
    ap.add_argument("--peer-seconds", type=float, default=10.0,
                    help="record length of the OpenSees peer (it runs ~1 ms per step)")
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
    # the serial chain: loop alone vs the same linear algebra at this machine's best
    t_in, t_loop = loop_seconds(sim, ag, args.repeat)
    flops = chain_flops(sim)
    gflops = flops * (nt - 1) / t_loop / 1e9
    limit = machine_chain_gflops(sim, args.repeat)
    rtf_veh = vehicle_rtf(args.repeat, 400.0, secondary_devices=False)
    rtf_veh_dev = vehicle_rtf(args.repeat, 400.0, secondary_devices=True)
    rtf_veh3d = {m: vehicle3d_rtf(args.repeat, 400.0, m) for m in ("rigid", "shell")}
    peer = opensees_peer(ag, dt, args.peer_seconds)
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
    us = c_run / (nt - 1) * 1e6
    us_in, us_loop = t_in / (nt - 1) * 1e6, t_loop / (nt - 1) * 1e6
    print(f"per step (CPU): {us:.3f} us = input block products {us_in:.3f} + per-sample loop "
          f"{us_loop:.3f} (laws included) + output product and the rest "
          f"{us - us_in - us_loop:.3f}")
    print(f"serial chain: {flops} flop per step (laws excluded) -> {gflops:.2f} GFLOP/s in the "
          f"loop; the same chain alone (no laws) on this machine: {limit:.2f} GFLOP/s "
          f"({flops / limit:.0f} ns per step); ratio {gflops / limit:.2f}")
    print(f"vehicle twin (S2 trailer car, 400 Hz, 60 s of track): CPU RTF {rtf_veh:.0f}; with "
          f"the secondary suspension as devices {rtf_veh_dev:.0f}")
    print(f"3D car twin (trailer_car_3d.yaml, 400 Hz, 60 s, floor and every site's stroke "
          f"and force): CPU RTF rigid carbody {rtf_veh3d['rigid']:.0f}, shell carbody "
          f"{rtf_veh3d['shell']:.0f}")
    ratio = nrmse = None
    if peer is not None:
        nrmse = peer["linear_nrmse_base_pct"]
        if nrmse < 5.0:  # the gate: the models agree before their speeds are compared
            ratio = peer["linear_ratio"]
        else:
            print(f"OpenSees peer DISAGREES: NRMSE {nrmse:.1f} % >= 5 %: no time ratio given")
    print(json.dumps({
        "rtf_building": round(rtf, 1),
        "rtf_vehicle": round(rtf_veh, 1),
        "rtf_vehicle_devices": round(rtf_veh_dev, 1),
        "rtf_vehicle3d_cpu": round(rtf_veh3d["rigid"], 1),
        "rtf_vehicle3d_shell_cpu": round(rtf_veh3d["shell"], 1),
        "us_per_step": round(us, 3),
        "us_per_step_loop": round(us_loop, 3),
        "us_per_step_inputs": round(us_in, 3),
        "serial_chain_flops_per_step": flops,
        "serial_chain_gflops_achieved": round(gflops, 2),
        "machine_gflops_limit": round(limit, 2),
        "opensees_time_ratio": None if ratio is None else round(ratio, 1),
        "opensees_nrmse_pct": None if nrmse is None else round(nrmse, 3),
        "opensees_nrmse_quarter_dt_pct": None if peer is None else round(
            peer["linear_nrmse_quarter_dt_pct"], 3),
        "opensees_bilinear_time_ratio": None if peer is None else round(
            peer["bilinear_ratio"], 1),
        "opensees_bilinear_nrmse_pct": None if peer is None else round(
            peer["bilinear_nrmse_base_pct"], 3),
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
