"""The one Bouc-Wen integrator (models.devices.bouc_wen.bouc_wen_history): closed forms,
the device law, and the implementations it replaced (diagnosis.restoring_force, .sdof)."""

from __future__ import annotations

import numpy as np
import pytest

from modal_twin.diagnosis.restoring_force import bouc_wen_state
from modal_twin.errors import OptionError
from modal_twin.models.devices import BoucWenSDP
from modal_twin.models.devices.bouc_wen import bouc_wen_history, bw_rate_uniaxial


def _history(n: int = 1500) -> np.ndarray:
    """Growing, noisy cycles with several reversals, m."""
    rng = np.random.default_rng(11)
    t = np.arange(n) / 100.0
    return 0.02 * np.sin(2 * np.pi * 0.8 * t) * (1 + t / 5) + 1e-3 * rng.standard_normal(n)


def _old_restoring_force(y, a, b, nu, nsub):
    """diagnosis.restoring_force._bw_state before the registry (commit cce8463), in Python."""
    w = np.empty_like(y)
    w[0] = 0.0
    s = 0.0
    for i in range(1, y.size):
        h = (y[i] - y[i - 1]) / nsub
        for _ in range(nsub):
            k1 = h - a * abs(h) * abs(s) ** (nu - 1.0) * s - b * h * abs(s) ** nu
            s2 = s + 0.5 * k1
            k2 = h - a * abs(h) * abs(s2) ** (nu - 1.0) * s2 - b * h * abs(s2) ** nu
            s3 = s + 0.5 * k2
            k3 = h - a * abs(h) * abs(s3) ** (nu - 1.0) * s3 - b * h * abs(s3) ** nu
            s4 = s + k3
            k4 = h - a * abs(h) * abs(s4) ** (nu - 1.0) * s4 - b * h * abs(s4) ** nu
            s += (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
        w[i] = s
    return w


def _old_sdof_rate(v, z, al, a, b, nu):
    """dz/dt of Eq. (2) in diagnosis.sdof._rhs before the registry (commit cce8463)."""
    az = abs(z)
    if nu == 1.0:
        return al * v - a * abs(v) * z - b * v * az
    return al * v - a * abs(v) * az ** (nu - 1.0) * z - b * v * az**nu


def test_elastic_limit_small_drift() -> None:
    """|z| << bound: the nonlinear terms vanish, z = A u."""
    beta = gamma = 500.0  # bound sqrt(A / (beta + gamma)) = 0.0316 with A = 1
    u = 1e-6 * np.sin(np.linspace(0.0, 6 * np.pi, 601))
    for A in (1.0, 3.0):
        z = bouc_wen_history(u, beta=beta, gamma=gamma, A=A)
        # first neglected term: beta |u| z^2 ~ 1e3 * (1e-6)^2 relative to A u -> 1e-9
        np.testing.assert_allclose(z, A * u, rtol=0, atol=1e-8 * A * 1e-6)


@pytest.mark.parametrize("A", [1.0, 2.5])
def test_monotonic_drift_closed_forms(A: float) -> None:
    """Loading from rest: nu = 2 gives z = zu tanh(u A / zu), nu = 1 gives
    z = zu (1 - exp(-u A / zu)), with zu = (A / (beta + gamma))^(1 / nu) the saturation."""
    beta, gamma = 300.0, 700.0
    u = np.linspace(0.0, 0.3, 3001)
    zu2 = np.sqrt(A / (beta + gamma))
    z2 = bouc_wen_history(u, beta=beta, gamma=gamma, A=A, nu=2.0)
    np.testing.assert_allclose(z2, zu2 * np.tanh(u * A / zu2), rtol=0, atol=1e-9 * zu2)
    assert z2[-1] == pytest.approx(zu2, rel=2e-8)  # saturated: tanh(9.5) = 1 - 1.1e-8
    zu1 = A / (beta + gamma)
    z1 = bouc_wen_history(u, beta=beta, gamma=gamma, A=A, nu=1.0, n_sub=4)
    # RK4 truncation with 4 sub-steps of A du / zu <= 0.025: 3e-9 zu at most
    np.testing.assert_allclose(z1, zu1 * (1 - np.exp(-u * A / zu1)), rtol=0, atol=1e-8 * zu1)
    assert z1[-1] == pytest.approx(zu1, rel=1e-12)  # exp(-300 A) underflows: saturated


def test_equals_the_device_law_in_one_direction() -> None:
    """nu = 2, adaptive sub-steps: the scheme of BoucWenSDP (alpha = 0, K = I: f = Zx), to
    rounding (the law writes |dx zx| where the uniaxial rate writes |dx| |z|)."""
    y = np.concatenate([[0.0], _history()])  # the device starts from rest at u = 0
    A, beta, gamma = 1.0, 635.0, 1102.0
    dev = BoucWenSDP(A, beta, gamma, np.eye(2), 0.0, [0.0, 0.0])
    f = dev.respond(np.vstack([y, np.zeros_like(y)])).f[0]
    z = bouc_wen_history(y, beta=beta, gamma=gamma, A=A)
    np.testing.assert_allclose(z, f, rtol=0, atol=1e-12 * np.abs(f).max())


@pytest.mark.parametrize("nu", [1.0, 1.5, 2.0])
def test_equals_the_restoring_force_integrator_it_replaced(nu: float) -> None:
    y = _history(400)
    old = _old_restoring_force(y, 40.0 / 0.03, 15.0 / 0.03, nu, 4)
    np.testing.assert_allclose(bouc_wen_state(y, 40.0 / 0.03, 15.0 / 0.03, nu=nu), old,
                               rtol=1e-10, atol=1e-10 * np.abs(old).max())
    new = bouc_wen_history(y, beta=40.0 / 0.03, gamma=15.0 / 0.03, A=1.0, nu=nu, n_sub=4)
    np.testing.assert_allclose(new, old, rtol=1e-10, atol=1e-10 * np.abs(old).max())


@pytest.mark.parametrize("nu", [1.0, 1.7, 2.0])
def test_rate_equals_the_sdof_model_it_replaced(nu: float) -> None:
    """The single-DOF model's Eq. (2) (time form) is the uniaxial rate with du = v."""
    rng = np.random.default_rng(5)
    for v, z in rng.normal(size=(50, 2)) * [0.3, 200.0]:
        old = _old_sdof_rate(v, z, 5e4, 80.0, -30.0, nu)
        assert bw_rate_uniaxial(5e4, 80.0, -30.0, nu, z, v) == pytest.approx(old, rel=1e-12)


def test_bad_options() -> None:
    with pytest.raises(OptionError, match=r"nu: expected nu >= 1, got 0\.5"):
        bouc_wen_history(np.zeros(3), beta=1.0, gamma=1.0, nu=0.5)
    with pytest.raises(OptionError, match=r"n_sub: expected an int >= 1 or None, got 0"):
        bouc_wen_history(np.zeros(3), beta=1.0, gamma=1.0, n_sub=0)
