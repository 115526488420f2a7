"""Reference modal estimates of a record, independent of ``modal_twin.identification``.

pyOMA2 (``pyoma-2`` 1.4.3) installs with pip beside the venv's numpy / scipy, but its
automatic clustering (``Clustering(quick="Magalhaes")`` on SSI-cov, 60 orders) returns
about 100 clusters in 0.5-14.5 Hz on the Berkeley record, no usable reference without
tuning; these two classical estimators stand in for it, written
from the textbook forms with numpy / scipy only (no code shared with the library):

- **FDD** (Brincker et al. 2001): the output cross-spectral matrix G(f) from
  :func:`scipy.signal.csd` (Welch, Hann, zero-padded 8x), its first singular value s1(f)
  per line, peaks of s1 picked by :func:`scipy.signal.find_peaks` with a prominence in decibels.
- **SSI-cov** (Peeters & De Roeck 1999): output correlations R_k (biased, unnormalised),
  the block Toeplitz matrix of lags 1..2i, its SVD, the observability matrix of order n, A
  from the shift structure by least squares, eigenvalues -> continuous poles; a pole kept
  when 0 < zeta < 10 %; poles of all orders grouped by frequency (1 % gaps) and a group
  kept when it holds a pole in at least half of the orders (a stable column).

``agreed_modes`` returns the frequencies both see within 1 % (their mean): the modes an
identification of the record must report (issue 22, point 1).
"""

from __future__ import annotations

import numpy as np
import scipy.signal as sig


def fdd_peaks(y: np.ndarray, fs: float, band: tuple[float, float], *, seg_s: float = 20.0,
              prominence_db: float = 3.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Peaks of the first singular value of the output PSD matrix in ``band``.

    Returns ``(f_peaks, f, s1)``.
    """
    n_ch, n = y.shape
    nper = min(n, int(2 ** np.ceil(np.log2(seg_s * fs))))
    y0 = y - y.mean(axis=1, keepdims=True)
    f, _ = sig.csd(y0[0], y0[0], fs=fs, nperseg=nper, nfft=8 * nper)
    G = np.empty((f.size, n_ch, n_ch), complex)
    for a in range(n_ch):
        for b in range(a, n_ch):
            _, g = sig.csd(y0[a], y0[b], fs=fs, nperseg=nper, nfft=8 * nper)
            G[:, a, b] = g
            G[:, b, a] = np.conj(g)
    s1 = np.linalg.svd(G, compute_uv=False)[:, 0]
    sel = (f >= band[0]) & (f <= band[1])
    db = 10 * np.log10(s1[sel])
    pk, _ = sig.find_peaks(db, prominence=prominence_db)
    return f[sel][pk], f, s1


def ssi_cov_columns(y: np.ndarray, fs: float, band: tuple[float, float], *, rows: int,
                    orders: range, rel_gap: float = 0.01) -> np.ndarray:
    """Frequencies of the stable columns of a plain SSI-cov sweep in ``band``."""
    n_ch, n = y.shape
    y0 = y - y.mean(axis=1, keepdims=True)
    lags = 2 * rows + 1
    R = np.array([y0[:, k:] @ y0[:, : n - k].T / (n - k) for k in range(lags)])
    T = np.block([[R[rows + a - b] for b in range(rows)] for a in range(rows)])
    U, S, _ = np.linalg.svd(T)
    found: list[tuple[int, float]] = []
    for order in orders:
        O = U[:, :order] * np.sqrt(S[:order])
        A = np.linalg.lstsq(O[:-n_ch], O[n_ch:], rcond=None)[0]
        lam = np.log(np.linalg.eigvals(A).astype(complex)) * fs
        lam = lam[lam.imag > 0]
        w = np.abs(lam)
        f, z = w / (2 * np.pi), -lam.real / w
        keep = (z > 0) & (z < 0.1) & (f >= band[0]) & (f <= band[1])
        found += [(order, float(v)) for v in f[keep]]
    if not found:
        return np.zeros(0)
    fs_sorted = np.sort([v for _, v in found])
    groups: list[list[float]] = [[fs_sorted[0]]]
    for v in fs_sorted[1:]:
        if v - groups[-1][-1] <= rel_gap * v:
            groups[-1].append(v)
        else:
            groups.append([v])
    need = 0.5 * len(orders)
    out = []
    for g in groups:
        lo, hi = g[0], g[-1]
        n_orders = len({o for o, v in found if lo <= v <= hi})
        if n_orders >= need:
            out.append(float(np.median(g)))
    return np.array(out)


def agreed_modes(f_fdd: np.ndarray, f_ssi: np.ndarray, tol: float = 0.01) -> np.ndarray:
    """Frequencies FDD and SSI-cov both see within ``tol`` (their mean), ascending."""
    out = []
    for f in f_fdd:
        if f_ssi.size:
            g = f_ssi[np.argmin(np.abs(f_ssi - f))]
            if abs(g - f) <= tol * 0.5 * (f + g):
                out.append(0.5 * (f + g))
    return np.array(sorted(set(out)))
