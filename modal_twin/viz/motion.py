"""A record's motion on the structure: measured beside the twin, for the 3D view.

The sensors measure accelerations at a few points; to draw the whole structure moving,
each instant's sensor values are expanded onto every node with the model's modes (SEREP,
:func:`~modal_twin.viz.mode_pairs.expand_shapes`), for the measured record and for the
twin's prediction alike, over the record's strongest stretch. Accelerations are turned
into displacements in the frequency domain (``X = -A / omega^2``, nothing below a cut-off
taken from the model's first mode, where double integration only amplifies noise and
drift).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.errors import OptionError
from modal_twin.viz.mode_pairs import expand_shapes

__all__ = ["RecordMotion", "displacement_from_acceleration", "nrmse_per_sensor",
           "record_motion", "strongest_window"]


def displacement_from_acceleration(acc: FloatArray, fs_hz: float, f_low_hz: float
                                   ) -> FloatArray:
    """Displacement (rows) whose second derivative is ``acc`` above ``f_low_hz``.

    ``X(f) = -A(f) / (2 pi f)^2`` for ``f >= f_low_hz``, 0 below (the record taken as one
    period: its mean and slow drift are not integrated).
    """
    if not f_low_hz > 0:
        msg = f"f_low_hz: expected > 0, got {f_low_hz}"
        raise OptionError(msg)
    a = np.atleast_2d(np.asarray(acc, float))
    n = a.shape[-1]
    f = np.fft.rfftfreq(n, 1.0 / fs_hz)
    gain = np.zeros_like(f)
    keep = f >= f_low_hz
    gain[keep] = -1.0 / (2.0 * np.pi * f[keep]) ** 2
    return np.fft.irfft(np.fft.rfft(a, axis=-1) * gain, n, axis=-1)


def nrmse_per_sensor(channels: Sequence[str], measured: FloatArray, twin: FloatArray
                     ) -> dict[str, float]:
    """Sensor -> RMS(measured - twin) / RMS(measured) of its worst axis.

    Rows are the channels ``<sensor>_<axis>``; a channel that measured nothing scores 0.
    """
    d = measured - twin
    ref = np.sqrt(np.mean(measured ** 2, axis=1))
    rel = np.sqrt(np.mean(d * d, axis=1)) / np.where(ref > 0, ref, 1.0)
    worst: dict[str, float] = {}
    for ch, r in zip(channels, rel, strict=True):
        sensor = ch.rpartition("_")[0]
        worst[sensor] = max(worst.get(sensor, 0.0), float(r))
    return worst


def strongest_window(x: FloatArray, n: int) -> slice:
    """Return the ``n`` consecutive samples of rows ``x`` with the largest summed energy."""
    nt = x.shape[-1]
    if n >= nt:
        return slice(0, nt)
    e = np.concatenate([[0.0], np.cumsum(np.sum(np.atleast_2d(x) ** 2, axis=0))])
    k = int(np.argmax(e[n:] - e[:-n]))
    return slice(k, k + n)


@dataclass(frozen=True, slots=True)
class RecordMotion:
    """Measured and twin node displacements over a stretch of a record.

    Attributes
    ----------
    measured, twin : (n_frames, n_nodes, 3) float arrays
        Node displacements, m (SEREP-expanded from the sensors).
    t0_s, dt_s : float
        Time of the first frame in the record and between frames, s.
    sensor_nrmse : mapping sensor -> float
        RMS(measured - twin) / RMS(measured) over the stretch, worst axis of the sensor (of
        the ``scored`` signals).
    fit : float
        Share of the measured sensor motion the expansion reproduces (1 - relative
        residual of the least-squares fit).
    """

    measured: FloatArray
    twin: FloatArray
    t0_s: float
    dt_s: float
    sensor_nrmse: Mapping[str, float]
    fit: float


def record_motion(channels: Sequence[str], measured: FloatArray, twin: FloatArray, fs_hz: float,
                  basis_at_channels: FloatArray, basis_shapes: FloatArray, *,
                  window_s: float, n_frames: int = 96,
                  scored: tuple[FloatArray, FloatArray] | None = None) -> RecordMotion:
    """Measured and twin motion of the strongest ``window_s`` of a record, on every node.

    Parameters
    ----------
    channels : sequence of str
        Sensor channels ``<sensor>_<axis>`` (rows of ``measured`` and ``twin``).
    measured, twin : (n_ch, nt) float arrays
        Displacements at the channels, m.
    basis_at_channels, basis_shapes : arrays
        Model modes at the channels (n_ch, k) and on every node (k, n_nodes, 3).
    window_s : float
        Length of the stretch shown, s.
    n_frames : int
        Frames drawn over the stretch.
    scored : (measured, twin) arrays like ``measured``, optional
        What the NRMSE per sensor is taken of (e.g. the accelerations the sensors measure);
        default the displacements drawn.
    """
    win = strongest_window(measured, max(2, round(window_s * fs_hz)))
    step = max(1, (win.stop - win.start) // n_frames)
    idx = np.arange(win.start, win.stop, step)
    a_m, *_ = np.linalg.lstsq(basis_at_channels, measured[:, idx], rcond=None)
    fit = 1.0 - float(np.linalg.norm(basis_at_channels @ a_m - measured[:, idx])
                      / (np.linalg.norm(measured[:, idx]) or 1.0))
    m = expand_shapes(measured[:, idx], basis_at_channels, basis_shapes)
    t = expand_shapes(twin[:, idx], basis_at_channels, basis_shapes)
    sm, st = scored if scored is not None else (measured, twin)
    worst = nrmse_per_sensor(channels, sm[:, win], st[:, win])
    return RecordMotion(m, t, win.start / fs_hz, step / fs_hz, worst, fit)
