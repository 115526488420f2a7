"""Eigen-solver: sparse shift-invert vs dense, semi-definite mass, diagnostics, errors."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from modal_twin.errors import ConvergenceError, ModelError, OptionError, ShapeError
from modal_twin.models.fe import FEModel, count_eigenvalues_below, default_shift, solve_modes
from modal_twin.models.fe import eigen as eigen_mod


def _chain(n, k=1e6, m=2.0, massless_every=0):
    """Free-free spring chain (one rigid mode): exact eigenvalues known."""
    K = sp.diags([-k * np.ones(n - 1), k * np.r_[1, 2 * np.ones(n - 2), 1], -k * np.ones(n - 1)],
                 [-1, 0, 1], format="csr")
    md = m * np.ones(n)
    if massless_every:
        md[1::massless_every] = 0.0
    return K, sp.diags(md, format="csr")


def test_chain_frequencies_sparse_and_dense_agree_with_closed_form():
    n, k, m = 600, 1e6, 2.0
    K, M = _chain(n, k, m)
    j = np.arange(8)
    exact = 2 * np.sqrt(k / m) * np.sin(j * np.pi / (2 * n))  # free-free chain
    sp_sol = solve_modes(K, M, 8)
    assert sp_sol.method == "sparse"
    de_sol = solve_modes(K, M, 8, method="dense")
    assert de_sol.method == "dense"
    assert np.allclose(sp_sol.omega[1:], exact[1:], rtol=1e-9, atol=0.0)
    assert np.allclose(de_sol.omega[1:], exact[1:], rtol=1e-9, atol=0.0)
    assert sp_sol.omega[0] < 1e-5 * exact[1]
    assert sp_sol.max_rel_residual < 1e-12
    assert sp_sol.max_orthogonality_error < 1e-10
    assert np.allclose(np.abs(sp_sol.Phi[:, 3]), np.abs(de_sol.Phi[:, 3]), atol=1e-8)
    assert np.allclose(sp_sol.f_hz, sp_sol.omega / (2 * np.pi))


def test_semi_definite_mass_gives_finite_modes_only():
    K, M = _chain(500, massless_every=2)
    sol = solve_modes(K, M, 5)
    den = solve_modes(K, M, 5, method="dense")
    assert np.allclose(sol.omega[1:], den.omega[1:], rtol=1e-9)
    with pytest.raises(ModelError, match="n_modes: expected at most the number of DOFs with mass"):
        solve_modes(K[:6, :6], M[:6, :6], 5, method="dense")


def test_default_shift_scales_with_the_model():
    K, M = _chain(10, k=1e9, m=1.0)
    assert default_shift(K, M) == pytest.approx(-1e-6 * 2e9)
    assert default_shift(sp.csr_array((3, 3)), sp.identity(3)) == -1.0


_NO_STIFFNESS_NOR_MASS = r"K - sigma M .* diagonal entry > 0\), got 0 at DOF 1"


def test_eigen_bad_input_is_refused(monkeypatch):
    K, M = _chain(20)
    with pytest.raises(ShapeError, match=r"M: expected \(20, 20\), got \(19, 19\)"):
        solve_modes(K, M[:19, :19], 2)
    with pytest.raises(ShapeError, match=r"K: expected \(n, n\), got \(20, 19\)"):
        solve_modes(K[:, :19], M, 2)
    with pytest.raises(OptionError, match=r"n_modes: expected an int in \[1, 20\], got 0"):
        solve_modes(K, M, 0)
    with pytest.raises(OptionError, match="method: expected one of"):
        solve_modes(K, M, 2, method="lanczos")  # type: ignore[arg-type]
    with pytest.raises(OptionError, match="n_modes: expected < 19 for the sparse solver"):
        solve_modes(K, M, 19, method="sparse")
    with pytest.raises(ModelError, match="M: expected some positive mass"):
        solve_modes(K, 0 * M, 2)
    with pytest.raises(ModelError, match="M: expected a diagonal >= 0, got min -1"):
        solve_modes(K, sp.diags(np.r_[-1.0, np.ones(19)]), 2)
    with pytest.raises(ModelError, match=r"sigma: expected a negative shift, got 0\.0"):
        solve_modes(K, M, 2, sigma=0.0)
    # DOF 1 has neither stiffness nor mass: refused before any factorisation
    idle_k = sp.diags([1.0, 0.0, 1.0] * 10, format="csr")
    idle_m = sp.diags([1.0, 0.0, 1.0] * 10, format="csr")
    with pytest.raises(ModelError, match=_NO_STIFFNESS_NOR_MASS):
        solve_modes(idle_k, idle_m, 2, method="dense")
    with pytest.raises(ModelError, match=_NO_STIFFNESS_NOR_MASS):
        solve_modes(idle_k, idle_m, 2, method="sparse")

    def no_convergence(*args, **kwargs):
        msg = "no"
        raise spla.ArpackNoConvergence(msg, np.zeros(1), np.zeros((20, 1)))

    monkeypatch.setattr(eigen_mod.spla, "eigsh", no_convergence)
    with pytest.raises(ConvergenceError, match="eigsh: 1 of 2 modes converged"):
        solve_modes(K, M, 2, method="sparse")


def test_rotated_structure_has_the_same_frequencies():
    rng = np.random.default_rng(3)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    pts = np.array([(0, 0, 0), (2, 0, 0), (2, 1.5, 0), (2, 1.5, 1.0)], dtype=float)
    sec = {"E": 2e11, "G": 8e10, "A": 1e-3, "Iy": 1e-6, "Iz": 3e-6, "J": 1e-6, "rho": 7800}
    freqs = []
    for rot in (np.eye(3), q):
        fem = FEModel()
        for i, p in enumerate(pts @ rot.T):
            fem.add_node(i, p)
        for a, b in [(0, 1), (1, 2), (2, 3)]:
            z_ref = rot @ (np.array([0.0, 0.0, 1.0]) if a < 2 else np.array([1.0, 0.0, 0.0]))
            fem.add_member(a, b, 3, **sec, orientation=z_ref)
        fem.fix(0)
        asm = fem.assemble()
        freqs.append(solve_modes(asm.K, asm.M, 6).f_hz)
    assert np.allclose(freqs[0], freqs[1], rtol=1e-10, atol=0.0)


def test_sturm_count_matches_the_closed_form_spectrum():
    """Negative pivots of K - lam M = eigenvalues below lam (fixed-fixed chain, closed form)."""
    n, k, m = 60, 1e4, 0.5
    K = sp.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1]) * k
    M = sp.identity(n) * m
    lam = 4 * k / m * np.sin(np.arange(1, n + 1) * np.pi / (2 * (n + 1))) ** 2
    for j in (0, 1, 7, 31, 59):
        bound = 0.5 * (lam[j] + lam[j + 1]) if j < n - 1 else 2 * lam[-1]
        assert count_eigenvalues_below(K, M, bound) == j + 1
    assert count_eigenvalues_below(K, M, 0.5 * lam[0]) == 0
    Ms = sp.diags(np.r_[np.full(n - 1, m), 0.0])  # a massless DOF: an infinite eigenvalue
    assert count_eigenvalues_below(K, Ms, 1e12) == n - 1
    bad = sp.csr_array(K).tolil()
    bad[3, 3] = np.nan
    assert count_eigenvalues_below(bad, M, 1.0) is None
