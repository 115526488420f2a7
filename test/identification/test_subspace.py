from __future__ import annotations

import numpy as np
import pytest

from modal_twin.identification._subspace import leading_eigh


@pytest.mark.parametrize("n", [120, 200, 546])
def test_leading_eigh_matches_full_symmetric_solver(n: int) -> None:
    # a few dominant directions over a flat, clustered noise floor (as in SSI)
    rng = np.random.default_rng(n)
    B = rng.standard_normal((n, n + 40)) * np.r_[np.logspace(2, 0, 12), np.ones(n - 12)][:, None]
    P = B @ B.T
    w_ref, U_ref = np.linalg.eigh(P)
    w_ref, U_ref = w_ref[::-1], U_ref[:, ::-1]
    n_max = 40
    w, U = leading_eigh(P, n_max)
    n_sv = n if n <= 500 else max(2 * n_max, 100)
    assert w.shape == (n_sv,)
    assert U.shape == (n, n_max)
    np.testing.assert_allclose(w, w_ref[:n_sv], rtol=0, atol=1e-12 * w_ref[0])
    assert np.abs(U.T @ U - np.eye(n_max)).max() < 1e-12  # orthonormal
    # residual of each pair, relative to the norm of P
    assert np.linalg.norm(P @ U - U * w[:n_max], axis=0).max() < 1e-12 * w_ref[0]
    # the leading subspace (well separated: 12 dominant directions) is the same
    s = np.linalg.svd(U_ref[:, :12].T @ U[:, :12], compute_uv=False)
    assert s.min() > 1 - 1e-12
