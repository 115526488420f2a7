from __future__ import annotations

import numpy as np
import pytest

from modal_twin.errors import OptionError
from modal_twin.identification._lagsums import hankel_gram, lag_sums
from modal_twin.identification._subspace import default_block_rows


def _direct(x: np.ndarray, y: np.ndarray, L: int, a: int, b: int, n_valid: int) -> np.ndarray:
    yz = y.copy()
    yz[:, n_valid:] = 0.0
    yz = np.hstack([yz, np.zeros((y.shape[0], L))])
    return np.stack([x[:, a:b] @ yz[:, a + d : b + d].T for d in range(L)])


@pytest.mark.parametrize(("a", "b", "n_valid", "L"), [(0, 3000, 3000, 7), (10, 811, 811, 25),
                                                      (5, 2000, 2500, 40), (0, 17, 3000, 3)])
def test_lag_sums_equal_direct_products(a: int, b: int, n_valid: int, L: int) -> None:
    rng = np.random.default_rng(0)
    z = rng.standard_normal((4, 3000)) * np.array([[1.0], [1e3], [1e-3], [5.0]])
    got = lag_sums(z[:2], z, L, a, b, n_valid)
    ref = _direct(z[:2], z, L, a, b, n_valid)
    assert got.shape == (L, 2, 4)
    # exact to rounding, relative to the scale of each channel pair
    scale = np.sqrt(np.sum(z[:2, a:b] ** 2, axis=1))[:, None] * np.sqrt(
        np.sum(z[:, a:] ** 2, axis=1))[None, :]
    assert np.max(np.abs(got - ref) / scale) < 1e-12


def test_hankel_gram_is_the_gram_of_the_block_hankel_matrix() -> None:
    rng = np.random.default_rng(1)
    c, L = 3, 9
    z = rng.standard_normal((c, 700)) * np.array([[1.0], [1e2], [1e-2]])
    j = z.shape[1] - L + 1
    H = np.vstack([z[:, b : b + j] for b in range(L)])  # row = block * c + channel
    edges = np.array([0, 50, 333, j])
    groups = [(slice(5, 9), slice(0, 1)), (slice(0, 5), slice(0, 1)), (slice(0, 5), slice(1, 3)),
              (slice(5, 9), slice(1, 3))]  # the [U_f; U_p; Y_p; Y_f] layout of n4sid
    rows = np.concatenate([(np.arange(L)[b][:, None] * c + np.arange(c)[q]).ravel()
                           for b, q in groups])
    G = hankel_gram(z, L, edges, groups)
    for k in range(3):
        Hk = H[rows, edges[k] : edges[k + 1]]
        ref = Hk @ Hk.T
        d = np.sqrt(np.diag(ref))
        assert np.max(np.abs(G[k] - ref) / np.outer(d, d)) < 1e-12
    full = H[rows] @ H[rows].T
    d = np.sqrt(np.diag(full))
    assert np.max(np.abs(sum(G) - full) / np.outer(d, d)) < 1e-12
    assert hankel_gram(z, L, np.array([0, j]))[0].shape == (L * c, L * c)


def test_default_block_rows_rule() -> None:
    # order limit alone (no f_min): ceil(67 / 42) + 1 = 3 -> floor 6
    assert default_block_rows(71.4, None, 66, 42, 54, floor=6) == 6
    # Test 010 of [004]: 71.4 Hz, lowest mode 0.69 Hz -> ceil(71.4 / (8 * 0.69)) = 13
    assert default_block_rows(71.4, 0.69, 66, 42, 54, floor=6) == 13
    # cost cap: i * 54 <= 1200 -> 22, but never below the order limit
    assert default_block_rows(71.4, 0.05, 66, 42, 54, floor=6) == 22
    assert default_block_rows(71.4, 0.05, 400, 4, 54, floor=6) == 102
    with pytest.raises(OptionError, match=r"f_min_hz: expected a frequency in \(0, fs_hz / 2"):
        default_block_rows(71.4, 40.0, 66, 42, 54, floor=6)


