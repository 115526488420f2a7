"""Ride of the 3D vehicle: floor accelerations, Sperling indices, floor PSDs ([002] Sec. 5).

A run draws a German track of the chosen level (:mod:`modal_twin.models.track3d`), runs
the vehicle (:class:`modal_twin.models.vehicle3d.Vehicle3D`) over it at a constant speed
and evaluates, at each floor point of [002] (above the bogie centres and mid-car), the
Sperling indices Wz and Wy (:func:`modal_twin.models.ride.sperling_index`, vertical and
lateral weighting) and the Welch PSDs with their peaks (:func:`modal_twin.models.ride.
floor_psd`). The carbody-shaking check of [002] Sec. 5 reads the PSD peaks beside the
carbody's modes of the coupled vehicle (:func:`carbody_modes`: rigid ones for a rigid
carbody) and the hunting (kinematic) mode, whose frequency moves with speed.

Spectral theory of the same run (:func:`floor_psd_theory`), to check the simulation: for
each independent irregularity component ``c`` (vertical, cross level, alignment) with
spatial PSD ``S_c(Omega)``, the temporal one-sided PSD is ``S_c(2 pi f / V) 2 pi / V``
(per Hz), wheelset ``a`` sees it delayed by ``tau_a = (x_1 - x_a) / V``, and the floor
output PSD is::

    S_y(f) = sum_c |G_c(f)|^2 S_c(2 pi f / V) 2 pi / V,
    G_c = sum_a exp(-i w tau_a) (H_{y, u_ca}(w) + i w H_{y, u'_ca}(w)),  w = 2 pi f

with ``H(w) = C_y (i w I - A)^-1 B + D_y`` of the vehicle's state space. The flexible
carbody's resonance in it (:func:`bending_peak`): the largest ``S_y`` within a band about
the coupled car's first vertical bending, on a fine grid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from modal_twin._types import ComplexArray, FloatArray
from modal_twin.errors import OptionError
from modal_twin.models.carbody_shell import shell_mode_labels
from modal_twin.models.ride import FloorPSD, floor_psd, sperling_index
from modal_twin.models.track import german_vertical_psd
from modal_twin.models.track3d import (
    german_alignment_psd,
    german_cross_level_psd,
    german_spectrum,
    random_track_3d,
    track_inputs_3d,
)
from modal_twin.models.vehicle3d import N_AXLES, N_U, Vehicle3D

__all__ = [
    "BendingPeak",
    "CarbodyMode",
    "RideResult",
    "bending_peak",
    "carbody_mode_shapes",
    "carbody_modes",
    "floor_psd_theory",
    "ride_run",
]

MAX_DURATION_S = 1200.0
"""Longest run accepted, s (memory: 24 inputs at the rate over the run)."""

_CAR_LABELS = {"car_x": "surge", "car_y": "sway", "car_z": "bounce", "car_roll": "roll",
               "car_pitch": "pitch", "car_yaw": "yaw"}


@dataclass(frozen=True, slots=True)
class CarbodyMode:
    """A mode of the coupled vehicle dominated by the carbody.

    Attributes
    ----------
    label : str
        The carbody coordinate with the largest share (bounce, pitch, sway, roll, yaw,
        surge; a flexible carbody's coordinate by its name, e.g. ``bending1``; the shell
        carbody's mode type, e.g. ``vertical bending 1``).
    f_hz, zeta : float
        Damped frequency (Hz) and damping ratio.
    share : float
        Share of the mode's kinetic energy in the carbody.
    """

    label: str
    f_hz: float
    zeta: float
    share: float


def carbody_modes(vehicle: Vehicle3D, speed: float, *, min_share: float = 0.5,
                  f_min_hz: float = 0.1) -> tuple[CarbodyMode, ...]:
    """Oscillatory modes with at least ``min_share`` of their kinetic energy in the carbody.

    As :func:`carbody_mode_shapes`, without the shapes.
    """
    return carbody_mode_shapes(vehicle, speed, min_share=min_share, f_min_hz=f_min_hz)[0]


def carbody_mode_shapes(vehicle: Vehicle3D, speed: float, *, min_share: float = 0.5,
                        f_min_hz: float = 0.1) -> tuple[tuple[CarbodyMode, ...], ComplexArray]:
    """Carbody-dominated modes and their shapes (vehicle coordinates, one column each).

    Oscillatory modes with at least ``min_share`` of their kinetic energy in the carbody.

    Energy share ``x_c^H M_cc x_c / x^H M x`` of the mode shape ``x`` (displacements);
    the label is the carbody coordinate of the largest kinetic energy ``M_ii |x_i|^2``,
    or, for the shell carbody, the type named from the recovered shape
    (:func:`modal_twin.models.carbody_shell.shell_mode_labels`: ``bounce`` ... ``yaw``,
    ``diamond 1``, ``vertical bending 1`` ...).
    Modes below ``f_min_hz`` (the car's slow lateral drift at a crawl) are left out. Sorted
    by frequency.
    """
    A, _ = vehicle.state_space(speed)
    lam, X = np.linalg.eig(A)
    nc = vehicle.carbody.n
    Xq = X[: vehicle.n_dof]
    M = vehicle.M
    total = np.einsum("ij,ik,kj->j", Xq.conj(), M, Xq).real
    car = np.einsum("ij,ik,kj->j", Xq[:nc].conj(), M[:nc, :nc], Xq[:nc]).real
    share = car / total
    Ed = np.diag(M)[:nc, None] * np.abs(Xq[:nc]) ** 2
    out = []
    sel = np.flatnonzero((lam.imag > 2.0 * math.pi * f_min_hz) & (share >= min_share))
    shell = shell_mode_labels(vehicle.carbody, lam[sel].imag / (2 * math.pi), Xq[:nc, sel])
    for j, i in enumerate(sel):
        name = vehicle.dof_names[int(np.argmax(Ed[:, i]))]
        label = _CAR_LABELS.get(name, name.removeprefix("car_")) if shell is None else shell[j]
        out.append(CarbodyMode(label, float(lam[i].imag / (2 * math.pi)),
                               float(-lam[i].real / abs(lam[i])), float(share[i])))
    order = sorted(range(len(out)), key=lambda j: out[j].f_hz)
    return tuple(out[j] for j in order), Xq[:, sel[order]] if order else Xq[:, :0]


@dataclass(frozen=True, slots=True)
class RideResult:
    """One ride run.

    Attributes
    ----------
    speed_kmh, duration_s, fs_hz : float
    level : str
        Track spectrum level.
    channels : tuple of str
        Floor channels ``floor_<label>_z`` / ``_y``.
    W : (n_ch,) float array
        Sperling index of each channel (Wz for ``_z``, Wy for ``_y``).
    psd : FloorPSD
        Welch PSDs of the channels and their peaks.
    acc : (n_ch, nt) float array
        Floor accelerations, m/s^2.
    modes : tuple of CarbodyMode
        Carbody modes of the coupled vehicle at this speed.
    kinematic : (float, float)
        Damping ratio and frequency (Hz) of the least-damped kinematic mode.
    """

    speed_kmh: float
    duration_s: float
    fs_hz: float
    level: str
    channels: tuple[str, ...]
    W: FloatArray
    psd: FloorPSD
    acc: FloatArray
    modes: tuple[CarbodyMode, ...]
    kinematic: tuple[float, float]

    def index(self, channel: str) -> float:
        """Sperling index of ``channel`` (e.g. ``floor_mid_z``)."""
        if channel not in self.channels:
            msg = f"channel: expected one of {list(self.channels)}, got {channel!r}"
            raise OptionError(msg)
        return float(self.W[self.channels.index(channel)])


def ride_run(vehicle: Vehicle3D, speed_kmh: float, *, duration_s: float = 60.0,
             fs_hz: float = 400.0, level: str = "low", seed: int = 0) -> RideResult:
    """Run the vehicle over a random German track and evaluate the ride (module docstring).

    Parameters
    ----------
    vehicle : Vehicle3D
    speed_kmh : float
    duration_s : float
        Record length, s (at least one 5 s Sperling segment, at most
        :data:`MAX_DURATION_S`).
    fs_hz : float
        Sample rate, Hz (at least 100 Hz: the weighting reaches 40 Hz).
    level : {"low", "high"}
    seed : int
        Random phases of the track.

    Raises
    ------
    OptionError
        Bad speed, duration, rate or level, or a speed where the linear vehicle is unstable
        (above the hunting critical speed: the motion grows without bound).
    """
    german_spectrum(level)
    if not (math.isfinite(speed_kmh) and 1.0 <= speed_kmh <= 1000.0):
        msg = f"speed_kmh: expected 1 .. 1000 km/h, got {speed_kmh!r}"
        raise OptionError(msg)
    if not (math.isfinite(duration_s) and 5.0 <= duration_s <= MAX_DURATION_S):
        msg = f"duration_s: expected 5 .. {MAX_DURATION_S:g} s, got {duration_s!r}"
        raise OptionError(msg)
    if not (math.isfinite(fs_hz) and 100.0 <= fs_hz <= 2000.0):
        msg = f"fs_hz: expected 100 .. 2000 Hz, got {fs_hz!r}"
        raise OptionError(msg)
    V = speed_kmh / 3.6
    if not vehicle.is_stable(V):
        msg = (f"speed_kmh: {speed_kmh:g} km/h is above the hunting critical speed (an "
               f"eigenvalue has a positive real part): no ride to evaluate")
        raise OptionError(msg)
    x = vehicle.spec.axle_x
    length = V * duration_s + (max(x) - min(x)) + 130.0
    track = random_track_3d(length, level=level, rng=seed)
    w = track_inputs_3d(track, x, V, fs_hz, duration_s)
    run = vehicle.simulate(w, fs_hz, V)
    W = np.array([sperling_index(a, fs_hz, direction="vertical" if n.endswith("_z")
                                 else "lateral").W
                  for n, a in zip(run.floor_names, run.floor, strict=True)])
    return RideResult(speed_kmh=float(speed_kmh), duration_s=float(duration_s),
                      fs_hz=float(fs_hz), level=level, channels=run.floor_names, W=W,
                      psd=floor_psd(run.floor, fs_hz), acc=run.floor,
                      modes=carbody_modes(vehicle, V), kinematic=vehicle.least_damped(V))


def floor_psd_theory(vehicle: Vehicle3D, speed: float, f_hz: FloatArray, *,
                     level: str = "low",
                     wavelength_band_m: tuple[float, float] = (1.0, 120.0)) -> FloatArray:
    """One-sided floor-acceleration PSDs by spectral theory (module docstring).

    Parameters
    ----------
    vehicle : Vehicle3D
    speed : float
        m/s.
    f_hz : (n_f,) float array
        Frequencies, Hz (> 0).
    level : {"low", "high"}
    wavelength_band_m : (float, float)
        The wavelengths the track holds (as drawn by :func:`ride_run`), m.

    Returns
    -------
    (n_ch, n_f) float array
        (m/s^2)^2/Hz, channels as :meth:`Vehicle3D.floor_outputs`.
    """
    c = german_spectrum(level)
    f = np.asarray(f_hz, dtype=float)
    A, B = vehicle.state_space(speed)
    Cy, Dy, _ = vehicle.floor_outputs(A, B)
    x = np.asarray(vehicle.spec.axle_x)
    tau = (x[0] - x) / speed
    Om = 2.0 * math.pi * f / speed
    short, long_ = wavelength_band_m
    inband = (Om >= 2 * math.pi / long_) & (Om <= 2 * math.pi / short)
    spectra = (german_vertical_psd(Om, A_v=c["A_v"], Omega_c=c["Omega_c"], Omega_r=c["Omega_r"]),
               german_cross_level_psd(Om, level), german_alignment_psd(Om, level))
    ns = A.shape[0]
    out = np.zeros((Cy.shape[0], f.size))
    for k, fk in enumerate(f):
        w = 2.0 * math.pi * fk
        H = Cy @ np.linalg.solve(1j * w * np.eye(ns) - A, B) + Dy  # (n_ch, 24)
        for comp, S in enumerate(spectra):
            cols = slice(comp * N_AXLES, (comp + 1) * N_AXLES)
            dcols = slice(N_U + comp * N_AXLES, N_U + (comp + 1) * N_AXLES)
            G = (H[:, cols] + 1j * w * H[:, dcols]) @ np.exp(-1j * w * tau)
            out[:, k] += np.abs(G) ** 2 * S[k] * 2.0 * math.pi / speed * inband[k]
    return out


@dataclass(frozen=True, slots=True)
class BendingPeak:
    """The floor PSD at the carbody's first vertical bending (:func:`bending_peak`).

    Attributes
    ----------
    f_mode_hz : float
        Damped frequency of the coupled car's ``vertical bending 1``, Hz.
    f_peak_hz : float
        Frequency of the largest floor PSD within the band about it, Hz.
    psd_peak : float
        That PSD, (m/s^2)^2/Hz.
    channel : str
    """

    f_mode_hz: float
    f_peak_hz: float
    psd_peak: float
    channel: str


def bending_peak(vehicle: Vehicle3D, speed: float, *, channel: str = "floor_mid_z",
                 level: str = "low", half_band_hz: float = 0.6,
                 df_hz: float = 0.005) -> BendingPeak | None:
    """Floor PSD peak at the first vertical bending by spectral theory (module docstring).

    Parameters
    ----------
    vehicle : Vehicle3D
    speed : float
        m/s.
    channel : str
        Floor channel (``floor_<label>_z`` / ``_y``).
    level : {"low", "high"}
    half_band_hz, df_hz : float
        The band ``f_mode +- half_band_hz`` searched on a grid of ``df_hz``, Hz.

    Returns
    -------
    BendingPeak or None
        None when the carbody has no mode named ``vertical bending 1`` (a rigid carbody).

    Raises
    ------
    OptionError
        Unknown channel.
    """
    modes = carbody_modes(vehicle, speed)
    vb = next((m for m in modes if m.label == "vertical bending 1"), None)
    if vb is None:
        return None
    A, B = vehicle.state_space(speed)
    names = list(vehicle.floor_outputs(A, B)[2])
    if channel not in names:
        msg = f"channel: expected one of {names}, got {channel!r}"
        raise OptionError(msg)
    f = np.arange(vb.f_hz - half_band_hz, vb.f_hz + half_band_hz + 0.5 * df_hz, df_hz)
    S = floor_psd_theory(vehicle, speed, f, level=level)[names.index(channel)]
    k = int(np.argmax(S))
    return BendingPeak(f_mode_hz=vb.f_hz, f_peak_hz=float(f[k]), psd_peak=float(S[k]),
                       channel=channel)
