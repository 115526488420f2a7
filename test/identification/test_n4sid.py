from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.signal as sig
import scipy.stats

from modal_twin.errors import OptionError, ShapeError, SignalError
from modal_twin.identification.metrics import mac
from modal_twin.identification.n4sid import n4sid
from modal_twin.identification.stabilization import select_modes, stabilization_diagram


def _chain(n: int = 5, zeta: float = 0.02) -> tuple:
    """Fixed-free spring-mass chain with modal damping; true f (Hz), zeta and shapes."""
    k = np.linspace(1.0, 0.6, n) * 1e3
    K = np.diag(k + np.r_[k[1:], 0.0]) - np.diag(k[1:], 1) - np.diag(k[1:], -1)
    M = np.eye(n)
    w2, Phi = sla.eigh(K, M)
    w = np.sqrt(w2)
    C = M @ Phi @ np.diag(2 * zeta * w) @ Phi.T @ M
    return M, C, K, w / (2 * np.pi), np.full(n, zeta), Phi


def _simulate(M, C, K, in_dofs, fs, n, rng, snr_db=20.0) -> tuple:
    """Exact-ZOH simulation, acceleration outputs at every DOF with white output noise."""
    nd = M.shape[0]
    Mi = np.linalg.inv(M)
    A = np.block([[np.zeros((nd, nd)), np.eye(nd)], [-Mi @ K, -Mi @ C]])
    Bf = np.eye(nd)[:, in_dofs]
    B = np.vstack([np.zeros_like(Bf), Mi @ Bf])
    sysd = sig.cont2discrete((A, B, A[nd:], (Mi @ Bf)), 1 / fs)
    u = rng.standard_normal((len(in_dofs), n))
    _, y, _ = sig.dlsim(sig.dlti(*sysd[:4], dt=1 / fs), u.T)
    y = y.T
    noise = rng.standard_normal(y.shape) * y.std(axis=1, keepdims=True) * 10 ** (-snr_db / 20)
    return u, y + noise, y, sysd[0]


@pytest.fixture(scope="module")
def chain_data() -> tuple:
    M, C, K, f, z, Phi = _chain()
    fs = 4.0 * f.max()
    u, y, y0, Ad = _simulate(M, C, K, [0, 4], fs, 20000, np.random.default_rng(0))
    return u, y, y0, Ad, fs, f, z, Phi


def test_chain_20db_known_modes(chain_data: tuple) -> None:
    u, y, _, _, fs, f, z, Phi = chain_data
    sweep = n4sid(u, y, fs, orders=range(2, 41, 2))
    mm = select_modes(stabilization_diagram(sweep))
    assert mm.method == "n4sid"
    assert mm.f_hz.size == 5
    np.testing.assert_allclose(mm.f_hz, f, rtol=3e-3)  # within 0.3 %
    np.testing.assert_allclose(mm.zeta, z, rtol=0.10)  # within 10 %
    assert np.diag(mac(mm.shapes, Phi)).min() > 0.99
    # standard deviations on by default, positive, and consistent with the actual error
    assert np.all(mm.std_f_hz > 0)
    assert np.all(mm.std_zeta > 0)
    assert np.all(np.abs(mm.f_hz - f) < 6 * mm.std_f_hz + 1e-4 * f)


def test_noise_free_recovers_exact_discrete_poles(chain_data: tuple) -> None:
    u, _, y0, Ad, fs, *_ = chain_data
    sweep = n4sid(u[:, :4000], y0[:, :4000], fs, orders=[10], n_blocks_std=0)
    lam_true = np.log(np.linalg.eigvals(Ad)) * fs
    lam_true = lam_true[lam_true.imag > 0]
    f_true = np.sort(np.abs(lam_true) / (2 * np.pi))
    # the Gram-matrix route squares the condition number: agreement ~ sqrt(eps)
    np.testing.assert_allclose(sweep.poles[0].f_hz, f_true, rtol=1e-5)
    assert sweep.n_blocks_std == 0
    assert np.all(np.isnan(sweep.poles[0].std_f_hz))


def test_one_factorisation_serves_every_order(chain_data: tuple) -> None:
    u, y, _, _, fs, *_ = chain_data
    full = n4sid(u, y, fs, orders=range(2, 31, 2), block_rows=8, n_blocks_std=0)
    alone = n4sid(u, y, fs, orders=[10], block_rows=8, n_blocks_std=0)
    k = list(full.orders).index(10)
    np.testing.assert_allclose(full.poles[k].f_hz, alone.poles[0].f_hz, rtol=1e-10)
    np.testing.assert_allclose(full.poles[k].zeta, alone.poles[0].zeta, rtol=1e-8)


