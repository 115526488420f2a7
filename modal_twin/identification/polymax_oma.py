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

**Sub-bands** (:func:`polymax_banded`): the band is fitted two octaves at a time, each
sub-band with a z-domain basis that puts its fitted band's middle at :math:`z = j`
(:data:`BASIS`), the poles of each sub-band's core merged per order.

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
from itertools import pairwise

import numpy as np

from modal_twin._types import ComplexArray, FloatArray
from modal_twin.errors import ShapeError
from modal_twin.identification.modal_model import ModalModel, PoleSet, PoleSweep
from modal_twin.identification.peaks import on_peak
from modal_twin.identification.polymax import polymax
from modal_twin.identification.stabilization import DroppedColumn

__all__ = ["BAND_RATIO", "BASIS", "N_ERRORS", "centred_owner", "half_spectra_support",
           "lag_window_error", "polymax_banded", "polymax_bands", "spectral_support"]

BAND_RATIO = 4.0
"""Upper over lower edge of a PolyMAX sub-band (two octaves; with :data:`BASIS` the one
width of 2, 3.5, 4 and 5 that kept the earthquake records' count while gaining on the
known truth, ``test/benchmarks/trace_polymax_basis.py``: a measured choice, not a law)."""
BASIS = "middle"
r"""z-domain basis of each sub-band: Nyquist frequency at :math:`a + b` for the fitted band
:math:`[a, b]`, :math:`\Delta t = 1 / 2 (a + b)`, so the band spans the arc
:math:`\pi [a, b] / (a + b)` of the unit circle, symmetric about :math:`z = j` and as far
from :math:`z = -1` (where a mode meets its conjugate's image) as from :math:`z = 1`."""
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
                   overlap: float = BAND_OVERLAP, basis: float | str | None = BASIS,
                   centred: bool = False
                   ) -> tuple[PoleSweep, list[tuple[float, float]]]:
    r"""PolyMAX (:func:`~modal_twin.identification.polymax.polymax`) fitted per sub-band.

    The linearised cost of pLSCF (Eqs. (1)-(4) of [002]) sums :math:`|B - H A|^2` over the
    lines, so over a wide band (a bridge's 0.3-39 Hz, the spectrum falling by 60 dB) the
    strong modes' lines set the denominator and a weak or low mode, crowded near
    :math:`z = 1` by the basis of the whole band, needs orders beyond the diagram's. As
    test engineers fit PolyMAX band by band, each sub-band of :func:`polymax_bands`
    (``ratio``: two octaves, with at least 4 p_max lines) is fitted on its own, over its
    core widened by ``overlap``, with its own basis (Eq. (3)); the poles in the core make
    that order's set. Numerator shapes.

    ``basis``: ``"middle"`` (:data:`BASIS`, the default) puts the fitted band
    :math:`[a, b]` on an arc symmetric about :math:`z = j`, :math:`\Delta t = 1 / 2 (a + b)`;
    None gives the band's own basis, :math:`\Delta t = 1 / 2 b` (Nyquist at the band's
    top, sessions 10-13); a number puts the Nyquist frequency at ``basis`` times :math:`b`.
    With its own basis a sub-band's upper modes sit near :math:`z = -1`, beside their
    conjugates' images, and come out low in frequency and damping at every order (on a
    stationary record with known modes 0.5-1 % low; ``test/benchmarks/
    trace_polymax_basis.py``).

    ``centred`` fits, besides the sub-bands :math:`[e_i, e_{i+1}]`, the half-overlapping
    bands between their middles, :math:`[m_i, m_{i+1}]` with
    :math:`m_i = (e_i + e_{i+1}) / 2`, each over exactly that band and with its own basis
    (or ``basis``); every pole is taken from the fit in which it sits nearest the fitted
    band's middle (:func:`centred_owner`), so no pole comes from the top of its fit, beside
    :math:`z = -1`, except at the top of the whole band.

    Returns
    -------
    (PoleSweep, list of (float, float))
        The merged poles of every order and the sub-bands' cores (``centred``: the fitted
        bands, in order of frequency).
    """
    cores = polymax_bands(band_hz, f_hz, 4 * max(orders), ratio)
    if centred:
        mids = [(a + b) / 2 for a, b in cores]
        fits = sorted(cores + list(pairwise(mids)))
    else:
        fits = [(max(band_hz[0], a / (1 + overlap)), min(band_hz[1], b * (1 + overlap)))
                for a, b in cores]
    sweeps = [polymax(H, f_hz, orders=orders, band_hz=fit, shapes="numerator",
                      dt_s=_basis_step(fit, basis)) for fit in fits]
    sets = []
    for k, p in enumerate(orders):
        if centred:
            keep = [(sw.poles[k], centred_owner(sw.poles[k].f_hz, fits) == j)
                    for j, sw in enumerate(sweeps)]
        else:
            keep = [(sw.poles[k], (sw.poles[k].f_hz >= a) & (sw.poles[k].f_hz < b))
                    for (a, b), sw in zip(cores, sweeps, strict=True)]
        sets.append(PoleSet(
            int(p), np.concatenate([q.f_hz[m] for q, m in keep]),
            np.concatenate([q.zeta[m] for q, m in keep]),
            np.concatenate([q.shapes[:, m] for q, m in keep], axis=1),
            np.concatenate([q.std_f_hz[m] for q, m in keep]),
            np.concatenate([q.std_zeta[m] for q, m in keep])))
    return PoleSweep("polymax", np.asarray(orders, dtype=np.int64), tuple(sets), np.zeros(0),
                     0), (fits if centred else cores)


def _basis_step(fit: tuple[float, float], basis: float | str | None) -> float | None:
    """Return the sampling step of a sub-band's z-domain basis (:func:`polymax_banded`)."""
    if basis is None:
        return None
    if basis == "middle":  # the band's middle at z = j: Nyquist at a + b
        return 1.0 / (2.0 * (fit[0] + fit[1]))
    return 1.0 / (2.0 * float(basis) * fit[1])


def centred_owner(f_hz: FloatArray, fits: list[tuple[float, float]]) -> np.ndarray:
    """Index of the band of ``fits`` in which each frequency sits nearest the middle.

    The distance is :math:`|f - (a + b) / 2| / (b - a)` over the bands :math:`[a, b]` that
    hold :math:`f`; -1 where none does.

    Examples
    --------
    >>> centred_owner(np.array([1.2, 1.9, 2.6, 5.0]), [(1, 2), (1.5, 3), (2, 4)]).tolist()
    [0, 1, 2, -1]
    """
    f = np.asarray(f_hz, dtype=float)[:, None]
    a = np.array([x for x, _ in fits], dtype=float)
    b = np.array([y for _, y in fits], dtype=float)
    d = np.where((f >= a) & (f <= b), np.abs(f - (a + b) / 2) / (b - a), np.inf)
    own = np.argmin(d, axis=1) if fits else np.zeros(f.shape[0], dtype=int)
    return np.where(np.isfinite(np.min(d, axis=1, initial=np.inf)), own, -1)
