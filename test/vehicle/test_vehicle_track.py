"""Track irregularity: German spectrum, generated profile PSD, wheelset delays."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
import scipy.signal

from modal_twin.errors import OptionError, ShapeError, SignalError
from modal_twin.models.track import (
    GERMAN_LOW_INTERFERENCE,
    german_vertical_psd,
    random_profile,
    wheelset_inputs,
)


def test_psd_closed_form_values():
    p = GERMAN_LOW_INTERFERENCE
    # Omega -> 0: A_v / Omega_r^2; Omega = Omega_c: A_v / (2 (Omega_c^2 + Omega_r^2))
    assert german_vertical_psd(0.0) == pytest.approx(p["A_v"] / p["Omega_r"] ** 2, rel=1e-12)
    oc = p["Omega_c"]
    assert german_vertical_psd(oc) == pytest.approx(
        p["A_v"] / (2 * (oc**2 + p["Omega_r"] ** 2)), rel=1e-12)
    # high wavenumbers fall as Omega^-4
    assert german_vertical_psd(100.0) / german_vertical_psd(200.0) == pytest.approx(16, rel=1e-3)


def test_generated_profile_matches_the_target_psd():
    prof = random_profile(20000.0, dx_m=0.25, wavelength_band_m=(2.0, 100.0), rng=7)
    nps = 4096
    n_hz, S_n = scipy.signal.welch(prof.z, fs=1.0 / prof.dx, nperseg=nps)
    Om = 2 * math.pi * n_hz
    S_om = S_n / (2 * math.pi)  # one-sided per (cycle/m) -> per (rad/m)
    edges = 2 * math.pi / np.array([80.0, 40.0, 20.0, 10.0, 5.0, 2.5])  # octave bands
    errs = []
    for lo, hi in itertools.pairwise(edges):
        sel = (Om >= lo) & (Om < hi)
        errs.append(np.mean(S_om[sel]) / np.mean(german_vertical_psd(Om[sel])) - 1.0)
    assert np.max(np.abs(errs)) < 0.15  # measured: largest band error in the report
    # variance = integral of the one-sided PSD over the generated band
    om = np.linspace(2 * math.pi / 100.0, 2 * math.pi / 2.0, 200001)
    var = np.trapezoid(german_vertical_psd(om), om)
    assert np.var(prof.z) == pytest.approx(var, rel=0.1)


def test_slope_is_the_derivative_of_the_profile():
    prof = random_profile(500.0, dx_m=0.01, wavelength_band_m=(1.0, 100.0), rng=3)
    fd = np.gradient(prof.z, prof.dx)
    inner = slice(5, -5)
    err = np.linalg.norm(fd[inner] - prof.dzdx[inner]) / np.linalg.norm(prof.dzdx[inner])
    assert err < 2e-3  # central difference error (pi dx / 1 m)^2 / 6 = 1.6e-4 at 1 m


def test_wheelset_delays_are_exact():
    prof = random_profile(600.0, dx_m=0.05, rng=11)
    v, fs = 80.0, 400.0  # v / fs = 0.2 m per sample
    x_axles = (10.2, 7.6, -7.6, -10.2)  # spacings 2.6, 15.2, 2.6 m = 13, 76, 13 samples
    u = wheelset_inputs(prof, x_axles, v, fs, 5.0)
    assert u.shape == (8, 2001)
    for a, lag in ((1, 13), (2, 89), (3, 102)):
        np.testing.assert_allclose(u[a, lag:], u[0, :-lag], rtol=0, atol=1e-12)
        np.testing.assert_allclose(u[4 + a, lag:], u[4, :-lag], rtol=0, atol=1e-10)
    # the rate is dz/dt: compare with a centred difference in time
    dz = np.gradient(u[0], 1 / fs)
    assert np.linalg.norm(dz - u[4]) / np.linalg.norm(u[4]) < 0.05


def test_track_errors():
    prof = random_profile(100.0, dx_m=0.05, wavelength_band_m=(1.0, 50.0), rng=0)
    with pytest.raises(SignalError, match=r"profile: expected to cover track coordinates"):
        wheelset_inputs(prof, (10.0, -10.0), 80.0, 100.0, 5.0)
    with pytest.raises(OptionError, match="speed: expected a positive finite value, got -1"):
        wheelset_inputs(prof, (1.0,), -1.0, 100.0, 0.1)
    with pytest.raises(ShapeError, match="x_axles: expected at least one wheelset"):
        wheelset_inputs(prof, (), 80.0, 100.0, 0.1)
    with pytest.raises(OptionError, match="length_m, dx_m: expected positive finite"):
        random_profile(-1.0)
    with pytest.raises(OptionError, match=r"wavelength_band_m: expected 0 < short < long"):
        random_profile(100.0, wavelength_band_m=(5.0, 200.0))
    with pytest.raises(OptionError, match=r"dx_m: expected <= shortest wavelength / 4"):
        random_profile(500.0, dx_m=0.5)
