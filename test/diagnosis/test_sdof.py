"""Single-DOF diagnosis: classifier of the linear model's residual and Bouc-Wen fit.

Truth records are integrated by scipy's ``solve_ivp`` (an independent solver) with a
continuous multisine force; the displacement carries seeded white noise.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from modal_twin.diagnosis.restoring_force import (
    ResidualDiagnosis,
    bouc_wen_state,
    check_record,
    classify_residual,
    restoring_force_map,
    state_derivatives,
    stop_operator,
)
from modal_twin.diagnosis.sdof import (
    BoucWenSDOF,
    fit_bouc_wen_sdof,
    fit_linear_sdof,
    simulate_sdof,
)
from modal_twin.errors import ModelError, OptionError, ShapeError, SignalError

FS = 1000.0
NT = 3000
M, K = 1.0, 4.0e4  # f_n = 31.8 Hz
C = 2 * 0.02 * np.sqrt(K * M)
SIGMA = 2e-3  # displacement scale (about std(y) of the linear truth), m


def _force() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(7)
    f = np.arange(3.0, 80.0, 1.0 / 3.0)
    ph = rng.uniform(0, 2 * np.pi, f.size)
    amp = 20.0 * np.sqrt(2.0 / f.size)
    return f, ph, np.full(f.size, amp)


def _u(t: np.ndarray | float) -> np.ndarray:
    f, ph, amp = _force()
    return np.sum(amp[:, None] * np.sin(2 * np.pi * f[:, None] * np.atleast_1d(t) + ph[:, None]),
                  axis=0)


@cache
def truth(kind: str, noise: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """Return (u, y) sampled at FS for a known restoring-force law, y with seeded noise."""
    f, ph, amp = _force()
    k3 = 0.2 * K / SIGMA**2
    fc = 5.0  # Coulomb force, N
    k_lin, alpha, a, b = (0.5 * K, 0.5 * K, 0.6 / SIGMA, 0.4 / SIGMA)

    def rhs(t: float, x: np.ndarray) -> list[float]:
        u = float(np.sum(amp * np.sin(2 * np.pi * f * t + ph)))
        y, v, z = x
        if kind == "linear":
            r, dz = K * y, 0.0
        elif kind == "cubic":
            r, dz = K * y + k3 * y**3, 0.0
        elif kind == "coulomb":
            r, dz = K * y + fc * np.tanh(v / 1e-4), 0.0
        else:  # Bouc-Wen, nu = 1
            r, dz = k_lin * y + z, alpha * v - a * abs(v) * z - b * v * abs(z)
        return [v, (u - C * v - r) / M, dz]

    t = np.arange(NT) / FS
    sol = solve_ivp(rhs, (0, t[-1]), [0.0, 0.0, 0.0], t_eval=t, method="LSODA",
                    rtol=1e-9, atol=[1e-12, 1e-10, 1e-8], max_step=1 / (4 * FS))
    y = sol.y[0]
    y = y + noise * np.std(y) * np.random.default_rng(11).standard_normal(NT)
    return _u(t), y


def diagnose(kind: str) -> ResidualDiagnosis:
    u, y = truth(kind)
    lin = fit_linear_sdof(u, y, FS).model
    rf = restoring_force_map(u, y, FS, m=lin.m, c=lin.c, k=lin.k, f_max_hz=150.0)
    return classify_residual(rf)


# --- classifier -------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kind", "expected"),
    [("bouc_wen", "hysteresis"), ("cubic", "cubic_stiffness"), ("coulomb", "friction")],
)
def test_classifier_names_the_effect(kind: str, expected: str) -> None:
    dg = diagnose(kind)
    assert dg.top == expected, (dg.explained, dg.unique)
    assert dg.significant
    assert dg.ranking[0] == expected
    others = [dg.explained[g] for g in dg.explained if g != expected]
    assert dg.explained[expected] > max(0.3, 1.5 * max(others))


def test_classifier_says_nothing_for_linear_truth() -> None:
    dg = diagnose("linear")
    assert dg.top == "nothing significant", dg.explained
    assert not dg.significant
    assert max(dg.explained.values()) < dg.min_score


def test_descriptive_indices() -> None:
    # friction: positive jump at velocity reversal; cubic: odd in y
    assert diagnose("coulomb").jump_index > 0.5
    assert diagnose("cubic").odd_index > 0.3
    # Bouc-Wen against its true linear part: the residual z dissipates energy (a loop)
    u, y = truth("bouc_wen")
    rf = restoring_force_map(u, y, FS, m=M, c=C, k=0.5 * K, f_max_hz=150.0)
    assert classify_residual(rf).loop_energy_ratio > 0.5
    # the linear truth against itself: no loop, no jump
    u, y = truth("linear")
    dg = classify_residual(restoring_force_map(u, y, FS, m=M, c=C, k=K, f_max_hz=150.0))
    assert abs(dg.loop_energy_ratio) < 0.05
    assert abs(dg.jump_index) < 0.3


def test_error_surface_eq20_is_normalised() -> None:
    u, y = truth("cubic")
    rf = restoring_force_map(u, y, FS, m=M, c=C, k=K, f_max_hz=150.0, n_bins=11)
    assert rf.surface.shape == (11, 11)
    np.testing.assert_allclose(rf.e_norm, rf.e / (K * np.max(np.abs(rf.y))))
    # residual of the true linear part is the cubic force k3 y^3 (up to noise and filter)
    k3 = 0.2 * K / SIGMA**2
    cub = k3 * rf.y**3
    assert np.std(rf.e - cub) < 0.15 * np.std(cub)


# --- simulation and fits ----------------------------------------------------------------


def test_simulator_matches_solve_ivp() -> None:
    u, y = truth("bouc_wen", noise=0.0)
    model = BoucWenSDOF(M, C, 0.5 * K, 0.5 * K, 0.6 / SIGMA, 0.4 / SIGMA)
    ys = simulate_sdof(model, u, FS, oversample=10)
    assert np.sqrt(np.mean((ys - y) ** 2)) < 2e-4 * np.std(y)


def test_linear_fit_recovers_m_c_k() -> None:
    u, y = truth("linear")
    fit = fit_linear_sdof(u, y, FS)
    np.testing.assert_allclose([fit.model.m, fit.model.c, fit.model.k], [M, C, K], rtol=0.02)
    assert fit.nrmse < 0.02  # noise is 1 % of std(y)
    assert fit.converged


def test_bouc_wen_fit_recovers_parameters() -> None:
    u, y = truth("bouc_wen")
    fit = fit_bouc_wen_sdof(u, y, FS, f_max_hz=150.0)
    true = [M, C, 0.5 * K, 0.5 * K, 0.6 / SIGMA, 0.4 / SIGMA]
    np.testing.assert_allclose(fit.model.vector(), true, rtol=0.05)
    assert fit.nrmse < 0.015
    assert fit.std.shape == (6,)
    assert np.all(fit.std < 0.05 * np.abs(true))


def test_periodic_simulation_is_steady_state() -> None:
    # a linear SDOF under one multisine period: the FRF gives the steady state exactly
    n = 1000
    rng = np.random.default_rng(3)
    U = np.zeros(n // 2 + 1, complex)
    U[3:60] = np.exp(2j * np.pi * rng.uniform(size=57))
    u = np.fft.irfft(U, n) * 200.0
    w = 2 * np.pi * np.fft.rfftfreq(n, 1 / FS)
    y_ref = np.fft.irfft(np.fft.rfft(u) / (K - M * w**2 + 1j * C * w), n)
    ys = simulate_sdof(BoucWenSDOF(M, C, K), u, FS, period=n, oversample=10)
    # one warm-up period (1 s) leaves exp(-zeta w_n t) ~ 2e-2 of the transient
    assert np.sqrt(np.mean((ys - y_ref) ** 2)) < 0.05 * np.std(y_ref)


def test_operators_known_answers() -> None:
    y = np.array([0.0, 1.0, 3.0, 2.0, -2.0])
    np.testing.assert_allclose(stop_operator(y, 1.5), [0.0, 1.0, 1.5, 0.5, -1.5])
    # nu = 1, a = b = 0: the state is the displacement itself
    np.testing.assert_allclose(bouc_wen_state(y, 0.0, 0.0), y)
    # loading from rest: w = (1 - exp(-(a + b) y)) / (a + b)
    yy = np.linspace(0, 2e-3, 200)
    np.testing.assert_allclose(bouc_wen_state(yy, 300.0, 200.0)[-1],
                               (1 - np.exp(-500 * 2e-3)) / 500, rtol=1e-8)
    # spectral derivatives of a periodic sine
    t = np.arange(500) / 500.0
    x, v, a = state_derivatives(np.sin(2 * np.pi * 5 * t), 500.0, periodic=True)
    np.testing.assert_allclose(v, 2 * np.pi * 5 * np.cos(2 * np.pi * 5 * t), atol=1e-9)
    np.testing.assert_allclose(a, -(2 * np.pi * 5) ** 2 * x, atol=1e-7)


# --- bad input --------------------------------------------------------------------------


def test_bad_records() -> None:
    u, y = truth("linear")
    with pytest.raises(ShapeError, match=r"u, y: expected equal lengths, got 3000 and 2999"):
        fit_linear_sdof(u, y[:-1], FS)
    yn = y.copy()
    yn[17] = np.nan
    with pytest.raises(SignalError, match=r"y: expected finite samples, got nan at index 17"):
        fit_bouc_wen_sdof(u, yn, FS)
    with pytest.raises(ShapeError, match=r"expected at least 64 samples, got 10"):
        fit_linear_sdof(u[:10], y[:10], FS)
    with pytest.raises(ShapeError, match=r"u: expected one channel"):
        check_record(np.ones((2, 100)), np.ones(100), FS)
    with pytest.raises(SignalError, match=r"fs_hz: expected a positive finite"):
        check_record(u, y, -1.0)


def test_bad_options() -> None:
    u, y = truth("linear")
    with pytest.raises(OptionError, match=r"period: expected a divisor of the record length"):
        fit_linear_sdof(u, y, FS, period=7)
    with pytest.raises(OptionError, match=r"period: expected a divisor"):
        restoring_force_map(u, y, FS, m=M, c=C, k=K, period=7)
    with pytest.raises(OptionError, match=r"oversample: expected an integer >= 1"):
        simulate_sdof(BoucWenSDOF(M, C, K), u, FS, oversample=0)
    with pytest.raises(OptionError, match=r"f_max_hz: expected 0 < f_max_hz"):
        state_derivatives(y, FS, f_max_hz=600.0)
    rf = restoring_force_map(u, y, FS, m=M, c=C, k=K)
    with pytest.raises(OptionError, match=r"min_score: expected a fraction in \(0, 1\)"):
        classify_residual(rf, min_score=1.5)
    with pytest.raises(OptionError, match=r"r: expected a positive yield"):
        stop_operator(y, 0.0)
    with pytest.raises(OptionError, match=r"nu: expected nu >= 1"):
        bouc_wen_state(y, 1.0, 1.0, nu=0.5)


def test_bad_models() -> None:
    u, y = truth("linear")
    with pytest.raises(ModelError, match=r"m, c, k, alpha: expected m > 0"):
        BoucWenSDOF(-1.0, C, K)
    with pytest.raises(ModelError, match=r"nu: expected nu >= 1"):
        BoucWenSDOF(M, C, K, nu=0.5)
    with pytest.raises(ModelError, match=r"m, k: expected positive mass and stiffness"):
        restoring_force_map(u, y, FS, m=0.0, c=C, k=K)
    # force and displacement unrelated: the equation-error start has a negative mass
    rng = np.random.default_rng(5)
    with pytest.raises(ModelError, match=r"equation-error start has m="):
        fit_linear_sdof(rng.standard_normal(500), -np.cumsum(rng.standard_normal(500)) * 0, FS)


def test_unstable_candidate_does_not_crash() -> None:
    # a strongly hardening start (a + b < 0) runs away: the simulation stops at the limit
    u, _ = truth("linear")
    ys = simulate_sdof(BoucWenSDOF(M, C, K, 10 * K, -5e4, -5e4), 50 * u, FS, y_limit=1.0)
    assert np.all(np.isfinite(ys))
    assert ys[-1] == 1.0


# --- the external benchmark data, when present ------------------------------------------

DATA = Path(__file__).resolve().parents[3] / "shared" / "benchmarks" / "boucwen"


def test_benchmark_train_names_hysteresis() -> None:
    h5py = pytest.importorskip("h5py")
    if not (DATA / "train.h5").is_file():
        pytest.skip(f"Bouc-Wen benchmark data not found in {DATA}")
    with h5py.File(DATA / "train.h5", "r") as h:
        u = np.asarray(h["multisine/u"][()], float).ravel()
        y = np.asarray(h["multisine/y"][()], float).ravel()
    lin = fit_linear_sdof(u, y, 750.0, period=8192)
    # the best linear SDOF errs by ~1.8e-4 m (benchmark README)
    assert 1.5e-4 < lin.rmse_m < 2.2e-4
    m = lin.model
    rf = restoring_force_map(u, y, 750.0, m=m.m, c=m.c, k=m.k, period=8192, f_max_hz=200.0)
    dg = classify_residual(rf)
    assert dg.top == "hysteresis"
    assert dg.explained["hysteresis"] > 0.8
