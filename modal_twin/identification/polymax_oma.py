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
:func:`~modal_twin.identification.record.half_spectra` to 1 % over :math:`N / 4` lags,
:math:`N \beta \approx 4 \ln 100` and :math:`\varepsilon \approx 0.23`).
:func:`lag_window_error` evaluates the finite sum. The correlations are those of
:func:`~modal_twin.identification.ssi_cov.correlations` (the many lags of the half-spectra
from one transform of the record, :mod:`~modal_twin.identification._lagsums`).

**Sub-bands** (:func:`polymax_banded`): the band is fitted octave by octave, each with its
own z-domain basis, the poles of each octave's core merged per order.

**Physical-pole test** (:func:`spectral_support`): a mode is what makes a peak of the
response spectrum, so a pole PolyMAX selects from the half-spectra is reported only where
the first singular value of :math:`\hat G` (the CMIF of the fitted data) has a local
maximum of topographic prominence at least :math:`10 \log_{10}(1 + 2 \varepsilon)` dB
(:func:`~modal_twin.identification.peaks.on_peak`; a peak above
two standard errors of the estimate, :data:`N_ERRORS`) within the half-power half-width of
the fitted pole, :math:`(\sigma_r + \sigma_w) / 2\pi` Hz (its decay rate with the window's
:math:`\sigma_w = \beta f_s`; at least one line). A pole that repeats over the model
orders but sits on the flank or in the valley of the spectrum (noise of a short, transient
record fitted consistently by the high-order polynomial) is dropped, with the reason.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from modal_twin._types import ComplexArray, FloatArray
from modal_twin.errors import ShapeError
from modal_twin.identification.modal_model import ModalModel, PoleSet, PoleSweep
from modal_twin.identification.peaks import on_peak
from modal_twin.identification.polymax import polymax
from modal_twin.identification.stabilization import DroppedColumn

__all__ = ["BAND_RATIO", "N_ERRORS", "half_spectra_support",
           "lag_window_error", "polymax_banded", "polymax_bands", "spectral_support"]

BAND_RATIO = 2.0
"""Upper over lower edge of a PolyMAX sub-band (an octave)."""
BAND_OVERLAP = 0.15
"""Each sub-band is fitted over its core widened by this fraction on each side; only the
poles in the core are kept (a pole at a fitted band's edge is biased by the modes outside)."""
N_ERRORS = 2.0
"""A supporting peak rises above its surroundings by this many standard errors of the PSD
estimate (about 95 % of a Gaussian scatter stays below it; with the window of
:func:`~modal_twin.identification.record.half_spectra` over a quarter of the record,
:math:`\varepsilon \approx 0.23` and the threshold 1.7 dB)."""


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
    df = float(np.median(np.diff(fl))) if fl.size > 1 else 0.0
    w = 2 * np.pi * modes.f_hz
    half = np.maximum((modes.zeta * w + sigma_w) / (2 * np.pi), df)  # half-power half-width
    ok = on_peak(fl, _first_singular_value(S[..., pos]), modes.f_hz, half,
                 1.0 + N_ERRORS * rel_error, flank=None)
    dropped = []
    for k in np.nonzero(~ok)[0]:
        fk, hk = float(modes.f_hz[k]), float(half[k])
        span = _span(sweep, fk, hk) if sweep is not None else (
            int(modes.mode_orders[k]), int(modes.mode_orders[k]))
        dropped.append(DroppedColumn(
            fk, float(modes.zeta[k]), int(modes.n_support[k]), span,
            f"no peak of the half-spectra's PSD (prominence >= {prom:.2f} dB, {N_ERRORS:g} "
            f"standard errors) within its half-power half-width {hk:.3g} Hz: not a mode of "
            f"the response"))
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