def test_close_isolation_modes_of_004_table2_are_separated() -> None:
    # Table 2 of [004]: 0.6853 / 0.6975 / 0.7095 Hz at 7.6-8.6 % damping, plus two
    # superstructure modes; 8 sensors, 3 measured inputs, fs = 20 Hz (civil scale)
    f = np.array([0.6853, 0.6975, 0.7095, 4.7812, 5.1749])
    z = np.array([7.63, 8.62, 7.92, 3.21, 3.41]) / 100
    Q = scipy.stats.ortho_group.rvs(5, random_state=3)
    w = 2 * np.pi * f
    M, K, C = np.eye(5), Q @ np.diag(w**2) @ Q.T, Q @ np.diag(2 * z * w) @ Q.T
    rng = np.random.default_rng(3)
    u, y, _, _ = _simulate(M, C, K, [0, 1, 2], 20.0, 20000, rng)
    T = rng.standard_normal((8, 5))  # sensor layout
    sweep = n4sid(u, T @ y, 20.0, orders=range(4, 41, 2), block_rows=30)
    mm = select_modes(stabilization_diagram(sweep))
    iso = mm.f_hz < 1.0
    assert iso.sum() == 3
    np.testing.assert_allclose(mm.f_hz[iso], f[:3], rtol=3e-3)
    np.testing.assert_allclose(mm.zeta[iso], z[:3], rtol=0.10)
    assert np.diff(mm.f_hz[iso]).min() > 0.005  # three distinct poles, not one
    np.testing.assert_allclose(mm.f_hz[~iso], f[3:], rtol=3e-3)


def test_mode_with_node_at_every_sensor_is_not_invented() -> None:
    # symmetric 3-mass chain fixed at both ends: mode 2 has a node at the middle mass
    k = 1000.0
    K = k * np.array([[2.0, -1, 0], [-1, 2, -1], [0, -1, 2]])
    M = np.eye(3)
    w2, Phi = sla.eigh(K, M)
    f = np.sqrt(w2) / (2 * np.pi)
    C = M @ Phi @ np.diag(2 * 0.02 * np.sqrt(w2)) @ Phi.T @ M
    fs = 4 * f.max()
    u, y, _, _ = _simulate(M, C, K, [1], fs, 20000, np.random.default_rng(5))
    mm = select_modes(stabilization_diagram(n4sid(u, y[1:2], fs, orders=range(2, 17, 2))))
    assert mm.f_hz.size == 2
    np.testing.assert_allclose(mm.f_hz, f[[0, 2]], rtol=3e-3)


def test_bad_input(chain_data: tuple) -> None:
    u, y, *_ = chain_data
    fs = 35.0
    with pytest.raises(ShapeError, match=r"expected at least \d+ samples for block_rows"):
        n4sid(u[:, :100], y[:, :100], fs, orders=[10])
    with pytest.raises(ShapeError, match="y: expected 20000 samples as u"):
        n4sid(u, y[:, :-1], fs, orders=[4])
    bad = y.copy()
    bad[2, 10] = np.inf
    with pytest.raises(SignalError, match=r"NaN/Inf in channel\(s\) \[2\]"):
        n4sid(u, bad, fs, orders=[4])
    const = y.copy()
    const[3] = 1.0
    with pytest.raises(SignalError, match=r"constant channel\(s\) \[3\]"):
        n4sid(u, const, fs, orders=[4])
    with pytest.raises(SignalError, match="u: expected 2 linearly independent channels"):
        n4sid(np.vstack([u[0], 2 * u[0]]), y, fs, orders=[4])
    with pytest.raises(OptionError, match=r"orders: expected orders <= 35"):
        n4sid(u, y, fs, orders=[40], block_rows=8)
    with pytest.raises(OptionError, match="orders: expected a non-empty 1-D sequence"):
        n4sid(u, y, fs, orders=[2.5])
    with pytest.raises(OptionError, match="block_rows: expected an integer >= 2"):
        n4sid(u, y, fs, orders=[2], block_rows=1)
    with pytest.raises(OptionError, match="fs_hz"):
        n4sid(u, y, 0.0, orders=[2])
    with pytest.warns(RuntimeWarning, match="n_blocks_std: 8 blocks"):
        sw = n4sid(u[:, :600], y[:, :600], fs, orders=[4], block_rows=6)
    assert 1 < sw.n_blocks_std < 8


