from __future__ import annotations

import numpy as np
import pytest
import scipy.signal as sig

from modal_twin.acquisition.frf import frf
from modal_twin.errors import OptionError, ShapeError, SignalError

FS = 100.0
P = 1024  # samples per period of the periodic random excitation


def _system(n_in: int) -> sig.dlti:
    """Exact ZOH discretisation of an SDOF (n_in = 1) or a 2-DOF chain (n_in = 2)."""
    if n_in == 1:
        M, K = np.eye(1), np.array([[(2 * np.pi * 5.0) ** 2]])
    else:
        M, K = np.diag([1.0, 2.0]), np.array([[3000.0, -1000.0], [-1000.0, 1000.0]])
    C = 0.02 * K / np.sqrt(K[0, 0]) if n_in == 1 else 1.0 * M + 1e-3 * K  # 1 %; Rayleigh
    n = M.shape[0]
    Mi = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Mi @ K, -Mi @ C]])
    B = np.vstack([np.zeros((n, n)), Mi])[:, :n_in]
    Cd = np.hstack([np.eye(n), np.zeros((n, n))])
    return sig.dlti(*sig.cont2discrete((A, B, Cd, np.zeros((n, n_in))), 1 / FS)[:4], dt=1 / FS)


def _fresp(sys: sig.dlti, f_hz: np.ndarray) -> np.ndarray:
    """C (zI - A)^-1 B + D on the lines, shape (n_out, n_in, n_f)."""
    z = np.exp(2j * np.pi * f_hz / FS)
    n = sys.A.shape[0]
    X = np.linalg.solve(z[:, None, None] * np.eye(n) - sys.A, sys.B[None])
    return np.moveaxis(sys.C @ X + sys.D, 0, -1)


def _periodic_run(sys: sig.dlti, rng: np.random.Generator, n_keep: int) -> tuple:
    """Steady-state periodic response: 8 settling periods dropped, n_keep periods kept."""
    n_in = sys.B.shape[1]
    one = rng.standard_normal((n_in, P))
    u = np.tile(one, (1, 8 + n_keep))
    _, y, _ = sig.dlsim(sys, u.T)
    return u[:, 8 * P :], y.T[:, 8 * P :]


@pytest.fixture(scope="module")
def sdof() -> tuple:
    sys = _system(1)
    u, y = _periodic_run(sys, np.random.default_rng(0), 4)
    return sys, u, y


def test_h1_of_noise_free_sdof_equals_its_analytic_frf(sdof: tuple) -> None:
    sys, u, y = sdof
    est = frf(u, y, FS, nperseg=P, noverlap=0, window="boxcar", detrend=False)
    H = _fresp(sys, est.f_hz)[0, 0]
    # analytic FRF of the sampled (ZOH) system on the FFT lines: exact for periodic input
    np.testing.assert_allclose(est.H1[0, 0], H, rtol=1e-8)
    np.testing.assert_allclose(est.H2[0, 0], H, rtol=1e-8)
    np.testing.assert_allclose(est.coherence, 1.0, atol=1e-10)
    assert est.n_averages == 4
    # resonance peak within one line of the damped natural frequency of the continuous SDOF
    fd = 5.0 * np.sqrt(1 - 0.02**2 * (2 * np.pi * 5.0) ** 2 / (2 * np.pi * 5.0) ** 2)
    assert abs(est.f_hz[np.argmax(np.abs(est.H1[0, 0]))] - fd) <= FS / P


def test_output_noise_h1_unbiased_h2_high(sdof: tuple) -> None:
    sys, u, y = sdof
    rng = np.random.default_rng(1)
    u, y = _periodic_run(sys, rng, 64)
    yn = y + 0.3 * np.std(y) * rng.standard_normal(y.shape)
    est = frf(u, yn, FS, nperseg=P, noverlap=0, window="boxcar", detrend=False)
    # identity of the estimators: H1 = coherence * H2 for a single input
    np.testing.assert_allclose(est.H1[0, 0], est.coherence[0] * est.H2[0, 0], rtol=1e-9)
    H = _fresp(sys, est.f_hz)[0, 0]
    band = (est.f_hz > 3.0) & (est.f_hz < 7.0)
    assert np.all(np.abs(est.H2[0, 0, band]) >= np.abs(est.H1[0, 0, band]))
    assert np.median(np.abs(est.H1[0, 0, band] / H[band] - 1)) < 0.05
    assert np.all(est.coherence <= 1.0)
    assert np.all(est.coherence >= 0.0)


def test_mimo_repeated_hits() -> None:
    sys = _system(2)
    rng = np.random.default_rng(2)
    runs = [_periodic_run(sys, rng, 1) for _ in range(4)]  # 4 independent "hits"
    x = np.stack([r[0] for r in runs])
    y = np.stack([r[1] for r in runs])
    est = frf(x, y, FS, detrend=False)
    H = _fresp(sys, est.f_hz)
    np.testing.assert_allclose(est.H1, H, rtol=1e-7, atol=1e-7 * np.abs(H).max())
    np.testing.assert_allclose(est.coherence, 1.0, atol=1e-9)
    assert np.all(np.isnan(est.H2))  # H2 is not defined for two inputs
    assert est.n_averages == 4


def test_welch_defaults_gain() -> None:
    rng = np.random.default_rng(3)
    u = rng.standard_normal(8192)
    est = frf(u, -3.0 * u, FS)
    np.testing.assert_allclose(est.H1[0, 0], -3.0, rtol=1e-10)


def test_lines_without_input_power_are_nan() -> None:
    u = np.cos(2 * np.pi * 5 * np.arange(256) / 64)  # exactly on line 5 of 64
    est = frf(u, 2.0 * u, FS, nperseg=64, noverlap=0, window="boxcar", detrend=False)
    assert est.H1[0, 0, 5] == pytest.approx(2.0)
    assert np.isnan(est.H1[0, 0, 7])
    assert est.coherence[0, 7] == 0.0


def test_errors() -> None:
    rng = np.random.default_rng(4)
    u = rng.standard_normal((2, 512))
    with pytest.raises(ShapeError, match="expected the same hits and samples"):
        frf(u, u[:, :500], FS)
    with pytest.raises(ShapeError, match="at least n_in = 2 averages"):
        frf(u, u, FS, nperseg=512)
    with pytest.raises(SignalError, match="linearly independent"):
        frf(np.vstack([u[0], 2 * u[0]]), u, FS, nperseg=64)
    with pytest.raises(OptionError, match="nperseg: expected 2 <= nperseg"):
        frf(u, u, FS, nperseg=1000)
    with pytest.raises(OptionError, match="noverlap: expected 0 <= noverlap"):
        frf(u, u, FS, nperseg=64, noverlap=64)
    with pytest.raises(OptionError, match="detrend: expected one of"):
        frf(u, u, FS, detrend="quadratic")  # type: ignore[arg-type]
    with pytest.raises(OptionError, match="must be None for repeated hits"):
        frf(u[None], u[None], FS, nperseg=64)
    bad = u.copy()
    bad[1, 3] = np.nan
    with pytest.raises(SignalError, match="NaN/Inf"):
        frf(u, bad, FS)