def test_lag_sums_many_passes_and_self_correlation() -> None:
    # a long record: several hundred FFT segments, so more than one pass of segments
    rng = np.random.default_rng(2)
    z = rng.standard_normal((3, 60000)) * np.array([[1.0], [1e2], [1e-2]])
    L, a, b = 5, 3, 59990
    got = lag_sums(z, z, L, a, b, z.shape[1])
    ref = _direct(z, z, L, a, b, z.shape[1])
    scale = np.sqrt(np.sum(z[:, a:b] ** 2, axis=1))
    assert np.max(np.abs(got - ref) / np.outer(scale, scale)) < 1e-12


def test_hankel_gram_leading_row_groups() -> None:
    rng = np.random.default_rng(3)
    c, L = 3, 8
    z = rng.standard_normal((c, 500))
    j = z.shape[1] - L + 1
    groups = [(slice(4, 8), slice(0, 1)), (slice(0, 4), slice(0, 1)), (slice(0, 4), slice(1, 3)),
              (slice(4, 8), slice(1, 3))]
    edges = np.array([0, 200, j])
    full = hankel_gram(z, L, edges, groups)
    part = hankel_gram(z, L, edges, groups, row_groups=3)
    kr = 4 * 1 + 4 * 1 + 4 * 2  # rows of [U_f; U_p; Y_p]
    for f, p in zip(full, part, strict=True):
        assert p.shape == (kr, L * c)
        np.testing.assert_allclose(p, f[:kr], rtol=0, atol=1e-12 * np.abs(f).max())


@pytest.mark.parametrize(("a", "b", "n_valid", "L"), [(0, 3000, 3000, 7), (10, 811, 811, 25),
                                                      (5, 2000, 2500, 40), (3, 2811, 2820, 9)])
def test_lag_sums_of_a_signal_with_itself(a: int, b: int, n_valid: int, L: int) -> None:
    # x IS y: one transform per segment plus a short DFT of the next L - 1 samples
    rng = np.random.default_rng(4)
    z = rng.standard_normal((3, 3000)) * np.array([[1.0], [1e3], [1e-3]])
    got = lag_sums(z, z, L, a, b, n_valid)
    ref = _direct(z, z, L, a, b, n_valid)
    scale = np.sqrt(np.sum(z[:, a:b] ** 2, axis=1))[:, None] * np.sqrt(
        np.sum(z[:, a:] ** 2, axis=1))[None, :]
    assert np.max(np.abs(got - ref) / scale) < 1e-12


@pytest.mark.parametrize(("a", "b", "n_valid", "L"), [(0, 1500, 1500, 400), (5, 900, 1000, 300),
                                                      (0, 17, 3000, 5), (7, 2000, 2100, 60)])
@pytest.mark.parametrize("same", [True, False])
def test_lag_sums_many_lags_from_one_transform(monkeypatch: pytest.MonkeyPatch, a: int, b: int,
                                               n_valid: int, L: int, same: bool) -> None:
    # L^2 > WHOLE_RANGE (b - a): one transform of the range; the last case forced both ways
    import modal_twin.identification._lagsums as ls

    rng = np.random.default_rng(5)
    z = rng.standard_normal((3, 3000)) * np.array([[1.0], [1e3], [1e-3]])
    x = z if same else z[:2]
    ref = _direct(x, z, L, a, b, n_valid)
    scale = np.sqrt(np.sum(x[:, a:b] ** 2, axis=1))[:, None] * np.sqrt(
        np.sum(z[:, a:] ** 2, axis=1))[None, :]
    assert ls.WHOLE_RANGE * (b - a) < L * L or L == 60
    for whole in (ls.WHOLE_RANGE, 0.0, np.inf):
        monkeypatch.setattr(ls, "WHOLE_RANGE", whole)
        got = lag_sums(x, z, L, a, b, n_valid)
        assert got.shape == (L, x.shape[0], 3)
        assert np.max(np.abs(got - ref) / scale) < 1e-12
