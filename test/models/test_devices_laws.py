"""Known-answer tests of the device laws (modal_twin.models.devices)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from modal_twin.errors import ModelError, ShapeError, SignalError
from modal_twin.models.devices import (
    BilinearElastic,
    BilinearHysteretic,
    BoucWenSDP,
    CoulombFriction,
    CubicSpring,
    GapSpring,
    LinearDevice,
    PrandtlJoint,
    table2_mode_bay,
    table6_updated,
    table10_esb,
    table10_rubber_bearing,
    table10_sdp,
)


def _cycle(X: float, n_cyc: int = 2, n: int = 4000) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0.0, n_cyc, n_cyc * n + 1)
    return t, X * np.sin(2 * np.pi * t)


def _loop_area(u: np.ndarray, f: np.ndarray) -> float:
    return float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(u)))


def test_linear_table6_and_force() -> None:
    d = table6_updated("SDP1")
    f, Kt, Ct, _ = d.evaluate([0.01, -0.02], [0.1, 0.2], d.initial_state())
    np.testing.assert_allclose(f, [3793e3 * 0.01 + 159.2e3 * 0.1, -3709e3 * 0.02 + 134.68e3 * 0.2])
    np.testing.assert_allclose(np.diag(Kt), [3793e3, 3709e3])
    np.testing.assert_allclose(np.diag(Ct), [159.2e3, 134.68e3])


def test_bilinear_elastic_eq9_and_no_dissipation() -> None:
    rb = table10_rubber_bearing("RB1")
    k, kb, ub = 1.075e6, 0.786e6, 0.0258
    _t, u = _cycle(0.1)
    r = rb.respond(np.vstack([u, 0.5 * u]))
    expected = np.where(np.abs(u) <= ub, k * u, np.sign(u) * (k * ub + kb * (np.abs(u) - ub)))
    np.testing.assert_allclose(r.f[0], expected, rtol=1e-12, atol=1e-9)
    # nonlinear elastic: a closed cycle dissipates nothing
    assert abs(_loop_area(u, r.f[0])) <= 1e-9 * np.abs(r.f[0]).max() * 0.1
    # small amplitude -> initial stiffness, large -> post-yield
    assert r.Kt[0, 0, 1] == pytest.approx(k)
    assert r.Kt[0, 0, np.argmax(u)] == pytest.approx(kb)


def test_bilinear_hysteretic_loop_area_closed_form() -> None:
    k, kb, ub, X = 2.0e6, 0.5e6, 0.01, 0.05
    d = BilinearHysteretic(k, kb, ub, [0.0])
    t, u = _cycle(X, n_cyc=3)
    r = d.respond(u[None, :])
    last = t >= 2.0
    area = _loop_area(u[last], r.f[0, last])
    assert area == pytest.approx(4 * (k - kb) * ub * (X - ub), rel=1e-3)


def test_coulomb_energy_per_cycle() -> None:
    Fk, X = 100.0, 0.02
    d = CoulombFriction(1.3 * Fk, Fk, kt=1e9)
    t, u = _cycle(X, n_cyc=3, n=20000)
    r = d.respond(u[None, :])
    last = t >= 1.0
    area = _loop_area(u[last], r.f[0, last]) / 2.0
    assert area == pytest.approx(4 * Fk * X, rel=0.01)
    # never above the static limit; sliding at the kinetic force
    assert np.abs(r.f).max() <= 1.3 * Fk * (1 + 1e-12)
    assert np.median(np.abs(r.f)) == pytest.approx(Fk, rel=1e-12)


def test_coulomb_stick_until_static_limit() -> None:
    Fs, Fk, kt = 130.0, 100.0, 1e6
    d = CoulombFriction(Fs, Fk, kt)
    u = np.linspace(0.0, 2 * Fs / kt, 201)
    r = d.respond(u[None, :])
    stuck = kt * u < Fs * (1 - 1e-9)
    np.testing.assert_allclose(r.f[0, stuck], kt * u[stuck])
    assert np.all(r.f[0, ~stuck] == pytest.approx(Fk))


def test_bouc_wen_sdp_vs_solve_ivp() -> None:
    d = table10_sdp()
    t, u = _cycle(0.08, n_cyc=2, n=2000)
    uy = 0.5 * np.sin(2 * np.pi * t + 0.7) * 0.08
    r = d.respond(np.vstack([u, uy]))
    A, b, g = 1.0, 635.0, 1102.0

    def rate(tt: float, Z: np.ndarray) -> np.ndarray:
        dx = 0.08 * 2 * np.pi * np.cos(2 * np.pi * tt)
        dy = 0.04 * 2 * np.pi * np.cos(2 * np.pi * tt + 0.7)
        zx, zy = Z
        return np.array([
            A * dx - b * abs(dx * zx) * zx - g * dx * zx**2 - b * abs(dy * zy) * zx
            - g * dy * zx * zy,
            A * dy - b * abs(dy * zy) * zy - g * dy * zy**2 - b * abs(dx * zx) * zy
            - g * dx * zx * zy,
        ])  # fmt: skip

    z0 = [0.0, 0.04 * np.sin(0.7)]  # u_y(0) != 0: the device jumps there from u = (0, 0)
    d0 = BoucWenSDP(A, b, g, np.diag([3.975e6, 3.779e6]), 0.1225, [0.0, 0.0])
    _, _, _, s1 = d0.evaluate([0.0, z0[1]], [0, 0], d0.initial_state())
    sol = solve_ivp(rate, (0, 2), s1[2:4], t_eval=t, rtol=1e-10, atol=1e-13, max_step=1e-3)
    K = np.diag([3.975e6, 3.779e6])
    f_ref = K @ (0.1225 * np.vstack([u, uy]) + 0.8775 * sol.y)
    err = np.sqrt(np.mean((r.f - f_ref) ** 2, axis=1)) / np.sqrt(np.mean(f_ref**2, axis=1))
    assert np.all(err < 0.01)


def test_bouc_wen_sdp_uncoupled_is_two_uniaxial_laws() -> None:
    # uncoupled: each direction its own variable. Monotonic loading from rest in x with
    # A = 1, beta = gamma = b has the closed form z = tanh(sqrt(2 b) u) / sqrt(2 b)
    # (dz/du = 1 - 2 b z^2), whatever y does; coupled (Eq. (10) of [004]) the same x
    # loading yields earlier when y has loaded z_y (the circular yield surface)
    b, k, alpha = 0.5 / 0.01**2, 4e6, 0.05
    ux = np.linspace(0.0, 0.05, 5001)
    uy = 0.03 * np.sin(np.linspace(0.0, 6.0 * np.pi, ux.size))  # y cycles beyond its yield
    unc = BoucWenSDP(1.0, b, b, np.diag([k, k]), alpha, [0.0, 0.0], uncoupled=True)
    cpl = BoucWenSDP(1.0, b, b, np.diag([k, k]), alpha, [0.0, 0.0])
    zx = np.tanh(np.sqrt(2 * b) * ux) / np.sqrt(2 * b)
    f_ref = k * (alpha * ux + (1 - alpha) * zx)
    f_unc = unc.respond(np.vstack([ux, uy])).f
    np.testing.assert_allclose(f_unc[0], f_ref, rtol=1e-6, atol=1e-6 * k * 0.01)
    # y alone: its own uniaxial loop, the same as with x at rest
    f_y_alone = unc.respond(np.vstack([0 * ux, uy])).f[1]
    np.testing.assert_allclose(f_unc[1], f_y_alone, rtol=1e-12, atol=1e-9)
    f_cpl = cpl.respond(np.vstack([ux, uy])).f
    assert np.max(np.abs(f_cpl[0] - f_ref)) > 0.05 * np.max(np.abs(f_ref))
    # along one direction the two forms are one law (the cross terms vanish with z_y = 0)
    one = np.vstack([0.04 * np.sin(np.linspace(0.0, 4.0 * np.pi, 801)), np.zeros(801)])
    np.testing.assert_array_equal(unc.respond(one).f, cpl.respond(one).f)


def test_bouc_wen_amplitude_limits() -> None:
    d = BoucWenSDP(1.0, 635.0, 1102.0, np.diag([4e6, 4e6]), 0.1, [0.0, 0.0])
    small = d.respond(np.vstack([np.linspace(0, 1e-5, 11), np.zeros(11)]))
    assert small.Kt[0, 0, -1] == pytest.approx(4e6, rel=1e-3)  # initial stiffness
    big = d.respond(np.vstack([np.linspace(0, 0.5, 2001), np.zeros(2001)]))
    assert big.Kt[0, 0, -1] == pytest.approx(0.1 * 4e6, rel=1e-3)  # post-yield alpha K


def test_esb_friction_law_and_saturation() -> None:
    W = 1.1e6
    d = table10_esb("ESB1", W=W)
    u = np.linspace(0.0, 0.3, 3001)
    v = np.full_like(u, 0.1)
    r = d.respond(np.vstack([u, 0 * u]), np.vstack([v, 0 * v]))
    mu = 0.0606 * (W / 0.1018 * 1e-6) ** -0.5883 * (100.0) ** 0.1148
    # Z saturates at sqrt(A / (beta + gamma)) = 1 (A = beta + gamma for the ESB)
    assert r.f[0, -1] == pytest.approx(mu * W + 3.79e3 * 0.1, rel=1e-6)


def test_prandtl_backbone_and_branches() -> None:
    Fs, Kb = 2.0, 1e4
    dc = Fs / Kb
    d = PrandtlJoint(0.0, 0.0, 0.0, 0.0, Fs, Kb)
    X = 3 * dc
    up = np.linspace(0.0, X, 301)
    down = np.linspace(X, -X, 601)[1:]
    back = np.linspace(-X, X, 601)[1:]
    u = np.concatenate([up, down, back])
    r = d.respond(u[None, :])
    f = r.f[0]
    # backbone: stuck line Kb x up to dc, then the slip force
    np.testing.assert_allclose(f[:301], np.minimum(Kb * up, Fs), rtol=1e-12)
    # branch after reversal at dn = X: Eq. (6) of [003] with C1..C3 of Eqs. (9)-(11)
    dn, L = X, X + dc
    C1 = Kb * np.exp(-abs(dn - dc) / dc)
    C2 = (6 * Fs - Kb * L) / L**2 - 2 * C1 / L
    C3 = (-4 * Fs + Kb * L) / L**3 + C1 / L**2
    xi = np.abs(down + dc)
    FM = np.where(down > -dc, -C3 * xi**3 - C2 * xi**2 - C1 * xi + Fs, Fs)
    np.testing.assert_allclose(f[301:901], -FM, rtol=1e-9, atol=1e-12 * Fs)
    # Masing-type start: initial slope Kb after the reversal, odd symmetry of the loop
    assert (f[301] - f[300]) / (down[0] - up[-1]) == pytest.approx(Kb, rel=1e-2)
    np.testing.assert_allclose(f[901:], -f[301:901], rtol=1e-9, atol=1e-12 * Fs)
    # loop area closed form: 2 (2 X Fs - int_0^L p), p = C1 xi + C2 xi^2 + C3 xi^3
    P = C1 * L**2 / 2 + C2 * L**3 / 3 + C3 * L**4 / 4
    area = _loop_area(u[300:], f[300:])
    assert area == pytest.approx(2 * (2 * X * Fs - P), rel=1e-4)


def test_prandtl_small_amplitude_is_linear() -> None:
    d = table2_mode_bay("F11")
    dc = 1.586 / 6.201e4
    _t, u = _cycle(0.5 * dc)
    r = d.respond(u[None, :])
    K1, K2, K3 = 1.471e5, -8.894e7, -1.008e12
    np.testing.assert_allclose(r.f[0], K1 * u + K2 * u**2 + K3 * u**3 + 6.201e4 * u, rtol=1e-10)
    assert abs(_loop_area(u, r.f[0])) < 1e-9 * np.abs(r.f).max() * dc


def test_cubic_hardening_softening() -> None:
    u = np.linspace(-0.1, 0.1, 21)
    hard = CubicSpring(1e3, 1e5, [0.0]).respond(u[None, :])
    soft = CubicSpring(1e3, -1e4, [0.0]).respond(u[None, :])
    np.testing.assert_allclose(hard.f[0], 1e3 * u + 1e5 * u**3)
    np.testing.assert_allclose(soft.Kt[0, 0], 1e3 - 3e4 * u**2)


def test_gap_zero_inside() -> None:
    d = GapSpring(1e5, 0.01, n_dir=2)
    u = np.linspace(-0.03, 0.03, 61)
    r = d.respond(np.vstack([u, u[::-1]]))
    inside = np.abs(u) < 0.01 * (1 - 1e-9)
    assert np.all(r.f[:, inside] == 0.0)
    np.testing.assert_allclose(
        r.f[0, ~inside], 1e5 * (u[~inside] - 0.01 * np.sign(u[~inside])), atol=1e-6
    )


def test_gap_one_sided_hertz_contact_closed_form() -> None:
    # a stop on the positive side only (g_neg beyond the path), Hertz contact n = 1.5:
    # f = k d (d / g)^0.5 for d = u - g > 0, i.e. k_h d^1.5 with k_h = k / sqrt(g)
    k, g = 2e6, 0.04
    d = GapSpring(k, g, n_dir=1, g_neg=10.0, n=1.5)
    u = np.linspace(-0.1, 0.1, 201)
    r = d.respond(u[None, :])
    over = np.maximum(u - g, 0.0)
    np.testing.assert_allclose(r.f[0], k / np.sqrt(g) * over**1.5, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(r.Kt[0, 0], 1.5 * k / np.sqrt(g) * over**0.5, rtol=1e-12,
                               atol=1e-9)
    assert np.all(r.f[0, u < 0] == 0.0)  # nothing on the open side
    # asymmetric clearances, linear contact: the closed form on each side
    a = GapSpring(1e5, 0.01, n_dir=1, g_neg=0.02).respond(u[None, :])
    want = 1e5 * (np.maximum(u - 0.01, 0.0) + np.minimum(u + 0.02, 0.0))
    np.testing.assert_allclose(a.f[0], want, atol=1e-6)
    with pytest.raises(ModelError, match="contact exponent in"):
        GapSpring(1.0, 0.01, n=0.5)


def test_friction_speed_dependent_limit_and_spring_beside() -> None:
    # sliding at constant speed V after breakaway: the limit Fk + (Fs - Fk) exp(-(V/v_s)^2)
    # plus the spring beside the slider kp u (Stribeck, closed form)
    Fs, Fk, kt, kp, v_s = 2e4, 1e4, 1e9, 3e5, 0.05
    for speed in (0.02, 0.05, 0.2):
        t = np.linspace(0.0, 1.0, 2001)
        u = speed * t
        r = CoulombFriction(Fs, Fk, kt, kp=(kp, 0.0), v_s=v_s).respond(
            u[None, :], np.full((1, t.size), speed))
        limit = Fk + (Fs - Fk) * np.exp(-((speed / v_s) ** 2))
        sliding = u > 2.0 * Fs / kt + 2.0 * speed * t[1]  # after the breakaway sample
        np.testing.assert_allclose(r.f[0, sliding], limit + kp * u[sliding], rtol=1e-12)
    # v_s = 0 and kp = 0: the classical law, unchanged
    base = CoulombFriction(Fs, Fk, kt).respond(u[None, :])
    assert np.allclose(base.f[0, u > 2.0 * Fs / kt], Fk)


def test_regularised_friction_closed_form() -> None:
    # f = kp u + mu(s) v / sqrt(s^2 + v_reg^2), s = |v| (bidirectional), at any (u, v)
    Fs, Fk, kp, v_s, v_reg = 2e4, 1e4, (3e5, 2e5), 0.05, 0.002
    rng = np.random.default_rng(4)
    u = rng.normal(0.0, 0.05, (2, 400))
    v = rng.normal(0.0, 0.05, (2, 400))
    d = CoulombFriction(Fs, Fk, 1.0, n_dir=2, kp=kp, v_s=v_s, v_reg=v_reg)
    r = d.respond(u, v)
    s = np.hypot(v[0], v[1])
    mu = Fk + (Fs - Fk) * np.exp(-((s / v_s) ** 2))
    want = np.array(kp)[:, None] * u + mu * v / np.sqrt(s**2 + v_reg**2)
    np.testing.assert_allclose(r.f, want, rtol=1e-12)
    # below v_reg it is a dashpot of Fs / v_reg, far above it friction at Fk
    slow = d.respond(np.zeros((2, 1)), np.array([[1e-6], [0.0]]))
    assert slow.f[0, 0] == pytest.approx(Fs / v_reg * 1e-6, rel=1e-3)
    fast = d.respond(np.zeros((2, 1)), np.array([[1.0], [0.0]]))
    assert fast.f[0, 0] == pytest.approx(Fk, rel=1e-4)


def test_friction_dashpot_per_direction() -> None:
    # f = kp u + mu(s) v / sqrt(s^2 + v_reg^2) + diag(cx, cy) v: the dashpot beside the
    # slider need not be isotropic (a bearing's nominal c differs between x and y)
    Fs, Fk, c, v_s, v_reg = 2e4, 1e4, (3e4, 1e4), 0.05, 0.002
    rng = np.random.default_rng(5)
    u = rng.normal(0.0, 0.05, (2, 300))
    v = rng.normal(0.0, 0.05, (2, 300))
    d = CoulombFriction(Fs, Fk, 1.0, c, n_dir=2, v_s=v_s, v_reg=v_reg)
    s = np.hypot(v[0], v[1])
    mu = Fk + (Fs - Fk) * np.exp(-((s / v_s) ** 2))
    want = mu * v / np.sqrt(s**2 + v_reg**2) + np.array(c)[:, None] * v
    np.testing.assert_allclose(d.respond(u, v).f, want, rtol=1e-12)
    np.testing.assert_array_equal(d.reference_damping(), np.diag(c))
    # one value: the same dashpot in both directions (as before)
    iso = CoulombFriction(Fs, Fk, 1.0, 2e4, n_dir=2, v_s=v_s, v_reg=v_reg)
    np.testing.assert_allclose(iso.respond(u, v).f,
                               want + (2e4 - np.array(c))[:, None] * v, rtol=1e-12)
    # the stick-slip form too: while stuck at rest the force is the dashpot's alone
    stuck = CoulombFriction(Fs, Fk, 1e9, c, n_dir=2).respond(np.zeros((2, 1)),
                                                              np.array([[0.01], [0.02]]))
    np.testing.assert_allclose(stuck.f[:, 0], [3e4 * 0.01, 1e4 * 0.02], rtol=1e-12)


@pytest.mark.parametrize("cls", [BilinearElastic, BilinearHysteretic])
def test_bilinear_anisotropic_bearing_scales_y(cls) -> None:
    # the same drift history in x and y: y's force is y_scale times x's (same yield drift)
    u = 0.05 * np.sin(np.linspace(0.0, 4.0 * np.pi, 400))
    r = cls(2e6, 0.5e6, 0.01, [0.0, 0.0], y_scale=1.3).respond(np.vstack([u, u]))
    np.testing.assert_allclose(r.f[1], 1.3 * r.f[0], rtol=1e-12)
    np.testing.assert_allclose(r.Kt[1, 1], 1.3 * r.Kt[0, 0], rtol=1e-12)
    iso = cls(2e6, 0.5e6, 0.01, [0.0]).respond(u[None, :])
    np.testing.assert_array_equal(iso.f[0], r.f[0])


def test_errors() -> None:
    with pytest.raises(ModelError, match="expected one of"):
        table10_rubber_bearing("RB3")
    with pytest.raises(ModelError, match="expected one of"):
        table10_esb("ESB3", W=1.0)
    with pytest.raises(ModelError, match="expected one of"):
        table6_updated("XX")
    with pytest.raises(ModelError, match="expected one of"):
        table2_mode_bay("F99")
    with pytest.raises(ModelError, match="kb <= k"):
        BilinearElastic(1.0, 2.0, 0.1, [0.0])
    with pytest.raises(ModelError, match="beta \\+ gamma > 0"):
        BoucWenSDP(1.0, -1.0, 0.0, np.eye(2), 0.1, [0.0, 0.0])
    with pytest.raises(ModelError, match="symmetric"):
        BoucWenSDP(1.0, 1.0, 1.0, np.array([[1.0, 2.0], [0.0, 1.0]]), 0.1, [0.0, 0.0])
    with pytest.raises(ModelError, match="alpha"):
        BoucWenSDP(1.0, 1.0, 1.0, np.eye(2), 1.5, [0.0, 0.0])
    with pytest.raises(ModelError, match="W, S"):
        table10_esb("ESB1", W=-1.0)
    with pytest.raises(ModelError, match="Fk <= Fs"):
        CoulombFriction(1.0, 2.0, 1.0)
    with pytest.raises(ModelError, match="Kb > 0"):
        PrandtlJoint(0, 0, 0, 0, 1.0, 0.0)
    with pytest.raises(ModelError, match="k1 >= 0"):
        CubicSpring(-1.0, 0.0, [0.0])
    with pytest.raises(ModelError, match="non-negative"):
        GapSpring(-1.0, 0.0)
    with pytest.raises(ModelError, match="equal lengths"):
        LinearDevice([1.0, 2.0], [1.0])
    with pytest.raises(ModelError, match="non-negative"):
        LinearDevice([-1.0], [1.0])
    with pytest.raises(ShapeError, match="n_dir"):
        GapSpring(1.0, 0.0, n_dir=3)
    d = LinearDevice([1.0], [0.0])
    with pytest.raises(ShapeError, match="expected shape"):
        d.respond(np.zeros((2, 5)))
    with pytest.raises(SignalError, match="index 3"):
        d.respond(np.array([[0.0, 0, 0, np.nan]]))
