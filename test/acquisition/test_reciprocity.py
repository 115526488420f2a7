from __future__ import annotations

import numpy as np
import pytest

from modal_twin.acquisition.reciprocity import reciprocity
from modal_twin.errors import ShapeError, SignalError


def _frf(K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    f = np.linspace(0.5, 20.0, 400)
    M = np.diag([1.0, 1.5, 0.8])
    C = 1e-3 * (K + K.T) / 2
    w = 2 * np.pi * f
    Z = -(w**2)[:, None, None] * M + 1j * w[:, None, None] * C + K
    return np.moveaxis(np.linalg.inv(Z), 0, -1), f  # (n_out, n_in, n_f)


K0 = np.array([[2000.0, -1000.0, 0.0], [-1000.0, 2500.0, -1500.0], [0.0, -1500.0, 1500.0]])


def test_symmetric_structure_is_reciprocal() -> None:
    H, _ = _frf(K0)
    chk = reciprocity(H, [0, 1, 2])
    np.testing.assert_array_equal(chk.pairs, [[0, 1], [0, 2], [1, 2]])
    assert np.all(chk.rel_error < 1e-12)
    np.testing.assert_allclose(chk.frac, 1.0, atol=1e-12)
    # two inputs at DOFs 2 and 0 of three outputs: collocated outputs given explicitly
    chk2 = reciprocity(H[:, [2, 0], :], [2, 0], band=slice(10, 300))
    assert chk2.rel_error[0] < 1e-12


def test_asymmetric_stiffness_breaks_reciprocity() -> None:
    K = K0.copy()
    K[0, 1] *= 1.3  # non-reciprocal coupling (e.g. a follower force)
    chk = reciprocity(_frf(K)[0], [0, 1, 2])
    assert chk.rel_error[0] > 0.05
    assert chk.frac[0] < 1.0


def test_errors() -> None:
    H, _ = _frf(K0)
    with pytest.raises(ShapeError, match=r"expected shape \(n_out, n_in, n_f\)"):
        reciprocity(H[0], [0])
    with pytest.raises(ShapeError, match="collocated: expected 3"):
        reciprocity(H, [0, 1])
    with pytest.raises(ShapeError, match="collocated: expected 3"):
        reciprocity(H, [0, 1, 5])
    Hn = H.copy()
    Hn[0, 1, :] = np.nan
    with pytest.raises(SignalError, match="finite FRF lines"):
        reciprocity(Hn, [0, 1, 2])
