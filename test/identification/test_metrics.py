from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from modal_twin.errors import ShapeError, SignalError
from modal_twin.identification.metrics import automac, complexity, mac, mpc

_finite = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)


def test_mac_known_values_and_always_2d() -> None:
    e = np.eye(3)
    np.testing.assert_allclose(mac(e, e), np.eye(3))
    assert mac([1.0, 1.0, 0.0], [1.0, 0.0, 0.0]).shape == (1, 1)
    assert mac([1.0, 1.0, 0.0], [1.0, 0.0, 0.0])[0, 0] == pytest.approx(0.5)
    assert mac(e, [1.0, 0.0, 0.0]).shape == (3, 1)
    assert mac([0.0, 0.0], [1.0, 0.0])[0, 0] == 0.0  # zero shape: defined as 0
    # a complex mode and its conjugate (004 Fig. 8): MAC < 1 for a non-monophase shape
    v = np.array([1.0, 1j, -1.0])
    assert mac(v, v.conj())[0, 0] == pytest.approx(1.0 / 9.0)


@settings(max_examples=60, derandomize=True, deadline=None, database=None)
@given(
    re=arrays(np.float64, (6, 3), elements=_finite),
    im=arrays(np.float64, (6, 3), elements=_finite),
    scale_abs=st.floats(1e-3, 1e3),
    scale_arg=st.floats(-np.pi, np.pi),
)
def test_mac_invariants(re, im, scale_abs, scale_arg) -> None:
    a = re + 1j * im
    b = np.roll(a, 1, axis=0)
    m = mac(a, b)
    assert m.shape == (3, 3)
    assert np.all((m >= 0.0) & (m <= 1.0))
    c = scale_abs * np.exp(1j * scale_arg)
    np.testing.assert_allclose(mac(c * a, b), m, atol=1e-9)  # complex scale invariant
    np.testing.assert_allclose(mac(b, a), m.T, atol=1e-12)  # symmetric
    d = np.diag(automac(a))
    nz = np.linalg.norm(a, axis=0) > 0
    np.testing.assert_allclose(d[nz], 1.0)


def test_mpc_eqs_7_9_against_principal_axes() -> None:
    rng = np.random.default_rng(0)
    v = rng.standard_normal((8, 5)) + 1j * rng.standard_normal((8, 5))
    ref = []
    for col in v.T:
        X = np.vstack([col.real, col.imag])
        lam = np.linalg.eigvalsh(X @ X.T)
        ref.append(((lam[1] - lam[0]) / lam.sum()) ** 2)
    np.testing.assert_allclose(mpc(v), ref, rtol=1e-10)
    np.testing.assert_allclose(complexity(v), 1.0 - np.asarray(ref), rtol=1e-10)


def test_mpc_special_shapes() -> None:
    real = np.array([1.0, -2.0, 0.5])
    assert mpc(real)[0] == pytest.approx(1.0)
    assert mpc(real * np.exp(0.7j))[0] == pytest.approx(1.0)  # monophase
    assert mpc(np.array([1.0, 1j]))[0] == pytest.approx(0.0)  # circular spread
    assert mpc(np.array([1.0, 2j]))[0] == pytest.approx(0.36)  # ((4 - 1) / 5)^2
    assert mpc(np.zeros(3))[0] == 0.0
    assert complexity(real)[0] == pytest.approx(0.0)


def test_errors() -> None:
    with pytest.raises(ShapeError, match="phi_b: expected 3 channels as phi_a, got 2"):
        mac(np.ones(3), np.ones(2))
    with pytest.raises(ShapeError, match=r"phi_a: expected shape \(n_ch, n_modes\)"):
        mac(np.ones((2, 2, 2)), np.ones(2))
    with pytest.raises(SignalError, match="finite mode shapes"):
        mpc([1.0, np.nan])