def test_f_min_sets_the_horizon(chain_data: tuple) -> None:
    u, y, _, _, fs, f, *_ = chain_data
    # ceil(fs / (8 f_min)) block rows: the same sweep as passing that value explicitly
    i = int(np.ceil(fs / (8 * 0.5 * f[0])))
    a = n4sid(u, y, fs, orders=[10], f_min_hz=0.5 * f[0], n_blocks_std=0)
    b = n4sid(u, y, fs, orders=[10], block_rows=i, n_blocks_std=0)
    np.testing.assert_allclose(a.poles[0].f_hz, b.poles[0].f_hz, rtol=1e-12)
    np.testing.assert_allclose(a.poles[0].f_hz, f, rtol=3e-3)
    with pytest.raises(OptionError, match="f_min_hz: expected a frequency in"):
        n4sid(u, y, fs, orders=[10], f_min_hz=-1.0)


def test_thin_block_product_matches_the_factor() -> None:
    from modal_twin.identification.n4sid import _l32, _l32_times

    rng = np.random.default_rng(7)
    H = rng.standard_normal((60, 500))
    Phi = H @ H.T
    G = np.linalg.qr(rng.standard_normal((24, 5)))[0]
    W = _l32(Phi, 12, 24)  # L32 L32^T = W^T W, the full-data route
    ref = W.T @ (W @ G)
    got = _l32_times(Phi, 12, 24, G)  # the std-block route, products with G only
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12 * np.abs(ref).max())


def test_whiten_reads_the_lower_triangle_and_falls_back_to_the_pseudo_inverse() -> None:
    from modal_twin.identification.n4sid import _whiten

    rng = np.random.default_rng(7)
    X = rng.standard_normal((6, 9))
    A = X @ X.T  # SPD: Cholesky with its relative 1e-10 ridge
    B = rng.standard_normal((6, 3))
    W = _whiten(np.tril(A), B)  # upper triangle never read
    ref = B.T @ np.linalg.solve(A + 1e-10 * np.trace(A) / 6 * np.eye(6), B)
    np.testing.assert_allclose(W.T @ W, ref, rtol=1e-10)
    A[5, 5] = -1.0  # indefinite: Cholesky fails, pseudo-inverse of the PSD part
    w, V = np.linalg.eigh(A)
    keep = w > 1e-10 * w.max()
    ref = B.T @ V[:, keep] @ np.diag(1 / w[keep]) @ V[:, keep].T @ B
    W = _whiten(np.tril(A), B)
    np.testing.assert_allclose(W.T @ W, ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())


def test_l32_factor_against_the_schur_complement_formula() -> None:
    from modal_twin.identification.n4sid import _l32

    rng = np.random.default_rng(8)
    mf, p, ly = 3, 8, 5
    H = rng.standard_normal((mf + p + ly, 60))
    Phi = H @ H.T  # SPD Gram matrix of [U_f; W_p; Y_f]
    S = Phi[mf:, mf:] - Phi[mf:, :mf] @ np.linalg.solve(Phi[:mf, :mf], Phi[:mf, mf:])
    ref = S[p:, :p] @ np.linalg.solve(S[:p, :p], S[:p, p:])  # Phi_32|1 Phi_22|1^-1 Phi_23|1
    W = _l32(Phi[: mf + p], mf, p)  # only the rows of [U_f; W_p] are read
    np.testing.assert_allclose(W.T @ W, ref, rtol=1e-8, atol=1e-8 * np.abs(ref).max())
    # Phi_22|1 indefinite beyond the ridge: the pseudo-inverse of its PSD part
    Phi2 = Phi.copy()
    Phi2[mf + 2, mf + 2] -= 2 * S[2, 2]
    S2 = S.copy()
    S2[2, 2] -= 2 * S[2, 2]
    w, V = np.linalg.eigh(S2[:p, :p])
    keep = w > 1e-10 * w.max()
    ref2 = S2[p:, :p] @ V[:, keep] @ np.diag(1 / w[keep]) @ V[:, keep].T @ S2[:p, p:]
    W2 = _l32(Phi2[: mf + p], mf, p)
    np.testing.assert_allclose(W2.T @ W2, ref2, rtol=1e-8, atol=1e-8 * np.abs(ref2).max())
