"""Inputs (own generators), sensor noise and records of the truth cases.

Building: 6-DOF table accelerations (x, y, 0.3 z), a band-limited random training record,
an earthquake-like held-out record (enveloped filtered noise) and a low-level random record
(1/20 of the training level). Vehicle: a random track profile (band 3-80 m wavelengths)
seen by the four wheelsets with their delays, at two speeds and a low level.
Noise: white Gaussian, ``pct`` % of each clean channel's RMS, seeded; the achieved floor
RMS(noise) / RMS(measured) is returned per channel.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

FloatArray = np.ndarray
_W = np.array([1.0, 1.0, 0.3, 0.0, 0.0, 0.0])


def table_random(seconds: float, fs_hz: float, rms: float, seed: int) -> FloatArray:
    """Band-limited (0.2-20 Hz) Gaussian table accelerations (6, nt), x/y RMS ``rms``."""
    nt = round(seconds * fs_hz)
    rng = np.random.default_rng(seed)
    sos = signal.butter(4, [0.2, 20.0], btype="band", fs=fs_hz, output="sos")
    a = signal.sosfiltfilt(sos, rng.standard_normal((6, nt)), axis=1)
    a /= a.std(axis=1, keepdims=True)
    return a * signal.windows.tukey(nt, 0.1) * (_W * rms)[:, None]


def table_earthquake(seconds: float, fs_hz: float, pga: float, seed: int) -> FloatArray:
    """Earthquake-like table accelerations (6, nt): 0.25-10 Hz noise under a build-up /
    strong / decay envelope, x peak ``pga`` (y 0.8, z 0.3 of it)."""
    nt = round(seconds * fs_hz)
    t = np.arange(nt) / fs_hz
    rng = np.random.default_rng(seed)
    sos = signal.butter(2, [0.25, 10.0], btype="band", fs=fs_hz, output="sos")
    a = signal.sosfiltfilt(sos, rng.standard_normal((6, nt)), axis=1)
    t1, t2 = 0.15 * seconds, 0.5 * seconds
    env = np.where(t < t1, (t / t1) ** 2, np.where(t < t2, 1.0, np.exp(-4.0 * (t - t2)
                                                                     / seconds)))
    a *= env * signal.windows.tukey(nt, 0.05)
    a /= np.abs(a).max(axis=1, keepdims=True)
    return a * (np.array([1.0, 0.8, 0.3, 0.0, 0.0, 0.0]) * pga)[:, None]


def track_inputs(axle_x: tuple[float, ...], speed_kmh: float, seconds: float, fs_hz: float,
                 rms_m: float, seed: int) -> FloatArray:
    """Wheelset inputs (8, nt): irregularity under wheelsets 1-4 (m), then their rates."""
    v = speed_kmh / 3.6
    nt = round(seconds * fs_hz)
    lead = max(axle_x) - min(axle_x) + 5.0
    dx = v / fs_hz / 2.0
    x = np.arange(0.0, v * seconds + lead + 10.0, dx)
    rng = np.random.default_rng(seed)
    sos = signal.butter(2, [1.0 / 80.0, 1.0 / 3.0], btype="band", fs=1.0 / dx, output="sos")
    z = signal.sosfiltfilt(sos, rng.standard_normal(x.size))
    z *= rms_m / z.std() * np.clip(x / 30.0, 0.0, 1.0) ** 2  # run-in from a level track
    t = np.arange(nt) / fs_hz
    front = max(axle_x)
    zt = np.array([np.interp(v * t + lead - (front - a), x, z) for a in axle_x])
    return np.vstack([zt, np.gradient(zt, 1.0 / fs_hz, axis=1)])


@dataclass(frozen=True)
class Noisy:
    """A measured record (the fields of ``modal_twin.diagnosis.record.Record``) and its
    noise floor per channel, RMS(noise) / RMS(measured)."""

    fs_hz: float
    input_names: tuple[str, ...]
    inputs: FloatArray
    channel_names: tuple[str, ...]
    data: FloatArray
    source: str
    noise_floor: FloatArray


def measured(inputs: tuple[str, ...], u: FloatArray, names: tuple[str, ...],
             clean: FloatArray, fs_hz: float, pct: float, seed: int, source: str,
             gains: dict[str, float] | None = None) -> Noisy:
    """Add a sensor gain error (``gains``: channel -> factor) and white noise of ``pct`` %
    of each channel's clean RMS."""
    y = clean.copy()
    for ch, g in (gains or {}).items():
        y[names.index(ch)] *= g
    rng = np.random.default_rng(10_000 + seed)
    rms = np.sqrt(np.mean(y**2, axis=1, keepdims=True))
    noise = rng.standard_normal(y.shape) * rms * pct / 100.0
    meas = y + noise
    floor = np.sqrt(np.mean(noise**2, axis=1)) / np.sqrt(np.mean(meas**2, axis=1))
    return Noisy(fs_hz, inputs, u, names, meas, source, floor)
