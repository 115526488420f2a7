r"""Output-only PolyMAX: which selected poles the positive half-spectra show as a peak.

PolyMAX without inputs fits the positive half-spectra :math:`S^+` of the outputs (Peeters
et al. 2004, sec. 3 of [002]; :func:`~modal_twin.identification.record.half_spectra`):
correlations :math:`R_k` (every output a reference) weighted by the exponential lag window
:math:`w_k = e^{-\beta k}`. The spectrum they stand for,

.. math:: \hat G(\omega) = S^+(\omega) + S^+(\omega)^H
          = \sum_{|k| < L} w_{|k|} R_k e^{-j\omega k \Delta t},

is the lag-window (Blackman-Tukey) estimate of the output PSD matrix, and its relative
standard error for a record of :math:`N` samples is

.. math:: \varepsilon = \sqrt{\tfrac{1}{N} \sum_{|k| < L} w_{|k|}^2}

(Priestley 1981, *Spectral Analysis and Time Series*, Eq. (6.2.124); with the window of
:func:`~modal_twin.identification.record.half_spectra`, :math:`N \beta \approx 4 \ln 100`
and :math:`\varepsilon \approx 0.23`). :func:`lag_window_error` evaluates the finite sum.

**Physical-pole test** (:func:`spectral_support`): a mode is what makes a peak of the
response spectrum, so a pole PolyMAX selects from the half-spectra is reported only where
the first singular value of :math:`\hat G` (the CMIF of the fitted data) has a local
maximum of prominence at least :math:`10 \log_{10}(1 + 2 \varepsilon)` dB (a peak above
two standard errors of the estimate, :data:`N_ERRORS`) within the half-power half-width of
the fitted pole, :math:`(\sigma_r + \sigma_w) / 2\pi` Hz (its decay rate with the window's
:math:`\sigma_w = \beta f_s`; at least one line). A pole that repeats over the model
orders but sits on the flank or in the valley of the spectrum (noise of a short, transient
record fitted consistently by the high-order polynomial) is dropped, with the reason.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import scipy.signal as sig

from modal_twin._types import BoolArray, ComplexArray, FloatArray
from modal_twin.errors import ShapeError
from modal_twin.identification.modal_model import ModalModel, PoleSweep
from modal_twin.identification.stabilization import DroppedColumn

__all__ = ["N_ERRORS", "half_spectra_support", "lag_window_error", "spectral_support"]

N_ERRORS = 2.0
"""A supporting peak rises above its surroundings by this many standard errors of the PSD
estimate (about 95 % of the estimate's scatter stays below it)."""


def lag_window_error(beta: float, n_lags: int, n_samples: int) -> float:
    r"""Relative standard error :math:`\varepsilon` of the lag-window PSD (module docstring).

    Parameters
    ----------
    beta : float
        Decay per lag of the window :math:`w_k = e^{-\beta k}`, k = 0 .. n_lags - 1.
    n_lags : int
    n_samples : int
        Samples of the record the correlations come from.

    Examples
    --------
    >>> round(lag_window_error(0.0, 1, 100), 3)  # one lag: the raw variance, 1 / sqrt(N)
    0.1
    """
    k = np.arange(1, max(int(n_lags), 1))
    s2 = 1.0 + 2.0 * float(np.sum(np.exp(-2.0 * beta * k)))
    return float(np.sqrt(s2 / max(int(n_samples), 1)))


def _first_singular_value(S: ComplexArray) -> FloatArray:
    """First singular value per line of :math:`S^+ + S^{+H}` (S: (n_out, n_out, n_f))."""
    G = S + np.conj(np.swapaxes(S, 0, 1))
    sv = np.linalg.svd(np.moveaxis(G, -1, 0), compute_uv=False)
    return np.asarray(sv[:, 0], dtype=np.float64)


def spectral_support(modes: ModalModel, f_hz: FloatArray, S: ComplexArray, sigma_w: float,
                     rel_error: float, sweep: PoleSweep | None = None
                     ) -> tuple[ModalModel, list[DroppedColumn], float]:
    """Keep the modes that stand on a peak of the half-spectra's PSD (module docstring).

    Parameters
    ----------
    modes : ModalModel
        Selected modes, their poles with the window's decay taken back out.
    f_hz : (n_f,) array
        Lines of the half-spectra.
    S : (n_out, n_out, n_f) complex array
        Positive half-spectra, as fitted (windowed).
    sigma_w : float
        Decay rate the window added (1/s).
    rel_error : float
        Relative standard error of the PSD estimate (:func:`lag_window_error`).
    sweep : PoleSweep, optional
        The poles behind ``modes``: the orders a dropped mode spans are read from it.

    Returns
    -------
    (ModalModel, list of DroppedColumn, float)
        The modes kept, those dropped with the reason, and the prominence used (dB).

    Raises
    ------
    ShapeError
        ``S`` not (n, n, n_f) over ``f_hz``.
    """
    f = np.asarray(f_hz, dtype=float)
    if S.ndim != 3 or S.shape[0] != S.shape[1] or S.shape[2] != f.size:
        msg = f"S: expected (n_out, n_out, {f.size}) half-spectra, got {S.shape}"
        raise ShapeError(msg)
    prom = 10.0 * np.log10(1.0 + N_ERRORS * rel_error)
    if modes.f_hz.size == 0:
        return modes, [], prom
    pos = f > 0
    fl = f[pos]
    db = 10.0 * np.log10(np.maximum(_first_singular_value(S[..., pos]), 1e-300))
    pk, _ = sig.find_peaks(db, prominence=prom)
    fp = fl[pk]
    df = float(np.median(np.diff(fl))) if fl.size > 1 else 0.0
    w = 2 * np.pi * modes.f_hz
    half = np.maximum((modes.zeta * w + sigma_w) / (2 * np.pi), df)  # half-power half-width
    gap = (np.min(np.abs(fp[None, :] - modes.f_hz[:, None]), axis=1) if fp.size
           else np.full(modes.f_hz.size, np.inf))
    ok: BoolArray = gap <= half
    dropped = []
    for k in np.nonzero(~ok)[0]:
        fk, hk = float(modes.f_hz[k]), float(half[k])
        span = _span(sweep, fk, hk) if sweep is not None else (
            int(modes.mode_orders[k]), int(modes.mode_orders[k]))
        near = (f"the nearest at {float(fp[np.argmin(np.abs(fp - fk))]):.3f} Hz"
                if fp.size else "none in the band")
        dropped.append(DroppedColumn(
            fk, float(modes.zeta[k]), int(modes.n_support[k]), span,
            f"no peak of the half-spectra's PSD (prominence >= {prom:.2f} dB, {N_ERRORS:g} "
            f"standard errors) within its half-power half-width {hk:.3g} Hz ({near}): not a "
            f"mode of the response"))
    kept = replace(modes, f_hz=modes.f_hz[ok], zeta=modes.zeta[ok], shapes=modes.shapes[:, ok],
                   std_f_hz=modes.std_f_hz[ok], std_zeta=modes.std_zeta[ok],
                   mode_orders=modes.mode_orders[ok], n_support=modes.n_support[ok])
    return kept, dropped, prom


def _span(sweep: PoleSweep, f0: float, half: float) -> tuple[int, int]:
    """First and last order with a pole within ``half`` Hz of ``f0``."""
    hit = [int(p.order) for p in sweep.poles if np.any(np.abs(p.f_hz - f0) <= half)]
    return (min(hit), max(hit)) if hit else (0, 0)


def half_spectra_support(modes: ModalModel, f_hz: FloatArray, S: ComplexArray, sigma_w: float,
                         n_samples: int, fs_hz: float, sweep: PoleSweep | None = None
                         ) -> tuple[ModalModel, list[DroppedColumn], str]:
    r""":func:`spectral_support` for half-spectra of ``n_samples`` at ``fs_hz``, and a note.

    The window is that of :func:`~modal_twin.identification.record.half_spectra`: its lags
    from the lines (``n_f = n_lags + 1``), its decay per lag :math:`\beta = \sigma_w / f_s`.
    """
    n_lags = max(int(np.asarray(f_hz).size) - 1, 1)
    eps = lag_window_error(sigma_w / fs_hz, n_lags, n_samples)
    kept, dropped, prom = spectral_support(modes, f_hz, S, sigma_w, eps, sweep)
    note = (f"physical-pole test: a mode stands on a peak of the half-spectra's PSD (first "
            f"singular value, prominence >= {prom:.2f} dB: {N_ERRORS:g} x its standard "
            f"error {100 * eps:.0f} %) within its half-power half-width; {len(dropped)} of "
            f"{modes.f_hz.size} selected dropped")
    return kept, dropped, note
