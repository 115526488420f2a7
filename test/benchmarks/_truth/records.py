"""Inputs (own generators), sensor noise and records of the truth cases.

Building: 6-DOF table accelerations (x, y, 0.3 z), a band-limited random training record,
an earthquake-like held-out record (enveloped filtered noise) and a low-level random record
(1/20 of the training level). Vehicle: a random track profile (band 3-80 m wavelengths)
seen by the four wheelsets with their delays, at two speeds and a low level.
Noise: white Gaussian, ``pct`` % of each clean channel's RMS (per channel when asked: e.g.
nearly noise-free drift and force channels beside 1-3 % accelerometers), seeded; the
achieved floor RMS(noise) / RMS(measured) is returned per channel. Sensor faults: a gain,
a time delay (:func:`delayed`), the two horizontal axes of a sensor turned
(:func:`rotated`), a reversed polarity (a gain of -1), a zero that creeps (:func:`creeping`:
an offset plus a constant rate from the start of each record, as a charge amplifier's
output drifts with its input's leakage current after each reset), two channels' cables
exchanged (``swaps``).
Other noise forms (issue 20, item 1: simulators written apart add noise in forms we do not
control): coloured noise (:func:`coloured`: 1/f "pink" above 0.05 Hz, or white noise
low-passed by a 2nd-order Butterworth filter) of the same RMS, and an ADC (:func:`adc`)
that rounds each reading to its least significant bit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

FloatArray = np.ndarray
_W = np.array([1.0, 1.0, 0.3, 0.0, 0.0, 0.0])


def table_random(seconds: float, fs_hz: float, rms: float, seed: int,
                 band_hz: tuple[float, float] = (0.2, 20.0)) -> FloatArray:
    """Band-limited (``band_hz``, default 0.2-20 Hz; a narrow band gives a near-harmonic
    drive) Gaussian table accelerations (6, nt), x/y RMS ``rms``."""
    nt = round(seconds * fs_hz)
    rng = np.random.default_rng(seed)
    sos = signal.butter(4, list(band_hz), btype="band", fs=fs_hz, output="sos")
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


def delayed(x: FloatArray, fs_hz: float, tau_s: float) -> FloatArray:
    """``x(t - tau)`` by linear interpolation between samples (zero before the start): the
    reading of a sensor whose clock lags by ``tau``."""
    t = np.arange(x.shape[-1]) / fs_hz
    return np.interp(t - tau_s, t, x, left=0.0)


def rotated(xy: FloatArray, angle_deg: float) -> FloatArray:
    """Readings ``(a_x', a_y')`` of a two-axis sensor turned by ``angle_deg`` about z: its
    axes are the structure's axes rotated, ``a_x' = a . e_x'`` with
    ``e_x' = (cos, sin)``, ``e_y' = (-sin, cos)``."""
    c, s = np.cos(np.radians(angle_deg)), np.sin(np.radians(angle_deg))
    return np.array([c * xy[0] + s * xy[1], -s * xy[0] + c * xy[1]])


def creeping(nt: int, fs_hz: float, offset: float, rate: float) -> FloatArray:
    """What a creeping zero adds to a reading: ``offset + rate * t``, ``t`` from the
    record's first sample (the amplifier is reset when a record starts)."""
    return offset + rate * (np.arange(nt) / fs_hz)


def coloured(white: FloatArray, fs_hz: float, colour: str) -> FloatArray:
    """Rows of ``white`` given a spectral shape, each scaled back to unit variance.

    ``"white"`` returns the rows unchanged; ``"pink"``: PSD ``1 / f`` above 0.05 Hz (flat
    below), shaped in the frequency domain; ``"lowpass:F"``: a 2nd-order Butterworth low-pass
    at ``F`` Hz run forwards and backwards.
    """
    if colour == "white":
        return white
    if colour == "pink":
        f = np.fft.rfftfreq(white.shape[-1], 1.0 / fs_hz)
        z = np.fft.irfft(np.fft.rfft(white, axis=-1) / np.sqrt(np.maximum(f, 0.05)),
                         n=white.shape[-1], axis=-1)
    elif colour.startswith("lowpass:"):
        sos = signal.butter(2, float(colour.partition(":")[2]), fs=fs_hz, output="sos")
        z = signal.sosfiltfilt(sos, white, axis=-1)
    else:
        msg = f"unknown noise colour {colour!r}"
        raise ValueError(msg)
    return z / z.std(axis=-1, keepdims=True)


