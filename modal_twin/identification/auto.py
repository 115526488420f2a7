"""Settings of an identification run chosen from the record, and checks of its result.

Nothing here is a fixed frequency: the band comes from the record's spectrum (and the
anti-alias / band-pass corners the file states), the horizon from the lowest frequency
of that band, the orders from the number of outputs and the horizon.

- **Band** ``(f_lo, f_hi)``: ``f_hi`` is ``margin`` (1.25) x the frequency below which
  ``energy`` (99 %) of the summed, channel-normalised output PSD (Welch, mean removed)
  lies (weak higher modes stay in; two events of one structure, whose spectra differ in
  their strong part, get nearly the same edge), at most 0.8 x Nyquist and the stated
  low-pass corner; ``f_lo`` is the larger of the stated high-pass corner and
  ``n_cycles / T`` (20 cycles of the lowest mode in the record, so that its correlations
  are estimated at all).
- **Decimation** ``q = floor(fs / (2.5 f_hi))``: the new Nyquist is 1.25 f_hi, inside
  the 0.8 pass band of :func:`modal_twin.acquisition.decimation.decimate`.
- **Block rows** ``i = ceil(fs_q / (4 f_lo))`` (the past horizon spans a quarter period
  of the lowest mode, as the default of :func:`~modal_twin.identification.n4sid.n4sid`
  with ``f_min``), at least ``ceil((n_max + 1) / n_out) + 1`` and at most what keeps
  ``i (n_in + n_out) <= 1200`` (:data:`HANKEL_ROWS`) and twice as many Hankel columns as rows
  (``n_samples >= 2 i (1 + 2 (n_in + n_out))``).
- **Orders** ``2, 4, ..., n_max`` with ``n_max = min(60, n_out (i - 1))``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.signal as sig

from modal_twin._types import FloatArray
from modal_twin.errors import OptionError
from modal_twin.identification.modal_model import ModalModel, StabilizationDiagram

__all__ = ["HANKEL_ROWS", "AutoSettings", "choose_settings", "drifting_modes", "rms_spread"]

HANKEL_ROWS = 1200
"""Most block rows x channels of a Hankel matrix (its SVD / QR stays a few seconds)."""


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
    band_rule : str
        Where each band edge comes from (printed by the command).
    """

    band_hz: tuple[float, float]
    factor: int
    fs_hz: float
    block_rows: int
    orders: tuple[int, ...]
    band_rule: str = ""

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
    if not p.sum() > 0:  # constant channels: no band from the spectrum
        return float(f[-1])
    c = np.cumsum(p) / p.sum()
    return float(f[min(int(np.searchsorted(c, energy)), f.size - 1)])


def _check_band(f_max_hz: float | None, f_min_hz: float | None, limit_hz: float,
                limit_why: str) -> None:
    """Refuse a given band edge the record cannot support (the limit named)."""
    if f_max_hz is not None and not (math.isfinite(f_max_hz) and 0 < f_max_hz <= limit_hz):
        msg = (f"--f-max: expected a frequency in (0, {limit_hz:.4g}] Hz ({limit_why}), "
               f"got {f_max_hz!r}")
        raise OptionError(msg)
    if f_min_hz is not None and not (math.isfinite(f_min_hz) and f_min_hz >= 0):
        msg = f"--f-min: expected a frequency >= 0 Hz, got {f_min_hz!r}"
        raise OptionError(msg)


