"""Tests of the partially nonlinear modal simulator (modal_twin.twin.simulator)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal as sig
from scipy.integrate import solve_ivp

from modal_twin.errors import ConvergenceError, ModelError, OptionError, ShapeError, SignalError
from modal_twin.models.devices import (
    CoulombFriction,
    CubicSpring,
    LinearDevice,
    table10_esb,
    table10_rubber_bearing,
    table10_sdp,
)
from modal_twin.models.reduced import DeviceAttachment, ReducedSystem
from modal_twin.twin.simulator import Simulator, simulate


def _linear_system(rng: np.random.Generator) -> tuple[ReducedSystem, np.ndarray, np.ndarray]:
    n, n_in = 5, 2
    w = 2 * np.pi * np.array([0.5, 2.0, 5.0, 11.0, 23.0])
    K = np.diag(w**2)
    C = np.diag(2 * 0.02 * w)
    C[0, 1] = C[1, 0] = 0.3  # non-proportional
    G = rng.standard_normal((n, n_in))
    B1 = rng.standard_normal((2, n)) * 0.3
    B2 = rng.standard_normal((1, n)) * 0.3
    devs = (
        DeviceAttachment(LinearDevice([3.0, 5.0], [0.2, 0.1]), B1),
        DeviceAttachment(LinearDevice([7.0], [0.3]), B2),
    )
    Cout = np.hstack([np.eye(n), np.zeros((n, n)), np.eye(n)])
    s = ReducedSystem(np.eye(n), C, K, G, devs, Cout, np.zeros((n, n_in)))
    Kl = K + B1.T @ np.diag([3.0, 5.0]) @ B1 + 7 * B2.T @ B2
    Cl = C + B1.T @ np.diag([0.2, 0.1]) @ B1 + 0.3 * B2.T @ B2
    return s, Kl, Cl


def test_linear_matches_lsim() -> None:
    rng = np.random.default_rng(0)
    s, Kl, Cl = _linear_system(rng)
    n, dt, nt = s.n, 1e-3, 20000
    ag = rng.standard_normal((s.n_in, nt))
    r = simulate(s, ag, dt)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Kl, -Cl]])
    Bm = np.vstack([np.zeros((n, s.n_in)), -s.Gamma])
    _, _, x = sig.lsim((A, Bm, np.eye(2 * n), np.zeros((2 * n, s.n_in))), ag.T, np.arange(nt) * dt)
    err = np.sqrt(np.mean((r.q - x[:, :n].T) ** 2)) / np.sqrt(np.mean(x[:, :n] ** 2))
    assert err < 1e-3 * 1e-6  # exact discretisation: ~1e-13 measured
    # outputs: q + q'' with q'' from the equation of motion
    qdd = -Kl @ x[:, :n].T - Cl @ x[:, n:].T - s.Gamma @ ag
    y_ref = x[:, :n].T + qdd
    assert np.sqrt(np.mean((r.y - y_ref) ** 2)) <= 1e-9 * np.sqrt(np.mean(y_ref**2))
    assert r.drift.shape == (3, nt)
    assert r.rows == ("linear.x", "linear.y", "linear.x")


def _isolated_building() -> tuple[ReducedSystem, list[np.ndarray], np.ndarray, np.ndarray]:
    m1, m2 = 500e3, 186e3
    J = m1 * (10.0**2 + 12.0**2) / 12
    ks = m2 * (2 * np.pi * 2.5) ** 2
    M = np.diag([m1, m1, J, m2])
    K = np.zeros((4, 4))  # no linear isolation stiffness: the devices carry it (Eq. 12)
    K[np.ix_([0, 3], [0, 3])] = ks * np.array([[1, -1], [-1, 1]])
    C = np.zeros((4, 4))
    C[np.ix_([0, 3], [0, 3])] = 2 * 0.02 * np.sqrt(ks * m2) * np.array([[1, -1], [-1, 1]])
    P = np.zeros((4, 2))
    P[0, 0] = P[3, 0] = P[1, 1] = 1.0
    pos = [(-5, -6), (5, 6), (5, -6), (-5, 6)]
    devs = [
        table10_rubber_bearing("RB1"),
        table10_esb("ESB1", W=1.1e6),
        table10_sdp(),
        table10_rubber_bearing("RB2"),
    ]
    Bs = [np.array([[1, 0, -py, 0], [0, 1, px, 0.0]]) for px, py in pos]
    att = tuple(DeviceAttachment(d, b) for d, b in zip(devs, Bs, strict=True))
    Cout = np.hstack([np.zeros((4, 8)), np.eye(4)])
    return ReducedSystem(M, C, K, M @ P, att, Cout, P), Bs, M, P


def test_nonlinear_matches_solve_ivp() -> None:
    s, Bs, M, _P = _isolated_building()
    dt, T = 1e-3, 4.0
    t = np.arange(round(T / dt) + 1) * dt
    env = np.sin(np.pi * t / T) ** 2
    agx = env * (3.0 * np.sin(2 * np.pi * 0.6 * t) + 0.8 * np.sin(2 * np.pi * 1.7 * t + 1))
    agy = env * (2.5 * np.sin(2 * np.pi * 0.45 * t + 0.3) + 0.6 * np.sin(2 * np.pi * 2.3 * t))
    ag = np.vstack([agx, agy])
    r = simulate(s, ag, dt)
    Minv = np.linalg.inv(M)
    RB1, ESB, SDP, RB2 = (a.device.params for a in s.devices)

    def bil(u: np.ndarray, v: np.ndarray, p: np.ndarray) -> np.ndarray:
        k, kb, ub = p[0], p[1], p[2]
        f = k * u + p[3:5] * v
        return f - (k - kb) * (np.minimum(u + ub, 0.0) + np.maximum(u - ub, 0.0))  # Eq. (9)

    def bw(A: float, b: float, g: float, Z: np.ndarray, ud: np.ndarray) -> np.ndarray:
        (zx, zy), (dx, dy) = Z, ud
        return np.array([
            A * dx - b * abs(dx * zx) * zx - g * dx * zx**2 - b * abs(dy * zy) * zx
            - g * dy * zx * zy,
            A * dy - b * abs(dy * zy) * zy - g * dy * zy**2 - b * abs(dx * zx) * zy
            - g * dx * zx * zy,
        ])  # fmt: skip

    Ksdp = np.array([[SDP[6], SDP[7]], [SDP[7], SDP[8]]])

    def rhs(tt: float, x: np.ndarray) -> np.ndarray:
        q, qd, Ze, Zs = x[:4], x[4:8], x[8:10], x[10:12]
        u = [b @ q for b in Bs]
        v = [b @ qd for b in Bs]
        V = np.hypot(*v[1])
        mu = ESB[5] * (ESB[9] / ESB[8] * 1e-6) ** ESB[6] * (V * 1e3) ** ESB[7]
        f = [
            bil(u[0], v[0], RB1),
            mu * ESB[9] * Ze + ESB[3:5] * v[1],
            Ksdp @ (SDP[5] * u[2] + (1 - SDP[5]) * Zs) + SDP[3:5] * v[2],
            bil(u[3], v[3], RB2),
        ]
        a = np.array([np.interp(tt, t, agx), np.interp(tt, t, agy)])
        F = sum(b.T @ fi for b, fi in zip(Bs, f, strict=True))
        qdd = Minv @ (-s.C @ qd - s.K @ q - s.Gamma @ a - F)
        return np.concatenate([qd, qdd, bw(*ESB[:3], Ze, v[1]), bw(*SDP[:3], Zs, v[2])])

    sol = solve_ivp(
        rhs, (0, T), np.zeros(12), method="DOP853", t_eval=t, rtol=1e-9, atol=1e-12,
        max_step=2e-3,
    )  # fmt: skip
    assert sol.status == 0
    qr = sol.y[:4]
    err = np.sqrt(np.mean((r.q - qr) ** 2, axis=1)) / np.sqrt(np.mean(qr**2, axis=1))
    assert np.all(err < 0.005)  # ~3e-6 measured
    assert np.abs(r.drift).max() > 0.1  # well into the nonlinear range (yield 0.026 m)


def test_streaming_equals_one_shot() -> None:
    s, *_ = _isolated_building()
    rng = np.random.default_rng(3)
    ag = rng.standard_normal((2, 3001)) * 2.0
    one = simulate(s, ag, 1e-3)
    sim = Simulator(s, 1e-3)
    parts = [sim.step_block(ag[:, a:b]) for a, b in ((0, 1), (1, 700), (700, 701), (701, 3001))]
    for name in ("drift", "force", "t", "newton_iterations"):  # the kernel state: bitwise
        np.testing.assert_array_equal(np.hstack([getattr(p, name) for p in parts]),
                                      getattr(one, name))
    for name in ("y", "q", "qd", "qdd"):  # BLAS products of that state: to rounding
        ref = getattr(one, name)
        np.testing.assert_allclose(np.hstack([getattr(p, name) for p in parts]), ref,
                                   rtol=0, atol=1e-13 * np.abs(ref).max())
    sim.reset()
    again = sim.step_block(ag)
    np.testing.assert_array_equal(again.drift, one.drift)


def test_refuses_nonfinite_input() -> None:
    s, *_ = _isolated_building()
    ag = np.zeros((2, 100))
    ag[1, 42] = np.nan
    with pytest.raises(SignalError, match=r"sample 42 .*channel 1"):
        simulate(s, ag, 1e-3)
    sim = Simulator(s, 1e-3)
    sim.step_block(np.zeros((2, 10)))
    ag[1, 42] = np.inf
    with pytest.raises(SignalError, match=r"sample 52 .*channel 1"):
        sim.step_block(ag)


def test_nonfinite_state_stops() -> None:
    # a strongly softening cubic spring runs away once past its stability limit
    B = np.array([[1.0]])
    s = ReducedSystem(np.eye(1), np.zeros((1, 1)), np.eye(1), np.eye(1),
                      (DeviceAttachment(CubicSpring(0.0, -1e3, [0.0]), B),),
                      np.zeros((1, 3)), np.zeros((1, 1)))
    with pytest.raises((SignalError, ConvergenceError), match="sample"):
        simulate(s, -np.ones((1, 20000)) * 50.0, 1e-3)


def test_newton_divergence_reported() -> None:
    B = np.array([[1.0]])
    s = ReducedSystem(np.eye(1), np.zeros((1, 1)), np.eye(1), np.eye(1),
                      (DeviceAttachment(CoulombFriction(1.0, 0.5, 1e3), B),),
                      np.zeros((1, 3)), np.zeros((1, 1)))
    with pytest.raises(ConvergenceError, match="did not converge in 1 iterations"):
        simulate(s, np.ones((1, 10)) * 10.0, 1e-3, max_iter=1)


def test_errors() -> None:
    rng = np.random.default_rng(1)
    s, *_ = _linear_system(rng)
    with pytest.raises(OptionError, match="method"):
        simulate(s, np.zeros((2, 3)), 1e-3, method="newmark")  # type: ignore[arg-type]
    with pytest.raises(OptionError, match="dt"):
        Simulator(s, -1.0)
    with pytest.raises(OptionError, match="rtol"):
        Simulator(s, 1e-3, rtol=0.0)
    with pytest.raises(ShapeError, match="ag"):
        simulate(s, np.zeros((3, 4)), 1e-3)
    n = s.n
    kw = {"M": np.eye(n), "C": s.C, "K": s.K, "Gamma": s.Gamma, "devices": s.devices,
          "C_out": s.C_out, "D_out": s.D_out}
    with pytest.raises(ShapeError, match="K: expected"):
        ReducedSystem(**{**kw, "K": np.eye(n + 1)})
    with pytest.raises(ShapeError, match="Gamma"):
        ReducedSystem(**{**kw, "Gamma": np.zeros((n + 1, 2))})
    with pytest.raises(ShapeError, match="C_out"):
        ReducedSystem(**{**kw, "C_out": np.zeros((2, n))})
    with pytest.raises(ShapeError, match="D_out"):
        ReducedSystem(**{**kw, "D_out": np.zeros((n, 3))})
    with pytest.raises(ShapeError, match="output_names"):
        ReducedSystem(**kw, output_names=("a",))
    bad_dev = (DeviceAttachment(LinearDevice([1.0], [0.0]), np.zeros((2, n))),)
    with pytest.raises(ShapeError, match=r"devices\[0\]\.B"):
        ReducedSystem(**{**kw, "devices": bad_dev})
    with pytest.raises(ModelError, match="finite"):
        ReducedSystem(**{**kw, "C": np.full((n, n), np.nan)})
    with pytest.raises(ModelError, match="cond\\(M\\)"):
        Simulator(ReducedSystem(**{**kw, "M": np.zeros((n, n))}), 1e-3)
    free = ReducedSystem(np.eye(1), np.zeros((1, 1)), np.zeros((1, 1)), np.eye(1), (),
                         np.zeros((1, 3)), np.zeros((1, 1)))
    with pytest.raises(ModelError, match="ill-conditioned"):
        Simulator(free, 1e-3)


def test_one_law_evaluation_per_step_at_default_tolerance() -> None:
    # the modified Newton with the correction bound accepts most samples after one
    # evaluation, and the result stays far below the time-discretisation error
    s, *_ = _isolated_building()
    rng = np.random.default_rng(5)
    ag = rng.standard_normal((2, 3001)) * 2.0
    fast = simulate(s, ag, 1e-3)
    tight = simulate(s, ag, 1e-3, rtol=1e-12)
    assert fast.newton_iterations[1:].mean() < 1.2  # 1.03 measured
    assert np.abs(tight.drift).max() > 0.03  # past the RB yield drift (0.026 m)
    err = np.sqrt(np.mean((fast.drift - tight.drift) ** 2)) / np.sqrt(np.mean(tight.drift**2))
    assert err < 1e-6  # ~1e-9 measured
    # dt against dt / 4 (first-order hold: the input is linear between samples)
    t = np.arange(ag.shape[1]) * 1e-3
    t4 = np.arange(4 * (ag.shape[1] - 1) + 1) * 0.25e-3
    fine = simulate(s, np.vstack([np.interp(t4, t, a) for a in ag]), 0.25e-3, rtol=1e-12)
    disc = np.sqrt(np.mean((tight.drift - fine.drift[:, ::4]) ** 2))
    assert np.sqrt(np.mean((fast.drift - tight.drift) ** 2)) < 1e-2 * disc


def test_stick_slip_corrections_bounded() -> None:
    # Coulomb friction: the sticking stiffness enters the correction bound (kjump), so
    # the default tolerance tracks a tight solve through stick-slip transitions
    B = np.array([[1.0]])
    w = 2 * np.pi * 2.0
    s = ReducedSystem(np.eye(1), np.array([[0.1 * w]]), np.array([[w * w]]), np.eye(1),
                      (DeviceAttachment(CoulombFriction(2.0, 1.5, 1e4), B),),
                      np.array([[1.0, 0.0, 0.0]]), np.zeros((1, 1)))
    t = np.arange(4001) * 1e-3
    ag = 8.0 * np.sin(2 * np.pi * 1.3 * t)[None, :]
    fast = simulate(s, ag, 1e-3)
    tight = simulate(s, ag, 1e-3, rtol=1e-12)
    f = np.abs(tight.force[0])
    assert 1.9 < f.max() <= 2.0  # breakaway (static force) reached
    assert np.count_nonzero(np.abs(f - 1.5) < 1e-9) > 1000  # sliding at the kinetic force
    assert np.count_nonzero(f < 1.4) > 50  # sticking again after reversals
    np.testing.assert_allclose(fast.force, tight.force, rtol=0, atol=1e-5 * 2.0)
    np.testing.assert_allclose(fast.drift, tight.drift, rtol=0,
                               atol=1e-5 * np.abs(tight.drift).max())


def test_invert_inplace_matches_numpy() -> None:
    from modal_twin.twin.kernels import invert_inplace

    rng = np.random.default_rng(2)
    A = rng.standard_normal((7, 7))
    A[0, 0] = 0.0  # needs a row exchange
    Ainv = np.empty_like(A)
    invert_inplace(A.copy(), Ainv)
    np.testing.assert_allclose(Ainv @ A, np.eye(7), atol=1e-12 * np.linalg.cond(A))


def test_batched_bouc_wen_equals_the_law() -> None:
    # the kernel advances the Bouc-Wen devices together (bw_advance_many) and finishes
    # each with bw_esb_force / bw_sdp_force and the cached ESB pressure factor: the same
    # numbers, to the last bit, as the public laws (Device.evaluate), sub-steps included
    from modal_twin.models.devices import BoucWenESB, BoucWenSDP
    from modal_twin.models.devices.base import N_STATE
    from modal_twin.models.devices.bouc_wen import (
        bw_advance_many,
        bw_esb_force,
        bw_sdp_force,
        esb_pressure_factor,
    )

    devs = [table10_esb("ESB1", W=1.1e6), table10_sdp(),
            BoucWenESB(30.0, 5.0, 40.0, [1e3, 2e3], W=2e6, mu0=0.05, mu1=-0.3, mu2=0.2, S=0.2),
            BoucWenSDP(1.0, 300.0, 900.0, np.array([[2e6, 3e5], [3e5, 1e6]]), 0.2, [1e3, 1e3]),
            BoucWenSDP(1.0, 300.0, 900.0, np.diag([2e6, 1e6]), 0.1, [1e3, 1e3], uncoupled=True)]
    nd = len(devs)
    params = np.array([d.params for d in devs])
    idx = np.arange(nd, dtype=np.int64)
    rng = np.random.default_rng(11)
    states = np.zeros((nd, N_STATE))
    n_multi = 0
    for k in range(400):
        step = 1e-4 if k % 50 else 3e-2  # every 50th increment needs several RK4 sub-steps
        uv = np.zeros(4 * nd)
        uv[: 2 * nd] = states[:, :2].ravel() + step * rng.standard_normal(2 * nd)
        uv[2 * nd :] = 0.2 * rng.standard_normal(2 * nd) * (k % 7 != 0)  # some V = 0
        s_new = np.zeros_like(states)
        tan = np.zeros((nd, 4))
        nsub = np.zeros(nd, dtype=np.int64)
        bw_advance_many(idx, params, states, uv, s_new, tan, np.empty((11, nd)), nsub)
        n_multi += int(nsub.max() > 1)
        for d, dev in enumerate(devs):
            u = uv[2 * d : 2 * d + 2]
            v = uv[2 * nd + 2 * d : 2 * nd + 2 * d + 2]
            f_ref, Kt_ref, Ct_ref, s_ref = dev.evaluate(u, v, states[d])
            f, Kt, Ct = np.zeros(2), np.zeros((2, 2)), np.zeros((2, 2))
            if isinstance(dev, BoucWenESB):
                bw_esb_force(params[d], v.copy(), f, Kt, Ct, s_new[d], *tan[d],
                             esb_pressure_factor(params[d]))
            else:
                bw_sdp_force(params[d], u.copy(), v.copy(), f, Kt, Ct, s_new[d], *tan[d])
            for ref, got in ((f_ref, f), (Kt_ref, Kt), (Ct_ref, Ct), (s_ref, s_new[d])):
                # bitwise on a warm numba cache; a cold compile may contract one
                # multiply-add differently (seen: 1 ulp), hence 1e-14 relative
                np.testing.assert_allclose(got, ref, rtol=1e-14, atol=1e-300)
        states = s_new
    assert n_multi >= 7  # the sub-stepped branch was exercised


def test_split_drift_prediction_equals_projection() -> None:
    # the kernel predicts the drift of the next sample as Q xi_p,k + Ua0 a_k + Ua1 a_k+1
    # + Hf ft_k; it must equal P xi_p,k+1 with xi_p,k+1 = Lambda xi_k + E0 w_k + E1 g_k+1
    s, *_ = _isolated_building()
    sim = Simulator(s, 1e-3)
    rng = np.random.default_rng(4)
    ns, nf = sim._ns, sim._state.ft.size
    lam = sim._coef[0] + 1j * sim._coef[1]
    e0 = sim._coef[2] + 1j * sim._coef[3]
    e1 = sim._coef[4] + 1j * sim._coef[5]
    Ga = sim._GaT.T[:ns] + 1j * sim._GaT.T[ns:]
    Gf = sim._GfT.T[:ns] + 1j * sim._GfT.T[ns:]
    xi_p = rng.standard_normal(ns) + 1j * rng.standard_normal(ns)
    a0, a1 = rng.standard_normal((2, s.n_in))
    ft = rng.standard_normal(nf) * 1e5
    xi = xi_p + e1 * (Gf @ ft)
    w = Ga @ a0 + Gf @ ft
    xi_next = lam * xi + e0 * w + e1 * (Ga @ a1)
    ref = sim._P @ np.concatenate([xi_next.real, xi_next.imag])
    got = (sim._Q @ np.concatenate([xi_p.real, xi_p.imag]) + sim._Ua0T.T @ a0
           + sim._Ua1T.T @ a1 + sim._HfT.T @ ft)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12 * np.abs(ref).max())