def polymax_bands(band_hz: tuple[float, float], f_hz: FloatArray, min_lines: int,
                  ratio: float = BAND_RATIO) -> list[tuple[float, float]]:
    """Cores of the sub-bands of ``band_hz``: octaves (``ratio``), each with ``min_lines``.

    Adjacent octaves are merged until each holds at least ``min_lines`` lines of
    ``f_hz`` (a last short one joins the one below); a band too narrow for two is one core.
    """
    lo, hi = band_hz
    f = np.asarray(f_hz, dtype=float)
    edges = [lo]
    while edges[-1] * ratio < hi and edges[-1] > 0:
        edges.append(edges[-1] * ratio)
    edges.append(hi)

    def lines(a: float, b: float) -> int:
        return int(np.count_nonzero((f >= a) & (f <= b)))

    out: list[tuple[float, float]] = []
    a = edges[0]
    for b in edges[1:]:
        if lines(a, b) >= min_lines or b == hi:
            out.append((a, b))
            a = b
    if len(out) > 1 and lines(*out[-1]) < min_lines:
        out[-2:] = [(out[-2][0], out[-1][1])]
    return out


def polymax_banded(H: ComplexArray, f_hz: FloatArray, orders: list[int],
                   band_hz: tuple[float, float], *, ratio: float = BAND_RATIO,
                   overlap: float = BAND_OVERLAP, basis: float | None = None
                   ) -> tuple[PoleSweep, list[tuple[float, float]]]:
    r"""PolyMAX (:func:`~modal_twin.identification.polymax.polymax`) fitted per sub-band.

    The linearised cost of pLSCF (Eqs. (1)-(4) of [002]) sums :math:`|B - H A|^2` over the
    lines, so over a wide band (a bridge's 0.3-39 Hz, the spectrum falling by 60 dB) the
    strong modes' lines set the denominator and a weak or low mode, crowded near
    :math:`z = 1` by the basis of the whole band, needs orders beyond the diagram's. As
    test engineers fit PolyMAX band by band, each sub-band of :func:`polymax_bands`
    (octaves with at least 4 p_max lines) is fitted on its own, over its core widened by
    ``overlap``, with its own basis (Eq. (3): :math:`\Delta t = 1 / 2 f_{\max}` of the
    fitted band); the poles in the core make that order's set. Numerator shapes.

    ``basis`` (None: the band's own, as above) puts the basis' Nyquist frequency at
    ``basis`` times the fitted band's upper edge, :math:`\Delta t = 1 / (2\,
    \mathrm{basis}\, f_{\max})`: with its own basis a sub-band's upper modes sit near
    :math:`z = -1`, beside their conjugates' images, and on a stationary record with known
    modes they come out 0.5-1 % low at every order; with ``basis=2`` within 0.3 %
    (``test/benchmarks/trace_polymax_basis.py``; not the default: on the earthquake
    records it reports fewer of the modes the references agree on).

    Returns
    -------
    (PoleSweep, list of (float, float))
        The merged poles of every order and the sub-bands' cores.
    """
    cores = polymax_bands(band_hz, f_hz, 4 * max(orders), ratio)
    parts = []
    for a, b in cores:
        fit = (max(band_hz[0], a / (1 + overlap)), min(band_hz[1], b * (1 + overlap)))
        dt = None if basis is None else 1.0 / (2.0 * basis * fit[1])
        parts.append((a, b, polymax(H, f_hz, orders=orders, band_hz=fit, dt_s=dt,
                                    shapes="numerator")))
    sets = []
    for k, p in enumerate(orders):
        keep = [(sw.poles[k], (sw.poles[k].f_hz >= a) & (sw.poles[k].f_hz < b))
                for a, b, sw in parts]
        sets.append(PoleSet(
            int(p), np.concatenate([q.f_hz[m] for q, m in keep]),
            np.concatenate([q.zeta[m] for q, m in keep]),
            np.concatenate([q.shapes[:, m] for q, m in keep], axis=1),
            np.concatenate([q.std_f_hz[m] for q, m in keep]),
            np.concatenate([q.std_zeta[m] for q, m in keep])))
    return PoleSweep("polymax", np.asarray(orders, dtype=np.int64), tuple(sets), np.zeros(0),
                     0), cores
