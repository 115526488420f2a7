"""Vertical track irregularity: German high-speed spectrum, random profiles, wheelset inputs.

German high-speed track spectrum, vertical profile (low-interference track)::

    S(Omega) = A_v Omega_c^2 / ((Omega^2 + Omega_r^2) (Omega^2 + Omega_c^2))

with ``A_v = 4.032e-7 m rad``, ``Omega_c = 0.8246 rad/m``, ``Omega_r = 0.0206 rad/m``
(values as tabulated for the German low-interference spectrum in W. Zhai, *Vehicle-Track
Coupled Dynamics*, Springer 2020, Ch. 3; the track input of [002], Sec. 5). Convention
used here: ``Omega`` is the spatial angular frequency (rad/m) and ``S`` is **one-sided**
in m^2/(rad/m): the variance of the profile is ``int_0^inf S(Omega) dOmega`` (restricted
to the generated wavelength band).

Profiles are sums of cosines with deterministic amplitudes and random phases (the
spectral representation of Shinozuka), computed with one inverse FFT::

    z(x) = sum_k sqrt(2 S(Omega_k) dOmega) cos(Omega_k x + phi_k),  phi_k ~ U(0, 2 pi)

on the FFT grid ``Omega_k = 2 pi k / L`` inside the band; the slope ``dz/dx`` is the exact
derivative of the same sum (``-Omega_k`` times the quadrature component).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.errors import OptionError, ShapeError, SignalError

__all__ = [
    "GERMAN_LOW_INTERFERENCE",
    "TrackProfile",
    "german_vertical_psd",
    "random_profile",
    "wheelset_inputs",
]

GERMAN_LOW_INTERFERENCE: dict[str, float] = {"A_v": 4.032e-7, "Omega_c": 0.8246,
                                              "Omega_r": 0.0206}
"""German high-speed low-interference vertical spectrum: A_v (m rad), Omega_c, Omega_r (rad/m)."""


def german_vertical_psd(omega: FloatArray | float, *, A_v: float = 4.032e-7,
                        Omega_c: float = 0.8246, Omega_r: float = 0.0206) -> FloatArray:
    """One-sided vertical-profile PSD of the German spectrum, m^2/(rad/m) (module docstring).

    Parameters
    ----------
    omega : float or array
        Spatial angular frequency Omega, rad/m (``2 pi / wavelength``).
    A_v, Omega_c, Omega_r : float
        Roughness coefficient (m rad) and corner frequencies (rad/m); defaults: the
        low-interference track.

    Returns
    -------
    float array
        ``S(Omega)``, same shape as ``omega``.

    Examples
    --------
    >>> print(f"{german_vertical_psd(0.0):.4e}")
    9.5014e-04
    """
    Om = np.asarray(omega, dtype=float)
    return np.asarray(A_v * Omega_c**2 / ((Om**2 + Omega_r**2) * (Om**2 + Omega_c**2)))


@dataclass(frozen=True, slots=True)
class TrackProfile:
    """A vertical track profile sampled along the track.

    Attributes
    ----------
    x : (n,) float array
        Track coordinate, m (uniform, from 0).
    z : (n,) float array
        Vertical irregularity, m.
    dzdx : (n,) float array
        Its slope (exact derivative of the generated sum), m/m.
    wavelength_band_m : (float, float)
        Shortest and longest wavelengths generated, m.
    """

    x: FloatArray
    z: FloatArray
    dzdx: FloatArray
    wavelength_band_m: tuple[float, float]

    @property
    def dx(self) -> float:
        """Sample spacing, m."""
        return float(self.x[1] - self.x[0])


def random_profile(length_m: float, *, dx_m: float = 0.05,
                   wavelength_band_m: tuple[float, float] = (1.0, 120.0),
                   rng: np.random.Generator | int | None = None,
                   A_v: float = 4.032e-7, Omega_c: float = 0.8246,
                   Omega_r: float = 0.0206,
                   psd: Callable[[FloatArray], FloatArray] | None = None) -> TrackProfile:
    """Draw a random vertical profile of the German spectrum (module docstring).

    Parameters
    ----------
    length_m : float
        Profile length, m.
    dx_m : float
        Sample spacing, m (at most a quarter of the shortest wavelength).
    wavelength_band_m : (float, float)
        Shortest and longest wavelengths, m (default 1-120 m: 0.7-83 Hz at 300 km/h).
    rng : Generator or int, optional
        Random source or seed (``np.random.default_rng(rng)``).
    A_v, Omega_c, Omega_r : float
        Spectrum parameters (:func:`german_vertical_psd`).
    psd : callable, optional
        Another one-sided spectrum ``S(Omega)`` (rad/m in, units^2/(rad/m) out) used
        instead of the vertical one (e.g. alignment or cross level,
        :mod:`modal_twin.models.track3d`); ``A_v, Omega_c, Omega_r`` are then unused.

    Returns
    -------
    TrackProfile

    Raises
    ------
    OptionError
        Non-positive length or spacing, a band that is not ``0 < short < long <= length``,
        or ``dx_m`` above a quarter of the shortest wavelength.
    """
    lo, hi = (float(v) for v in wavelength_band_m)
    if not (math.isfinite(length_m) and length_m > 0 and math.isfinite(dx_m) and dx_m > 0):
        msg = f"length_m, dx_m: expected positive finite values, got {length_m!r}, {dx_m!r}"
        raise OptionError(msg)
    if not 0.0 < lo < hi <= length_m:
        msg = (f"wavelength_band_m: expected 0 < short < long <= length_m = {length_m}, got "
               f"{wavelength_band_m!r}")
        raise OptionError(msg)
    if dx_m > 0.25 * lo:
        msg = f"dx_m: expected <= shortest wavelength / 4 = {0.25 * lo}, got {dx_m}"
        raise OptionError(msg)
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    n = math.ceil(length_m / dx_m) + 1
    n_fft = 1 << math.ceil(math.log2(n))
    L = n_fft * dx_m
    k = np.arange(n_fft // 2 + 1)
    Om = np.asarray(2.0 * math.pi * k / L, dtype=np.float64)
    dOm = 2.0 * math.pi / L
    band = (Om >= 2.0 * math.pi / hi) & (Om <= 2.0 * math.pi / lo)
    S = (german_vertical_psd(Om, A_v=A_v, Omega_c=Omega_c, Omega_r=Omega_r) if psd is None
         else np.asarray(psd(Om), dtype=float))
    amp = np.where(band, np.sqrt(2.0 * S * dOm), 0.0)
    phase = gen.uniform(0.0, 2.0 * math.pi, k.size)
    Z = amp * np.exp(1j * phase) * (n_fft / 2.0)  # irfft(Z)[j] = sum amp cos(Om x + phi)
    z = np.fft.irfft(Z, n_fft)[:n]
    dz = np.fft.irfft(1j * Om * Z, n_fft)[:n]  # exact slope of the same cosine sum
    x = np.asarray(dx_m * np.arange(n), dtype=np.float64)
    return TrackProfile(x=x, z=z, dzdx=dz, wavelength_band_m=(lo, hi))


def wheelset_inputs(profile: TrackProfile, x_axles: Sequence[float], speed: float,
                    fs_hz: float, duration_s: float, *, start_m: float = 0.0) -> FloatArray:
    """Track displacements and rates under each wheelset while running at ``speed``.

    The vehicle runs towards +x; a wheelset at ``x_a`` (m from the carbody centre, front
    positive) is at track coordinate ``s_a(t) = s0 + v t + x_a`` with
    ``s0 = start_m - min(x_axles)`` (the last wheelset starts at ``start_m``). So wheelset
    ``a`` sees the leading wheelset's input delayed by ``(x_lead - x_a) / v`` exactly
    (linear interpolation of the profile at the same track points).

    Parameters
    ----------
    profile : TrackProfile
    x_axles : sequence of float
        Wheelset positions (e.g. :attr:`VehicleSpec.axle_x`), m.
    speed : float
        m/s.
    fs_hz : float
        Sample rate, Hz.
    duration_s : float
        Record length, s (``nt = round(duration_s fs_hz) + 1`` samples from t = 0).
    start_m : float
        Track coordinate of the last wheelset at t = 0.

    Returns
    -------
    (2 n_axles, nt) float array
        ``[z_1..z_n, z_1'..z_n']`` (m, m/s), the input ``u`` of the vehicle plant.

    Raises
    ------
    OptionError
        Non-positive speed, rate or duration.
    ShapeError
        Empty ``x_axles``.
    SignalError
        The run leaves the profile (the message gives the length needed).
    """
    xa = np.asarray(x_axles, dtype=float).ravel()
    if xa.size == 0:
        msg = "x_axles: expected at least one wheelset position, got none"
        raise ShapeError(msg)
    for name, v in (("speed", speed), ("fs_hz", fs_hz), ("duration_s", duration_s)):
        if not (math.isfinite(v) and v > 0.0):
            msg = f"{name}: expected a positive finite value, got {v!r}"
            raise OptionError(msg)
    nt = round(duration_s * fs_hz) + 1
    t = np.arange(nt) / fs_hz
    s0 = start_m - float(xa.min())
    need = s0 + speed * t[-1] + float(xa.max())
    if start_m < profile.x[0] or need > profile.x[-1]:
        msg = (f"profile: expected to cover track coordinates [{start_m:.2f}, {need:.2f}] m, "
               f"got [{profile.x[0]:.2f}, {profile.x[-1]:.2f}] m")
        raise SignalError(msg)
    out = np.empty((2 * xa.size, nt))
    for a, x in enumerate(xa):
        s = s0 + speed * t + x
        out[a] = np.interp(s, profile.x, profile.z)
        out[xa.size + a] = speed * np.interp(s, profile.x, profile.dzdx)  # dz/dt = v dz/dx
    return out
