"""Mode matching, objectives, eigen-derivatives, uncertainty and bad input (updating)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modal_twin.errors import ModelError, OptionError, ShapeError
from modal_twin.models.fe import FEModel, solve_modes
from modal_twin.updating.matching import match_modes
from modal_twin.updating.objectives import (
    close_match,
    frequencies_converged,
    frequency_figure_of_merit,
    frequency_mac_damping_cost,
    relaxed_cost,
    weighted_frequency_mac_cost,
)
from modal_twin.updating.problem import PENALTY, ModeTargets, UpdatingProblem
from modal_twin.updating.sensitivity import eigen_derivatives
from modal_twin.updating.uncertainty import parameter_covariance


def chain(n=8, k=None, m=None):
    k = np.linspace(2.0, 1.0, n) * 1e6 if k is None else k
    m = np.full(n, 100.0) if m is None else m
    K = np.zeros((n, n))
    for i in range(n):
        K[i, i] += k[i]
        if i + 1 < n:
            K[i, i] += k[i + 1]
            K[i, i + 1] = K[i + 1, i] = -k[i + 1]
    dK = []
    for i in range(n):
        D = np.zeros((n, n))
        D[i, i] = 1.0
        if i > 0:
            D[i - 1, i - 1] += 1.0
            D[i - 1, i] = D[i, i - 1] = -1.0
        dK.append(D)
    return K, np.diag(m), dK


# ---------------------------------------------------------------- matching
def test_match_assignment_equals_exhaustive_and_handles_swap():
    # (d) mode swap: FEM modes 1 and 2 have swapped order against the test (dislocation)
    rng = np.random.default_rng(0)
    phi = np.linalg.qr(rng.standard_normal((10, 5)))[0]
    f_id = np.array([2.0, 3.0, 3.1, 5.0])
    f_fem = np.array([2.02, 3.08, 3.02, 4.9, 6.0])
    phi_fem = phi[:, [0, 2, 1, 3, 4]]  # FEM mode 1 has the shape of test mode 2
    p = match_modes(f_id, phi[:, :4], f_fem, phi_fem)
    assert p.fem_index.tolist() == [0, 2, 1, 3]
    q = match_modes(f_id, phi[:, :4], f_fem, phi_fem, method="exhaustive")
    g = match_modes(f_id, phi[:, :4], f_fem, phi_fem, method="greedy")
    assert q.fem_index.tolist() == p.fem_index.tolist() == g.fem_index.tolist()
    assert np.allclose(p.mac, 1.0)
    assert p.unused_fem == (4,)
    # frequency order alone would pair them wrongly: MAC 0 -> outside the window
    assert np.allclose(p.df_rel * 100, [1.0, 2 / 3, -2 / 3.1, -2.0])


def test_match_spurious_and_unmatched():
    phi = np.eye(4)
    # identified mode 1 is spurious (shape matches nothing)
    f_id = [1.0, 1.5, 2.0]
    shapes = np.column_stack([phi[:, 0], np.ones(4), phi[:, 1]])
    p = match_modes(f_id, shapes, [1.01, 2.02], phi[:, :2])
    assert p.fem_index.tolist() == [0, -1, 1]
    assert p.unmatched_id == (1,)
    assert math.isinf(p.total_cost)
    assert math.isinf(frequency_mac_damping_cost(p))


def test_match_monotonic_greedy_and_bad_input():
    phi = np.eye(3)
    p = match_modes([1.0, 2.0], phi[:, :2], [1.0, 2.0, 2.05], phi, method="greedy", monotonic=True)
    assert p.fem_index.tolist() == [0, 1]
    with pytest.raises(OptionError, match="method: expected one of"):
        match_modes([1.0], phi[:, :1], [1.0], phi[:, :1], method="best")  # type: ignore[arg-type]
    with pytest.raises(OptionError, match="r_f, r_mac, r_zeta: expected > 0"):
        match_modes([1.0], phi[:, :1], [1.0], phi[:, :1], r_f=0.0)
    with pytest.raises(ShapeError, match="at least one identified mode"):
        match_modes([], np.zeros((3, 0)), [1.0], phi[:, :1])
    with pytest.raises(ShapeError, match="f_id: expected finite positive"):
        match_modes([-1.0], phi[:, :1], [1.0], phi[:, :1])
    with pytest.raises(ShapeError, match="columns"):
        match_modes([1.0, 2.0], phi[:, :1], [1.0], phi[:, :1])
    with pytest.raises(OptionError, match="permutations"):
        match_modes(np.arange(1, 9.0), np.eye(9)[:, :8], np.arange(1, 10.0), np.eye(9),
                    method="exhaustive", max_permutations=10)


# ---------------------------------------------------------------- objectives
def test_objectives_known_answers():
    phi = np.eye(3)
    p = match_modes([1.0, 2.0], phi[:, :2], [1.02, 1.96], phi[:, :2])
    assert frequency_mac_damping_cost(p) == pytest.approx(0.04)  # 2 % + 2 %, MAC 1
    assert weighted_frequency_mac_cost(p) == pytest.approx(2.0)  # 100 * mean |df| = 2 %
    assert frequency_figure_of_merit([1.02, 1.96], [1.0, 2.0]) == pytest.approx(8e-4)
    assert frequencies_converged([1.02, 1.96], [1.0, 2.0], eps=0.03)
    assert not frequencies_converged([1.02, 1.96], [1.0, 2.0], eps=0.02)
    assert close_match(p)
    assert relaxed_cost(p) == 0.0
    far = match_modes([1.0], phi[:, :1], [1.08], phi[:, :1])
    assert not close_match(far)
    assert relaxed_cost(far) == pytest.approx(0.03)
    z = match_modes([1.0], phi[:, :1], [1.0], phi[:, :1], zeta_id=[0.05], zeta_fem=[0.06],
                    w_zeta=1.0, r_zeta=1.0)
    assert frequency_mac_damping_cost(z, w_zeta=1.0) == pytest.approx(0.2)
    with pytest.raises(OptionError, match="w_zeta: damping weights"):
        frequency_mac_damping_cost(p, w_zeta=1.0)
    with pytest.raises(OptionError, match="gamma: expected at least one positive"):
        weighted_frequency_mac_cost(p, gamma=0.0)
    with pytest.raises(OptionError, match="w_mac: expected a scalar"):
        frequency_mac_damping_cost(p, w_mac=[1.0, 2.0, 3.0])
    with pytest.raises(ShapeError, match="f_exp: expected"):
        frequency_figure_of_merit([1.0], [0.0])


# ---------------------------------------------------------------- sensitivities
@pytest.mark.parametrize("sparse", [False, True])
def test_nelson_matches_finite_differences(sparse):
    import scipy.sparse as sp

    K, M, dK = chain()
    sol = solve_modes(K, M, 8, method="dense")
    modes = [0, 2, 4]
    KK, MM = (sp.csr_array(K), sp.csr_array(M)) if sparse else (K, M)
    dd = [sp.csr_array(D) for D in dK] if sparse else dK
    dM = [None] * 7 + [np.diag(np.r_[np.zeros(7), 1.0])]
    d = eigen_derivatives(KK, MM, sol.eigenvalues[modes], sol.Phi[:, modes], dd, dM)
    h = 1.0
    for i in (0, 3, 7):
        hh = 1e-2 if dM[i] is not None else h
        Kp, Km = K + hh * dK[i], K - hh * dK[i]
        Mp, Mm = (M + hh * dM[i], M - hh * dM[i]) if dM[i] is not None else (M, M)
        sp_, sm = solve_modes(Kp, Mp, 8, method="dense"), solve_modes(Km, Mm, 8, method="dense")
        fd_lam = (sp_.eigenvalues - sm.eigenvalues)[modes] / (2 * hh)
        assert np.allclose(d.dlam[:, i], fd_lam, rtol=1e-5, atol=1e-9 * abs(fd_lam).max())
        fd_phi = (sp_.Phi - sm.Phi)[:, modes] / (2 * hh)
        assert np.abs(d.dPhi[:, :, i] - fd_phi).max() <= 1e-4 * np.abs(fd_phi).max() + 1e-12
    # Fox-Kapoor with all modes equals Nelson
    f = eigen_derivatives(K, M, sol.eigenvalues, sol.Phi, dK, method="fox")
    n = eigen_derivatives(K, M, sol.eigenvalues, sol.Phi, dK, method="nelson")
    assert np.allclose(f.dPhi, n.dPhi, atol=1e-9 * np.abs(n.dPhi).max())
    with pytest.raises(OptionError, match="method: expected one of"):
        eigen_derivatives(K, M, sol.eigenvalues, sol.Phi, dK, method="x")  # type: ignore[arg-type]
    with pytest.raises(ShapeError, match="Phi: expected"):
        eigen_derivatives(K, M, sol.eigenvalues, sol.Phi[:, :2], dK)
    with pytest.raises(ShapeError, match="dM: expected"):
        eigen_derivatives(K, M, sol.eigenvalues, sol.Phi, dK, dM=[None])


def test_nelson_repeated_mode_raises():
    K, M = np.eye(2), np.eye(2)
    with pytest.raises(ModelError, match="Nelson"):
        eigen_derivatives(K, M, np.array([1.0]), np.array([[1.0], [0.0]]), [np.eye(2)])


# ---------------------------------------------------------------- problem and bad input
def chain_problem(truth_scale=1.1, **kw):
    K, M, dK = chain()
    k0 = np.linspace(2.0, 1.0, 8) * 1e6
    Kt, _, _ = chain(k=k0 * truth_scale)
    sol = solve_modes(Kt, M, 4, method="dense")
    t = ModeTargets.create(sol.f_hz, sol.Phi, std_f_hz=1e-3 * sol.f_hz)
    return UpdatingProblem(K, M, dK, None, k0, [f"k{i}" for i in range(8)], 0.5 * k0,
                           2.0 * k0, np.arange(8), t, **kw)


def test_problem_jacobian_matches_finite_differences():
    pr = chain_problem()
    th = pr.theta0 * 1.03
    J = pr.jacobian(th)
    for i in (0, 5):
        e = np.zeros(8)
        e[i] = 1e-3 * th[i]
        fd = (pr.residual(th + e) - pr.residual(th - e)) / (2 * e[i])
        assert np.abs(J[:, i] - fd).max() <= 1e-4 * np.abs(J).max()


def test_problem_bad_input():
    pr = chain_problem()
    K, M, dK = pr.K0, pr.M0, pr.dK
    t = pr.targets
    with pytest.raises(OptionError, match="expected lower < upper"):
        UpdatingProblem(K, M, dK, None, pr.theta0, pr.names, pr.upper, pr.lower, np.arange(8), t)
    lo = pr.lower.copy()
    lo[2] = np.nan
    with pytest.raises(OptionError, match="expected finite"):
        UpdatingProblem(K, M, dK, None, pr.theta0, pr.names, lo, pr.upper, np.arange(8), t)
    with pytest.raises(ShapeError, match="S: expected DOF indices"):
        UpdatingProblem(K, M, dK, None, pr.theta0, pr.names, pr.lower, pr.upper,
                        np.arange(1, 9), t)
    with pytest.raises(ShapeError, match="at least one identified mode"):
        ModeTargets.create([], np.zeros((8, 0)))
    with pytest.raises(OptionError, match="at least one parameter"):
        UpdatingProblem(K, M, [], None, [], [], [], [], np.arange(8), t)
    # a non-positive-definite trial point: penalty, not a crash
    bad = pr.theta0.copy()
    bad[0] = -5e6
    assert pr.cost(bad) == PENALTY * t.n_modes
    assert np.all(pr.residual(bad) == PENALTY)
    assert np.all(pr.jacobian(bad) == 0.0)
    with pytest.raises(ModelError, match="positive definite"):
        pr.modes(bad)


def test_from_parametric_bounds_errors():
    m = FEModel()
    m.add_node(0, [0, 0, 0])
    m.add_node(1, [1, 0, 0])
    m.add_spring(0, k={"ux": 1e6}, k_params={"ux": "k0"})
    m.add_spring(0, 1, k={"ux": 2e6}, k_params={"ux": "k1"})
    for n in (0, 1):
        m.add_mass(n, 10.0)
        m.fix(n, ["uy", "uz", "rx", "ry", "rz"])
    asm = m.assemble()
    sol = solve_modes(asm.K, asm.M, 2)
    t = ModeTargets.create(sol.f_hz, sol.Phi)
    with pytest.raises(OptionError, match="bounds: parameter 'k1' has none"):
        UpdatingProblem.from_parametric(asm.parametric, np.arange(2), t, names=["k0", "k1"],
                                        bounds={"k0": (1e5, 1e7)})
    pr = UpdatingProblem.from_parametric(asm.parametric, np.arange(2), t, names=["k0", "k1"],
                                         rel_bounds=0.5)
    assert pr.lower.tolist() == [5e5, 1e6]


# ---------------------------------------------------------------- uncertainty
def test_covariance_known_answer_and_undetermined():
    J = np.array([[1.0, 0.0], [0.0, 0.0]])
    u = parameter_covariance(J, np.array([1e-3, 1e-3]), names=["a", "b"], lower=np.zeros(2),
                             upper=np.ones(2))
    assert u.std[0] == pytest.approx(1e-3, rel=1e-4)
    assert u.std[1] == pytest.approx(1 / np.sqrt(12))  # the prior: no information
    assert u.determined.tolist() == [True, False]
    with pytest.raises(ShapeError, match="J, sigma, names"):
        parameter_covariance(J, np.ones(3), names=["a", "b"], lower=np.zeros(2),
                             upper=np.ones(2))
