"""Settings of an identification run chosen from the record, and checks of its result.

Nothing here is a fixed frequency: the band comes from the record's spectrum (and the
anti-alias / band-pass corners the file states), the horizon from the lowest frequency
of that band, the orders from the number of outputs and the horizon.

- **Band** ``(f_lo, f_hi)``: ``f_hi`` is ``margin`` (1.25) x the frequency below which
  ``energy`` (80 %) of the summed, channel-normalised output PSD (Welch, mean removed)
  lies (a weaker mode just above it stays in), at most 0.8 x Nyquist and the
  stated low-pass corner; ``f_lo`` is the larger of the stated high-pass corner and
  ``n_cycles / T`` (20 cycles of the lowest mode in the record, so that its correlations
  are estimated at all).
- **Decimation** ``q = floor(fs / (2.5 f_hi))``: the new Nyquist is 1.25 f_hi, inside
  the 0.8 pass band of :func:`modal_twin.acquisition.decimation.decimate`.
- **Block rows** ``i = ceil(fs_q / (4 f_lo))`` (the past horizon spans a quarter period
  of the lowest mode, as the default of :func:`~modal_twin.identification.n4sid.n4sid`
  with ``f_min``), at least ``ceil((n_max + 1) / n_out) + 1`` and at most what keeps
  ``i (n_in + n_out) <= 600`` and twice as many Hankel columns as rows
  (``n_samples >= 2 i (1 + 2 (n_in + n_out))``).
- **Orders** ``2, 4, ..., n_max`` with ``n_max = min(60, n_out (i - 1))``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.signal as sig

from modal_twin._types import FloatArray
from modal_twin.identification.modal_model import ModalModel, StabilizationDiagram

__all__ = ["AutoSettings", "choose_settings", "drifting_modes", "rms_spread"]


@dataclass(frozen=True, slots=True)
class AutoSettings:
    """What an identification run uses, with the reason printed by the command.

    Attributes
    ----------
    band_hz : (float, float)
        Analysis band.
    factor : int
        Decimation factor.
    fs_hz : float
        Sample rate after decimation.
    block_rows : int
    orders : tuple of int
    """

    band_hz: tuple[float, float]
    factor: int
    fs_hz: float
    block_rows: int
    orders: tuple[int, ...]

    def describe(self) -> str:
        """One line for the command's output."""
        return (f"band {self.band_hz[0]:.3g}-{self.band_hz[1]:.3g} Hz, decimation x"
                f"{self.factor} -> {self.fs_hz:.4g} Hz, block rows {self.block_rows}, "
                f"orders {self.orders[0]}..{self.orders[-1]} step "
                f"{self.orders[1] - self.orders[0] if len(self.orders) > 1 else 0}")


def _energy_band(y: FloatArray, fs_hz: float, energy: float) -> float:
    nper = min(y.shape[1], max(256, 2 ** int(np.log2(max(y.shape[1] // 8, 2)))))
    f, P = sig.welch(y - y.mean(axis=1, keepdims=True), fs=fs_hz, nperseg=nper, axis=-1)
    p = (P / np.maximum(P.sum(axis=1, keepdims=True), 1e-300)).sum(axis=0)
    c = np.cumsum(p) / p.sum()
    return float(f[min(int(np.searchsorted(c, energy)), f.size - 1)])


def choose_settings(y: FloatArray, fs_hz: float, n_in: int, *,
                    f_max_hz: float | None = None, corners_hz: tuple[float, float] | None
                    = None, energy: float = 0.8, margin: float = 1.25, n_cycles: float = 20.0
                    ) -> AutoSettings:
    """Band, decimation, block rows and orders for a record (module docstring).

    Parameters
    ----------
    y : ndarray, shape (n_out, n_samples)
        Outputs at ``fs_hz``.
    n_in : int
        Number of inputs (0 for output-only).
    f_max_hz : float, optional
        Upper band edge given by the user (replaces the spectral one).
    corners_hz : (float, float), optional
        Band-pass corners stated by the data file (NaN when not stated).
    """
    n_out, n = y.shape
    T = n / fs_hz
    lo_c, hi_c = corners_hz if corners_hz is not None else (math.nan, math.nan)
    f_hi = f_max_hz if f_max_hz is not None else margin * _energy_band(y, fs_hz, energy)
    f_hi = min(f_hi, 0.8 * fs_hz / 2, hi_c if math.isfinite(hi_c) else math.inf)
    f_lo = max(n_cycles / T, lo_c if math.isfinite(lo_c) else 0.0)
    f_hi = max(f_hi, 2.0 * f_lo)
    q = max(1, int(fs_hz // (2.5 * f_hi)))
    fs_q = fs_hz / q
    n_q = n // q
    n_ch = max(n_in + n_out, 1)
    i_max = max(2, min(600 // n_ch, (n_q - 2) // (4 * n_ch + 2)))
    i = max(math.ceil(fs_q / (4.0 * f_lo)), 4)
    i = min(i, i_max)
    n_max = max(2, min(60, n_out * (i - 1)))
    i = max(i, min(math.ceil((n_max + 1) / n_out) + 1, i_max))
    n_max = 2 * max(1, min(n_max, n_out * (i - 1)) // 2)
    return AutoSettings((f_lo, f_hi), q, fs_q, i, tuple(range(2, n_max + 1, 2)))


def rms_spread(y: FloatArray, n_windows: int = 8) -> float:
    """Largest over smallest RMS of ``n_windows`` equal windows (summed over channels).

    A stationary record gives a value near 1; an earthquake response (strong shaking
    then decay) gives 10 and more.
    """
    w = np.array_split(y - y.mean(axis=1, keepdims=True), n_windows, axis=1)
    r = np.array([np.sqrt(np.mean(b**2)) for b in w])
    return float(r.max() / max(r.min(), 1e-300))


def drifting_modes(diagram: StabilizationDiagram, modes: ModalModel, *,
                   rel_drift: float | None = None) -> list[tuple[float, float, int, int]]:
    """Modes whose pole column drifts over the model orders.

    For each selected mode the stable poles within ``3 rel_tol_f`` of its frequency are
    taken order by order (the nearest per order); the column drifts when a straight-line
    fit of f against order changes by more than ``rel_drift`` (default the diagram's
    ``rel_tol_f``) relative to f over the orders it spans.

    Returns
    -------
    list of (f_hz, drift_fraction, first_order, last_order)
    """
    tol = diagram.rel_tol_f if rel_drift is None else rel_drift
    out = []
    for fm in modes.f_hz:
        o, f = [], []
        for order, p, s in zip(diagram.orders, diagram.poles, diagram.stable, strict=True):
            near = np.nonzero(s & (np.abs(p.f_hz - fm) <= 3 * diagram.rel_tol_f * fm))[0]
            if near.size:
                k = near[np.argmin(np.abs(p.f_hz[near] - fm))]
                o.append(int(order))
                f.append(float(p.f_hz[k]))
        if len(o) < 3:
            continue
        slope = np.polyfit(o, f, 1)[0]
        drift = abs(slope) * (o[-1] - o[0]) / fm
        if drift > tol:
            out.append((float(fm), float(drift), o[0], o[-1]))
    return out
