"""Craig-Bampton reduction: exact coupling, rigid-body mass, frequencies vs the full model."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from modal_twin.errors import ModelError, OptionError, ShapeError
from modal_twin.models import craig_bampton as cb_mod
from modal_twin.models.craig_bampton import cb_check, craig_bampton
from modal_twin.models.fe import FEModel, solve_modes

SEC = {"E": 70e9, "G": 26e9, "A": 4e-3, "Iy": 2e-5, "Iz": 8e-5, "J": 1e-5, "rho": 2700.0}


@pytest.fixture(scope="module")
def ladder():
    """Free-free ladder frame 10 m x 2 m (a crude carbody) with four support nodes."""
    fem = FEModel()
    xs = [0.0, 2.5, 5.0, 7.5, 10.0]
    for j, x in enumerate(xs):
        fem.add_node(f"L{j}", (x, -1.0, 0.0))
        fem.add_node(f"R{j}", (x, 1.0, 0.0))
        fem.add_member(f"L{j}", f"R{j}", 4, **SEC)
    for j in range(len(xs) - 1):
        for side in "LR":
            fem.add_member(f"{side}{j}", f"{side}{j + 1}", 5, **SEC)
    fem.add_mass("L2", 300.0, inertia=(10.0, 20.0, 30.0))
    asm = fem.assemble()
    bnodes = ["L1", "R1", "L3", "R3"]
    bdofs = np.array([asm.dof_index(n, d) for n in bnodes
                      for d in ("ux", "uy", "uz", "rx", "ry", "rz")])
    return asm, bdofs


def test_cb_keeps_rigid_body_mass_zero_coupling_and_low_frequencies(ladder):
    asm, bdofs = ladder
    f_interest = 60.0
    # Cutoff 4x the band of interest; measured: 2x gives 1.1 %, 3x 0.7 %, 4x 0.24 %.
    cb = craig_bampton(asm.M, asm.K, bdofs, f_cut_hz=4.0 * f_interest)
    nb = cb.n_boundary
    assert nb == 24
    assert cb.n_modes > 0
    assert cb.f_fixed_hz.max() < 4.0 * f_interest
    assert not np.any(cb.Kr[:nb, nb:])
    assert not np.any(cb.Kr[nb:, :nb])
    assert np.allclose(np.diag(cb.Kr[nb:, nb:]), (2 * np.pi * cb.f_fixed_hz) ** 2, rtol=1e-12)
    assert np.allclose(cb.Mr[nb:, nb:], np.eye(cb.n_modes), rtol=0, atol=1e-10)
    chk = cb_check(cb, asm.M, asm.K, rb=asm.rigid_body_modes((5.0, 0.0, 0.0)),
                   f_compare_hz=f_interest)
    assert chk.rb_mass_rel_err < 1e-10
    assert chk.rb_mass_full[0, 0] == pytest.approx(asm.total_mass(), rel=1e-12)
    assert chk.rb_stiffness_rel < 1e-12
    assert chk.kbq_rel < 1e-10
    assert chk.kr_sym_rel == 0.0
    assert chk.mr_sym_rel == 0.0
    assert np.sum(np.isnan(chk.f_rel_err)) == 6  # six rigid-body modes
    assert chk.f_full_hz.size >= 9  # at least three flexible modes compared
    assert chk.max_f_rel_err < 5e-3
    assert np.all(chk.f_reduced_hz[6:] >= chk.f_full_hz[6:] * (1 - 1e-10))  # Rayleigh-Ritz


def test_cb_with_all_modes_is_exact_and_guyan_is_statically_exact():
    fem = FEModel()
    fem.add_node(0, (0, 0, 0))
    fem.add_node(1, (3.0, 0, 0))
    chain = fem.add_member(0, 1, 8, **SEC)
    fem.fix(0)
    asm = fem.assemble()
    b = np.array([asm.dof_index(1, d) for d in ("uy", "uz")] + [asm.dof_index(chain[4], "uy")])
    n_i = asm.n_dof - b.size
    full = craig_bampton(asm.M, asm.K, b, n_modes=n_i)
    f_full = solve_modes(asm.K, asm.M, 10).f_hz
    chk = cb_check(full, asm.M, asm.K, f_compare_hz=1.01 * f_full[-1])
    assert chk.f_full_hz.size == 10
    assert chk.max_f_rel_err < 1e-9
    guyan = craig_bampton(asm.M, asm.K, b, n_modes=0)
    f = np.zeros(asm.n_dof)
    f[b] = [1e3, -2e3, 5e2]
    u = spla.spsolve(sp.csc_array(asm.K), f)
    ub = np.linalg.solve(guyan.Kr, f[b])
    assert np.allclose(guyan.recover(ub), u, rtol=0, atol=1e-10 * np.abs(u).max())
    assert cb_check(guyan, asm.M, asm.K).f_full_hz.size == 0
    c = guyan.project(sp.identity(asm.n_dof, format="csr"))
    assert np.allclose(c, guyan.T.T @ guyan.T)


def test_cb_modes_by_count_and_cutoff_limit():
    rng = np.random.default_rng(7)
    n = 30
    K = sp.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1]) * 1e4
    M = sp.diags(rng.uniform(0.5, 1.5, n))
    cb = craig_bampton(M, K, [0, n - 1], n_modes=5)
    assert cb.n_modes == 5
    assert cb.f_cut_hz is None
    cb2 = craig_bampton(M, K, [0, n - 1], n_modes=3, f_cut_hz=1e6)
    assert cb2.n_modes == 3
    assert np.allclose(cb2.f_fixed_hz, cb.f_fixed_hz[:3], rtol=1e-12)
    dense = craig_bampton(M.toarray(), K.toarray(), np.array([0, n - 1]), f_cut_hz=10.0)
    assert np.all(dense.f_fixed_hz < 10.0)
    assert dense.n_modes >= 1
    chk = cb_check(cb, M, K)
    assert chk.f_compare_hz == cb.f_fixed_hz[-1]
    assert np.isnan(chk.rb_mass_rel_err)


def test_cb_sparse_interior_uses_shift_invert(ladder):
    asm, bdofs = ladder
    cb = craig_bampton(asm.M, asm.K, bdofs, n_modes=6, dense_max_dof=10)
    ref = craig_bampton(asm.M, asm.K, bdofs, n_modes=6)
    assert np.allclose(cb.f_fixed_hz, ref.f_fixed_hz, rtol=1e-9)


def test_cb_bad_input_is_refused():
    K = np.diag([2.0, 2.0, 2.0])
    M = np.eye(3)
    with pytest.raises(ShapeError, match=r"M: expected \(3, 3\), got \(2, 2\)"):
        craig_bampton(np.eye(2), K, [0], n_modes=1)
    with pytest.raises(ShapeError, match=r"K: expected \(n, n\), got \(3, 2\)"):
        craig_bampton(M, np.ones((3, 2)), [0], n_modes=1)
    with pytest.raises(ShapeError, match="boundary_dofs: expected unique indices"):
        craig_bampton(M, K, [0, 0], n_modes=1)
    with pytest.raises(ShapeError, match=r"boundary_dofs: expected indices in \[0, 3\)"):
        craig_bampton(M, K, [5], n_modes=1)
    with pytest.raises(ShapeError, match="boundary_dofs: expected a non-empty 1-D int array"):
        craig_bampton(M, K, [], n_modes=1)
    with pytest.raises(OptionError, match="expected at least one of them"):
        craig_bampton(M, K, [0])
    with pytest.raises(OptionError, match=r"n_modes: expected an int in \[0, 2\]"):
        craig_bampton(M, K, [0], n_modes=5)
    with pytest.raises(OptionError, match="f_cut_hz: expected a finite value > 0"):
        craig_bampton(M, K, [0], f_cut_hz=-3.0)
    free = sp.csr_array(np.array([[1.0, -1.0, 0.0], [-1.0, 1.0, 0.0], [0.0, 0.0, 0.0]]))
    with pytest.raises(ModelError, match="K_ii: expected nonsingular"):
        craig_bampton(M, free, [0], n_modes=1)
    bad = K.copy()
    bad[0, 1] = bad[1, 0] = np.nan
    with pytest.raises(ModelError, match="the constraint modes are not finite"):
        craig_bampton(M, bad, [0], n_modes=1)
    cb = craig_bampton(M, K, [0], n_modes=1)
    with pytest.raises(ShapeError, match=r"M, K: expected \(3, 3\) like cb.T"):
        cb_check(cb, np.eye(2), K)
    with pytest.raises(ShapeError, match=r"rb: expected \(3, 6\), got \(3, 5\)"):
        cb_check(cb, M, K, rb=np.ones((3, 5)))


def _fixed_free_chain(n: int, k: float = 1e6, m: float = 2.0):
    """Spring-mass chain of n + 1 equal masses, DOF 0 the boundary, the last end free."""
    K = sp.diags([-np.ones(n), np.r_[2.0 * np.ones(n), 1.0], -np.ones(n)], [-1, 0, 1]) * k
    M = sp.identity(n + 1, format="csr") * m
    j = np.arange(1, n + 1)
    # DOF 0 fixed: lambda_j = 4 k / m sin^2((2j - 1) pi / (2 (2n + 1)))
    lam = 4.0 * k / m * np.sin((2 * j - 1) * np.pi / (2 * (2 * n + 1))) ** 2
    return sp.csr_array(K), sp.csr_array(M), np.sqrt(lam) / (2 * np.pi)


@pytest.mark.parametrize("n_below", [1, 13, 50])
def test_cb_cutoff_finds_every_mode_below_it_in_one_search(n_below, monkeypatch):
    """Every fixed-interface mode below the cut-off, none above, closed form (fixed-free chain).

    13 and 50 modes sit between the old search's steps (12, 24, 48, 96): the Sturm count
    asks for them in one shift-invert run on the sparse path.
    """
    K, M, f_exact = _fixed_free_chain(400)
    f_cut = 0.5 * (f_exact[n_below - 1] + f_exact[n_below])
    asked = []
    real = cb_mod.lowest_eigenpairs

    def counting(K, M, n_modes, **kw):
        asked.append(n_modes)
        return real(K, M, n_modes, **kw)

    monkeypatch.setattr(cb_mod, "lowest_eigenpairs", counting)
    cb = craig_bampton(M, K, [0], f_cut_hz=f_cut, dense_max_dof=10)
    assert asked == [n_below + 1]  # one run: the count below the cut-off and one above
    assert cb.n_modes == n_below
    assert np.allclose(cb.f_fixed_hz, f_exact[:n_below], rtol=1e-10, atol=0)
    by_count = craig_bampton(M, K, [0], n_modes=n_below + 5, dense_max_dof=10)
    assert np.allclose(cb.f_fixed_hz, by_count.f_fixed_hz[:n_below], rtol=1e-10, atol=0)
    assert np.allclose(np.abs(cb.T), np.abs(by_count.T[:, :1 + n_below]), rtol=0, atol=1e-8)
    dense = craig_bampton(M.toarray(), K.toarray(), [0], f_cut_hz=f_cut, dense_max_dof=1000)
    assert np.allclose(dense.f_fixed_hz, f_exact[:n_below], rtol=1e-10, atol=0)



def test_cb_floating_interior_with_positive_diagonal_is_refused():
    """Two interior masses tied to each other only: K_ii singular with a positive diagonal."""
    K = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, -1.0], [0.0, -1.0, 1.0]])
    with pytest.raises(ModelError, match="K_ii: expected nonsingular"):
        craig_bampton(np.eye(3), K, [0], f_cut_hz=10.0)
