"""Drive signals: band-limited random, periodic chirp, multisine, impact, record playback.

Every generator returns an array of shape (n_channels, n_samples) in SI units and takes a
seeded ``numpy.random.Generator`` where it is random, so a run can be repeated exactly.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy import signal

from modal_twin._types import FloatArray
from modal_twin.errors import ConfigError, OptionError, SignalError
from modal_twin.models.array_files import npz_arrays, read_csv_numbers
from modal_twin.validation import check_array_budget, check_field

__all__ = [
    "band_limited_random",
    "chirp",
    "earthquake_like",
    "impact",
    "load_record",
    "multisine",
    "resample_record",
]


def _n_samples(duration_s: float, fs_hz: float) -> int:
    if not (np.isfinite(duration_s) and duration_s > 0 and np.isfinite(fs_hz) and fs_hz > 0):
        msg = f"duration_s and fs_hz: expected positive, got {duration_s!r}, {fs_hz!r}"
        raise OptionError(msg)
    return round(duration_s * fs_hz)


def _check_band(f_min_hz: float, f_max_hz: float, fs_hz: float) -> None:
    if not 0 <= f_min_hz < f_max_hz < fs_hz / 2:
        msg = (
            f"band: expected 0 <= f_min_hz < f_max_hz < fs_hz / 2 = {fs_hz / 2}, got "
            f"[{f_min_hz}, {f_max_hz}]"
        )
        raise OptionError(msg)


def band_limited_random(
    n_channels: int,
    duration_s: float,
    fs_hz: float,
    *,
    f_min_hz: float,
    f_max_hz: float,
    rms: float | FloatArray = 1.0,
    rng: np.random.Generator,
) -> FloatArray:
    """Gaussian random signals with a flat spectrum in [f_min_hz, f_max_hz].

    Built in the frequency domain (unit-modulus random-phase lines with Rayleigh amplitudes
    inside the band, zero outside) and scaled to the requested RMS per channel.
    """
    n = _n_samples(duration_s, fs_hz)
    _check_band(f_min_hz, f_max_hz, fs_hz)
    f = np.fft.rfftfreq(n, 1.0 / fs_hz)
    band = (f >= f_min_hz) & (f <= f_max_hz)
    if not band.any():
        msg = f"band [{f_min_hz}, {f_max_hz}] Hz holds no line at resolution {fs_hz / n} Hz"
        raise OptionError(msg)
    spec = np.zeros((n_channels, f.size), dtype=np.complex128)
    spec[:, band] = rng.normal(size=(n_channels, band.sum())) + 1j * rng.normal(
        size=(n_channels, band.sum())
    )
    x = np.fft.irfft(spec, n=n, axis=-1)
    x *= np.reshape(np.asarray(rms, dtype=float), (-1, 1)) / x.std(axis=-1, keepdims=True)
    return x


def chirp(
    duration_s: float, fs_hz: float, *, f_min_hz: float, f_max_hz: float, amplitude: float = 1.0
) -> FloatArray:
    """One linear sweep from f_min_hz to f_max_hz (scipy.signal.chirp), shape (1, n)."""
    n = _n_samples(duration_s, fs_hz)
    _check_band(f_min_hz, f_max_hz, fs_hz)
    t = np.arange(n) / fs_hz
    return amplitude * signal.chirp(t, f_min_hz, duration_s, f_max_hz)[None, :]


def multisine(
    duration_s: float,
    fs_hz: float,
    *,
    f_min_hz: float,
    f_max_hz: float,
    rms: float = 1.0,
    rng: np.random.Generator,
) -> FloatArray:
    """Random-phase multisine on every FFT line in the band (periodic in the record)."""
    x = band_limited_random(1, duration_s, fs_hz, f_min_hz=f_min_hz, f_max_hz=f_max_hz,
                            rms=1.0, rng=rng)
    spec = np.fft.rfft(x, axis=-1)
    nz = np.abs(spec) > 0
    spec[nz] = np.exp(1j * np.angle(spec[nz]))
    out = np.fft.irfft(spec, n=x.shape[-1], axis=-1)
    return rms * out / out.std()


def impact(
    duration_s: float, fs_hz: float, *, peak: float, width_s: float, at_s: float = 0.0
) -> FloatArray:
    """Half-sine hammer pulse of ``peak`` (N) and ``width_s`` starting at ``at_s``."""
    n = _n_samples(duration_s, fs_hz)
    t = np.arange(n) / fs_hz - at_s
    on = (t >= 0) & (t <= width_s)
    out = np.zeros((1, n))
    out[0, on] = peak * np.sin(np.pi * t[on] / width_s)
    return out


def hammer_pulse(n: int, fs_hz: float, *, peak_n: float, tip_stiffness_n_m: float,
                 hammer_mass_kg: float, at_s: float = 0.0) -> FloatArray:
    r"""Force of one hit: a half sine of ``peak_n`` lasting ``pi sqrt(m_h / k_t)`` from ``at_s``.

    Parameters
    ----------
    n : int
        Samples of the returned force.
    fs_hz : float
        Sample rate.
    peak_n : float
        Peak force in N.
    tip_stiffness_n_m, hammer_mass_kg : float
        Contact stiffness of the tip and mass of the hammer head: the contact lasts
        :math:`T_c = \pi \sqrt{m_h / k_t}` (a mass on a spring for half a period).
    at_s : float
        Time the contact starts.

    Returns
    -------
    (n,) array of the force in N.
    """
    if not (tip_stiffness_n_m > 0 and hammer_mass_kg > 0 and fs_hz > 0):
        msg = (f"hammer: expected positive tip stiffness, mass and rate, got "
               f"{tip_stiffness_n_m}, {hammer_mass_kg}, {fs_hz}")
        raise OptionError(msg)
    tc = np.pi * np.sqrt(hammer_mass_kg / tip_stiffness_n_m)
    t = np.arange(n) / fs_hz - at_s
    on = (t >= 0) & (t <= tc)
    out = np.zeros(n)
    out[on] = peak_n * np.sin(np.pi * t[on] / tc)
    return out


def load_record(path: str | Path) -> tuple[FloatArray, float, list[str]]:
    """Read an acceleration record from ``.npz`` or ``.csv``.

    ``.npz``: keys ``data`` (n_ch, n), ``fs_hz``, optional ``channels``; ``.csv``: first
    column time in s, one column per channel, header row of channel names.

    Returns
    -------
    data : ndarray (n_channels, n_samples), fs_hz : float, channels : list of str
    """
    p = Path(path)
    if not p.is_file():
        msg = f"record {p}: no such file"
        raise ConfigError(msg)
    if p.suffix == ".npz":
        z = npz_arrays(p, keys=("data", "fs_hz", "channels"))
        if "data" not in z or "fs_hz" not in z:
            msg = f"record {p}: expected keys 'data' and 'fs_hz', found {sorted(z)}"
            raise ConfigError(msg)
        if z["data"].dtype.kind not in "iuf" or z["fs_hz"].size != 1:
            msg = (f"record {p}: expected real 'data' and one 'fs_hz', got "
                   f"{z['data'].dtype} data and {z['fs_hz'].size} rates")
            raise ConfigError(msg)
        data = np.atleast_2d(np.asarray(z["data"], dtype=float))
        fs = float(z["fs_hz"].ravel()[0])
        names = [str(c) for c in np.atleast_1d(z["channels"])] if "channels" in z else [
            f"ch{i}" for i in range(data.shape[0])]
    elif p.suffix == ".csv":
        head, table = read_csv_numbers(p, lambda rows: 1)
        if table.shape[0] < 2 or table.shape[1] < 2:
            msg = f"record {p}: expected a time column and a channel, at least 2 rows"
            raise ConfigError(msg)
        t, data = table[:, 0], table[:, 1:].T
        dt = np.diff(t)
        if dt.size == 0 or np.any(dt <= 0) or np.ptp(dt) > 1e-6 * dt.mean():
            msg = f"record {p}: the time column must increase with a constant step"
            raise ConfigError(msg)
        fs = 1.0 / float(dt.mean())
        names = [c.strip() for c in head[0][1:]]
    else:
        msg = f"record {p}: unknown format {p.suffix!r}; expected .npz or .csv"
        raise ConfigError(msg)
    fs = check_field(fs, f"record {p}: sample rate", "sample_rate_hz")
    if not np.all(np.isfinite(data)):
        bad = np.argwhere(~np.isfinite(data))[0]
        msg = f"record {p}: non-finite sample in channel {names[bad[0]]} at index {bad[1]}"
        raise SignalError(msg)
    return data, fs, names


def resample_record(data: FloatArray, fs_in_hz: float, fs_out_hz: float) -> FloatArray:
    """Resample a record to the drive rate (polyphase, anti-aliased)."""
    from fractions import Fraction

    r = Fraction(fs_out_hz / fs_in_hz).limit_denominator(1000)
    check_array_budget((data.shape[0], data.shape[-1] * r.numerator // r.denominator + 1),
                       "resampled record")
    return signal.resample_poly(data, r.numerator, r.denominator, axis=-1)


def earthquake_like(
    duration_s: float,
    fs_hz: float,
    *,
    pga: float,
    rng: np.random.Generator,
    f_g_hz: float = 2.5,
    zeta_g: float = 0.6,
    t_rise_s: float | None = None,
    t_strong_s: float | None = None,
) -> FloatArray:
    """Synthesise a ground acceleration, shape (1, n), scaled to the peak ``pga`` (m/s^2).

    Kanai-Tajimi filtered white noise under a Jennings-type envelope (quadratic rise, strong
    phase, exponential decay).

    The Kanai-Tajimi filter ``H(s) = (2 zeta_g w_g s + w_g^2) / (s^2 + 2 zeta_g w_g s +
    w_g^2)`` gives the soil-filtered spectrum; a 0.1 Hz high-pass removes drift.
    """
    n = _n_samples(duration_s, fs_hz)
    t = np.arange(n) / fs_hz
    t1 = 0.1 * duration_s if t_rise_s is None else t_rise_s
    t2 = t1 + (0.4 * duration_s if t_strong_s is None else t_strong_s)
    env = np.where(t < t1, (t / t1) ** 2, np.where(t < t2, 1.0, np.exp(-3.0 * (t - t2) /
                                                                       (duration_s - t2))))
    w = rng.standard_normal(n)
    wg = 2 * np.pi * f_g_hz
    b, a = signal.bilinear([2 * zeta_g * wg, wg**2], [1.0, 2 * zeta_g * wg, wg**2], fs=fs_hz)
    x = signal.lfilter(b, a, w) * env
    sos = signal.butter(2, 0.1, "highpass", fs=fs_hz, output="sos")
    x = signal.sosfiltfilt(sos, x)
    return (pga * x / np.max(np.abs(x)))[None, :]
