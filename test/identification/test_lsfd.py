from __future__ import annotations

import numpy as np
import pytest

from modal_twin.errors import ShapeError, SignalError
from modal_twin.identification.lsfd import lsfd
from modal_twin.identification.metrics import mac


def test_residues_and_residuals_recovered_exactly() -> None:
    rng = np.random.default_rng(0)
    lam = 2 * np.pi * np.array([2.0, 3.5]) * (-0.02 + 1j)
    psi = rng.standard_normal((4, 2)) + 0.1j * rng.standard_normal((4, 2))
    L = rng.standard_normal((2, 2)) + 0.1j * rng.standard_normal((2, 2))
    RL = rng.standard_normal((4, 2))
    RU = 1e-3 * rng.standard_normal((4, 2))
    f = np.linspace(1.0, 5.0, 400)
    s = 2j * np.pi * f
    H = -RL[..., None] / (2 * np.pi * f) ** 2 + RU[..., None] + 0j
    for r in range(2):
        Rr = np.outer(psi[:, r], L[:, r])  # R_r = psi_r L_r^T, Eq. (5) of [002]
        H += Rr[..., None] / (s - lam[r]) + Rr.conj()[..., None] / (s - lam[r].conj())
    res = lsfd(H, f, lam)
    for r in range(2):
        np.testing.assert_allclose(res.residues[r], np.outer(psi[:, r], L[:, r]), rtol=1e-8)
    np.testing.assert_allclose(res.lower, RL, atol=1e-8)
    np.testing.assert_allclose(res.upper, RU, atol=1e-10)
    assert res.rel_residual < 1e-10
    np.testing.assert_allclose(np.diag(mac(res.shapes, psi)), 1.0, atol=1e-10)
    assert res.participation.shape == (2, 2)


def test_without_residuals_leaves_them_zero() -> None:
    lam = np.array([2 * np.pi * (-0.05 + 1j)])
    f = np.linspace(0.5, 1.5, 50)
    s = 2j * np.pi * f
    H = (2.0 / (s - lam[0]) + 2.0 / (s - lam[0].conj()))[None, None, :]
    res = lsfd(H, f, lam, lower=False, upper=False)
    assert res.residues[0, 0, 0] == pytest.approx(2.0)
    assert np.all(res.lower == 0)
    assert np.all(res.upper == 0)


def test_bad_input() -> None:
    f = np.linspace(1.0, 2.0, 10)
    with pytest.raises(ShapeError, match=r"expected \(n_out, n_in, n_f\), \(n_f,\)"):
        lsfd(np.ones((2, 10)), f, [1j])
    with pytest.raises(SignalError, match="finite poles"):
        lsfd(np.ones((1, 1, 10)), f, [np.nan])
    with pytest.raises(ShapeError, match="finite lines with f > 0"):
        lsfd(np.ones((1, 1, 10)), f, -0.1 + 1j * np.arange(1, 11))