def adc(x: FloatArray, span: FloatArray, bits: int) -> FloatArray:
    """Readings of an ADC of ``bits`` bits whose full scale per row is ``span`` (from
    ``-span / 2`` to ``+span / 2``): each value rounded to its step ``span / 2**bits`` and
    clipped to the range."""
    q = (np.asarray(span, float) / 2.0**bits)[:, None]
    half = np.asarray(span, float)[:, None] / 2.0
    return np.clip(np.round(x / q) * q, -half, half)


def measured(inputs: tuple[str, ...], u: FloatArray, names: tuple[str, ...],
             clean: FloatArray, fs_hz: float, pct: float, seed: int, source: str,
             gains: dict[str, float] | None = None, *,
             pct_of: dict[str, float] | None = None,
             delays: dict[str, float] | None = None,
             turns: dict[str, float] | None = None,
             drifts: dict[str, tuple[float, float]] | None = None,
             swaps: tuple[tuple[str, str], ...] = (), colour: str = "white",
             adc_bits: int = 0, adc_span: FloatArray | None = None) -> Noisy:
    """Add a sensor gain error (``gains``: channel -> factor) and white noise of ``pct`` %
    of each channel's clean RMS.

    ``pct_of`` (channel -> %) overrides ``pct`` for some channels (e.g. nearly noise-free
    drift and force channels); ``delays`` (channel -> s) delays channels
    (:func:`delayed`); ``turns`` (sensor stem -> degrees) turns the ``_x`` / ``_y`` pair
    of a sensor (:func:`rotated`); ``drifts`` (channel -> (offset, rate per s)) adds a
    creeping zero (:func:`creeping`); ``swaps`` exchanges the readings of two channels
    (their cables crossed). Delays, turns and drifts act on the clean signal, before the
    noise (the noise of a sensor is its own); a swap exchanges the noisy readings.
    ``colour`` shapes the noise's spectrum (:func:`coloured`, same RMS); with ``adc_bits``
    every reading then passes an ADC of that many bits over ``adc_span`` per channel
    (:func:`adc`); the floor returned counts the rounding with the noise.
    """
    y = clean.copy()
    for ch, g in (gains or {}).items():
        y[names.index(ch)] *= g
    for stem, ang in (turns or {}).items():
        ix, iy = names.index(f"{stem}_x"), names.index(f"{stem}_y")
        y[[ix, iy]] = rotated(y[[ix, iy]], ang)
    for ch, tau in (delays or {}).items():
        y[names.index(ch)] = delayed(y[names.index(ch)], fs_hz, tau)
    for ch, (offset, rate) in (drifts or {}).items():
        y[names.index(ch)] += creeping(y.shape[-1], fs_hz, offset, rate)
    rng = np.random.default_rng(10_000 + seed)
    rms = np.sqrt(np.mean(y**2, axis=1, keepdims=True))
    if pct_of:
        level = np.array([pct_of.get(n, pct) for n in names])[:, None]
        noise = coloured(rng.standard_normal(y.shape), fs_hz, colour) * rms * level / 100.0
    else:
        noise = coloured(rng.standard_normal(y.shape), fs_hz, colour) * rms * pct / 100.0
    meas = y + noise
    if adc_bits:
        meas = adc(meas, np.asarray(adc_span), adc_bits)
        noise = meas - y
    for a, b in swaps:
        ia, ib = names.index(a), names.index(b)
        meas[[ia, ib]] = meas[[ib, ia]]
        noise[[ia, ib]] = noise[[ib, ia]]
    floor = np.sqrt(np.mean(noise**2, axis=1)) / np.sqrt(np.mean(meas**2, axis=1))
    return Noisy(fs_hz, inputs, u, names, meas, source, floor)
