"""Track irregularity in three components: vertical profile, lateral alignment, cross level.

German high-speed track spectra (W. Zhai, *Vehicle-Track Coupled Dynamics*, Springer
2020, Ch. 3, Eqs. (3.7)-(3.9) and Table 3.2; the family of :mod:`modal_twin.models.track`),
one-sided in the spatial angular frequency ``Omega`` (rad/m)::

    vertical profile  S_v = A_v Omega_c^2 / ((Omega^2 + Omega_r^2)(Omega^2 + Omega_c^2))
    alignment         S_a = A_a Omega_c^2 / ((Omega^2 + Omega_r^2)(Omega^2 + Omega_c^2))
    cross level       S_c = (A_v / b^2) Omega_c^2 Omega^2
                            / ((Omega^2 + Omega_r^2)(Omega^2 + Omega_c^2)(Omega^2 + Omega_s^2))

with ``b = 0.75 m`` and, for the low- and high-interference tracks,

=========  ============  ============  ==========  ==========  ==========
level      A_v (m rad)   A_a (m rad)   Omega_c     Omega_r     Omega_s
=========  ============  ============  ==========  ==========  ==========
low        4.032e-7      2.119e-7      0.8246      0.0206      0.4380
high       10.80e-7      6.125e-7      0.8246      0.0206      0.4380
=========  ============  ============  ==========  ==========  ==========

``S_v`` and ``S_a`` are in m^2/(rad/m). ``S_c`` is read here as the spectrum of the
cross-level **angle** ``phi`` (rad^2/(rad/m), the roll of the track plane; the rails'
height difference is ``2 b phi``). The three components are drawn independently (random
phases, :func:`modal_twin.models.track.random_profile`).

Wheelset inputs: wheelset ``a`` at ``x_a`` from the carbody centre sees the leading
wheelset's input delayed by ``(x_lead - x_a) / V`` (same track points,
:func:`modal_twin.models.track.wheelset_inputs`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.errors import OptionError
from modal_twin.models.track import TrackProfile, random_profile, wheelset_inputs

__all__ = [
    "GERMAN_SPECTRA",
    "Track3D",
    "TrackLevel",
    "german_alignment_psd",
    "german_cross_level_psd",
    "german_spectrum",
    "random_track_3d",
    "track_inputs_3d",
]

TrackLevel = Literal["low", "high"]

GERMAN_SPECTRA: dict[str, dict[str, float]] = {
    "low": {"A_v": 4.032e-7, "A_a": 2.119e-7, "Omega_c": 0.8246, "Omega_r": 0.0206,
            "Omega_s": 0.4380, "b": 0.75},
    "high": {"A_v": 10.80e-7, "A_a": 6.125e-7, "Omega_c": 0.8246, "Omega_r": 0.0206,
             "Omega_s": 0.4380, "b": 0.75},
}
"""Coefficients of the German low- and high-interference spectra (module docstring)."""


def german_spectrum(level: str) -> dict[str, float]:
    """Coefficients of ``level`` ("low" or "high").

    Raises
    ------
    OptionError
        Unknown level.
    """
    if level not in GERMAN_SPECTRA:
        msg = f"level: expected one of {list(GERMAN_SPECTRA)}, got {level!r}"
        raise OptionError(msg)
    return GERMAN_SPECTRA[level]


def _base(Om: FloatArray, c: dict[str, float]) -> FloatArray:
    return np.asarray(c["Omega_c"] ** 2 / ((Om**2 + c["Omega_r"] ** 2)
                                           * (Om**2 + c["Omega_c"] ** 2)))


def german_alignment_psd(omega: FloatArray | float, level: str = "low") -> FloatArray:
    """One-sided alignment PSD ``S_a(Omega)``, m^2/(rad/m) (module docstring).

    Examples
    --------
    >>> print(f"{german_alignment_psd(0.0):.4e}")
    4.9934e-04
    """
    c = german_spectrum(level)
    Om = np.asarray(omega, dtype=float)
    return np.asarray(c["A_a"] * _base(Om, c))


def german_cross_level_psd(omega: FloatArray | float, level: str = "low") -> FloatArray:
    """One-sided cross-level-angle PSD ``S_c(Omega)``, rad^2/(rad/m) (module docstring).

    Examples
    --------
    >>> print(f"{german_cross_level_psd(0.0):.1f}")
    0.0
    """
    c = german_spectrum(level)
    Om = np.asarray(omega, dtype=float)
    return np.asarray(c["A_v"] / c["b"] ** 2 * _base(Om, c) * Om**2
                      / (Om**2 + c["Omega_s"] ** 2))


@dataclass(frozen=True, slots=True)
class Track3D:
    """Three independent irregularity components along the same track coordinate.

    Attributes
    ----------
    vertical : TrackProfile
        Vertical profile ``z`` (m), mean of the two rails.
    alignment : TrackProfile
        Lateral alignment ``y_a`` (m), + to the left.
    cross_level : TrackProfile
        Cross-level angle ``phi`` (rad), + when the right rail is lower (roll about +x).
    level : str
        Spectrum level.
    """

    vertical: TrackProfile
    alignment: TrackProfile
    cross_level: TrackProfile
    level: str


def random_track_3d(length_m: float, *, level: str = "low", dx_m: float = 0.05,
                    wavelength_band_m: tuple[float, float] = (1.0, 120.0),
                    rng: np.random.Generator | int | None = None) -> Track3D:
    """Draw the three components of a German spectrum of ``level`` (module docstring).

    Parameters
    ----------
    length_m, dx_m, wavelength_band_m
        As :func:`modal_twin.models.track.random_profile`.
    level : {"low", "high"}
    rng : Generator or int, optional

    Returns
    -------
    Track3D

    Raises
    ------
    OptionError
        Unknown level, or the profile options of ``random_profile``.
    """
    c = german_spectrum(level)
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    band = wavelength_band_m
    vert = random_profile(length_m, dx_m=dx_m, wavelength_band_m=band, rng=gen,
                          A_v=c["A_v"], Omega_c=c["Omega_c"], Omega_r=c["Omega_r"])
    align = random_profile(length_m, dx_m=dx_m, wavelength_band_m=band, rng=gen,
                           psd=lambda Om: german_alignment_psd(Om, level))
    cross = random_profile(length_m, dx_m=dx_m, wavelength_band_m=band, rng=gen,
                           psd=lambda Om: german_cross_level_psd(Om, level))
    return Track3D(vertical=vert, alignment=align, cross_level=cross, level=level)


def track_inputs_3d(track: Track3D, x_axles: Sequence[float], speed: float, fs_hz: float,
                    duration_s: float, *, start_m: float = 0.0) -> FloatArray:
    """Irregularities and their rates under each wheelset, delayed by axle spacing / V.

    Returns
    -------
    (6 n_axles, nt) float array
        ``[z_1..z_n, phi_1..phi_n, ya_1..ya_n, z'_1.., phi'_1.., ya'_1..]`` (m, rad, m
        and per second), the input ``[u; u']`` of :class:`modal_twin.models.vehicle3d.
        Vehicle3D`.

    Raises
    ------
    SignalError, OptionError, ShapeError
        As :func:`modal_twin.models.track.wheelset_inputs`.
    """
    n = len(x_axles)
    parts = [wheelset_inputs(p, x_axles, speed, fs_hz, duration_s, start_m=start_m)
             for p in (track.vertical, track.cross_level, track.alignment)]
    return np.vstack([p[:n] for p in parts] + [p[n:] for p in parts])
