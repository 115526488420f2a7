"""The exponential window of output-only PolyMAX adds a known decay, and it is taken back out.

A single-degree-of-freedom oscillator (3 Hz, 1 % damped: the truth), driven by white
noise and simulated by exact discretisation. Its output correlations decay as
:math:`e^{\\lambda k \\Delta t}`; the window :math:`w_k = e^{-\\beta k}` of the positive
half-spectrum makes that :math:`e^{(\\lambda - \\beta f_s) k \\Delta t}`, so the pole PolyMAX fits
is damped by :math:`\\sigma_w / \\omega_n` more (:math:`\\sigma_w = \\beta f_s`; Peeters
et al. 2004, sec. 3 of [002]; the exponential-window correction of impact testing,
Fladung & Rost 1997, "Application and correction of the exponential window for frequency
response functions", Mech. Syst. Signal Process. 11) and the true pole is the fitted one
plus :math:`\\sigma_w`. Windows from 0.3 % to 2.4 % of added damping must give the same
corrected damping, the truth's.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal as sig

from modal_twin.identification.polymax import polymax
from modal_twin.identification.record import _undo_window, half_spectra

FS, SECONDS = 50.0, 3600.0
F0, ZETA0 = 3.0, 0.01


@pytest.fixture(scope="module")
def response() -> np.ndarray:
    w0 = 2 * np.pi * F0
    A = np.array([[0.0, 1.0], [-(w0**2), -2 * ZETA0 * w0]])
    sysd = sig.cont2discrete((A, np.array([[0.0], [1.0]]), np.array([[1.0, 0.0]]),
                              np.zeros((1, 1))), 1 / FS)
    x = np.random.default_rng(2).standard_normal(int(FS * SECONDS))
    _, y, _ = sig.dlsim((*sysd[:4], 1 / FS), x)
    return np.asarray(y.T)


def _pole(response: np.ndarray, lags: int, decay: float) -> tuple[float, float, float, float]:
    """Fitted damping, corrected frequency and damping, and the window's added damping."""
    f, S, sigma_w = half_spectra(response, FS, lags, decay=decay)
    sweep = polymax(S, f, orders=range(2, 9), band_hz=(1.0, 6.0), shapes="numerator")
    fit = sweep.poles[-1]
    k = int(np.argmin(np.abs(fit.f_hz - F0)))
    true = _undo_window(sweep, sigma_w).poles[-1]
    return (float(fit.zeta[k]), float(true.f_hz[k]), float(true.zeta[k]),
            sigma_w / (2 * np.pi * F0))


def test_the_window_adds_its_decay_and_the_correction_removes_it(response: np.ndarray) -> None:
    got = [_pole(response, lags, decay) for lags, decay in
           ((2000, 0.1), (2000, 0.01), (1000, 0.01), (500, 0.01))]
    zeta_w = np.array([g[3] for g in got])
    assert zeta_w.min() < 0.004 and zeta_w.max() > 0.02  # 0.31 % to 2.45 % added
    fitted, f_true, zeta_true = (np.array([g[i] for g in got]) for i in range(3))
    # the fitted poles carry the window: the truth's damping plus the window's
    np.testing.assert_allclose(fitted, ZETA0 + zeta_w, rtol=0.1)
    # corrected: one damping whatever the window, the truth's (one 1-hour record: a few %)
    np.testing.assert_allclose(zeta_true, zeta_true.mean(), rtol=0.03)
    np.testing.assert_allclose(zeta_true, ZETA0, rtol=0.08)
    np.testing.assert_allclose(f_true, F0, rtol=1e-3)
    # the opposite sign (the window's damping added instead of removed) is far off
    assert np.all(fitted + zeta_w > 1.5 * ZETA0)