def choose_settings(y: FloatArray, fs_hz: float, n_in: int, *,
                    f_max_hz: float | None = None, f_min_hz: float | None = None,
                    factor: int | None = None, block_rows: int | None = None,
                    orders: tuple[int, ...] | None = None,
                    corners_hz: tuple[float, float] | None = None, energy: float = 0.99,
                    margin: float = 1.0, n_cycles: float = 20.0) -> AutoSettings:
    """Band, decimation, block rows and orders for a record (module docstring).

    Every setting given replaces the one chosen from the record; a given band edge the
    record cannot support is an error naming the limit, never clamped.

    Parameters
    ----------
    y : ndarray, shape (n_out, n_samples)
        Outputs at ``fs_hz``.
    n_in : int
        Number of inputs (0 for output-only).
    f_max_hz, f_min_hz : float, optional
        Band edges given by the user (replace the spectral / record-length ones).
    factor, block_rows : int, optional
        Decimation factor and Hankel block rows given by the user.
    orders : tuple of int, optional
        Model orders given by the user.
    corners_hz : (float, float), optional
        Band-pass corners stated by the data file (NaN when not stated).

    Raises
    ------
    OptionError
        ``f_max_hz`` outside (0, limit] (0.8 x Nyquist or the file's low-pass corner),
        ``f_min_hz`` negative or not below the upper edge, a factor or block rows < 1.
    """
    n_out, n = y.shape
    T = n / fs_hz
    lo_c, hi_c = corners_hz if corners_hz is not None else (math.nan, math.nan)
    nyq_lim = 0.8 * fs_hz / 2
    limit, why = nyq_lim, f"0.8 x the Nyquist frequency of {fs_hz:g} Hz"
    if math.isfinite(hi_c) and hi_c < limit:
        limit, why = hi_c, "the low-pass corner the file states"
    _check_band(f_max_hz, f_min_hz, limit, why)
    f_e = margin * _energy_band(y, fs_hz, energy)
    f_hi = min(f_e, limit) if f_max_hz is None else f_max_hz
    hi_why = ("given" if f_max_hz is not None else
              f"{100 * energy:g} % of the output energy below it" if f_e <= limit else why)
    if f_min_hz is not None:
        f_lo, lo_why = f_min_hz, "given"
    else:
        f_lo = max(n_cycles / T, lo_c if math.isfinite(lo_c) else 0.0)
        lo_why = (f"{n_cycles:g} cycles in the record" if f_lo == n_cycles / T
                  else "the high-pass corner the file states")
        if n_cycles / T >= limit:
            msg = (f"record: expected at least {n_cycles / limit:.3g} s ({n_cycles:g} cycles "
                   f"below the {limit:.4g} Hz limit), got {T:.3g} s")
            raise OptionError(msg)
    if f_max_hz is None:
        f_hi = min(max(f_hi, 2.0 * f_lo), limit)
    if not f_lo < f_hi:
        why_lo = "given" if f_min_hz is not None else "from the record's length / corners"
        msg = (f"band: expected the lower edge {f_lo:.4g} Hz ({why_lo}) below the upper "
               f"{f_hi:.4g} Hz")
        raise OptionError(msg)
    for val, name in ((factor, "decimation factor"), (block_rows, "block rows")):
        if val is not None and val < 1:
            msg = f"{name}: expected an integer >= 1, got {val!r}"
            raise OptionError(msg)
    q = factor if factor is not None else max(1, int(fs_hz // (2.5 * f_hi)))
    fs_q = fs_hz / q
    n_q = n // q
    n_ch = max(n_in + n_out, 1)
    i_max = max(2, min(HANKEL_ROWS // n_ch, (n_q - 2) // (4 * n_ch + 2)))
    i = max(math.ceil(fs_q / (4.0 * max(f_lo, 1e-300))), 4)
    i = min(i, i_max)
    n_max = max(2, min(60, n_out * (i - 1)))
    if orders is not None:
        n_max = max(orders)
    i = max(i, min(math.ceil((n_max + 1) / n_out) + 1, i_max))
    if block_rows is not None:
        i = block_rows
    if orders is None:
        n_max = 2 * max(1, min(n_max, n_out * (i - 1)) // 2)
        orders = tuple(range(2, n_max + 1, 2))
    return AutoSettings((f_lo, f_hi), q, fs_q, i, tuple(orders),
                        f"lower edge: {lo_why}; upper edge: {hi_why}")


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
