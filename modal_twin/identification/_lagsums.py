r"""Exact lag sums and block-Hankel Gram matrices by segmented FFT (private).

Shared by :mod:`.n4sid`, :mod:`.ssi_cov` and the half-spectra of output-only PolyMAX
(:func:`~modal_twin.identification.record.half_spectra`, through
:func:`~modal_twin.identification.ssi_cov.correlations`). The lag sums

.. math:: C_d = \sum_{s=s_0}^{s_1 - 1} x_s\, y_{s+d}^T, \qquad d = 0, \dots, L - 1

(``y`` zero from ``n_valid`` on) are the only data passes of both methods. Computed lag by
lag they cost :math:`L\, c_x c_y (s_1 - s_0)` multiply-adds; here the range is cut into
segments of K samples, each correlated with the K + L - 1 samples from its start by FFT
of length :math:`n_{fft} \ge K + L - 1` (no circular wrap, so the sums are exact to
rounding), and the cross spectra of all segments are accumulated by one batched matrix
product per frequency line: about :math:`c_x c_y (s_1 - s_0)` complex multiply-adds,
independent of L (Welch-style overlap-save; e.g. Bendat & Piersol, 2010, sec. 11.6).
The transforms run along the time axis laid out first, so that they come out line-major
for the products; for y = x (both callers) each segment is transformed once and the
window spectrum is completed by a short DFT of the L - 1 samples after it
(:func:`_self_spectra`).

The Gram matrix of the block Hankel matrix with 2i block rows of :math:`z_t`,
:math:`\Phi_{ab} = \sum_{t=t_0}^{t_1-1} z_{t+a} z_{t+b}^T`, follows EXACTLY from the lag
sums over :math:`[t_0, t_1)` and two short edge corrections (:func:`hankel_gram`), instead
of forming the :math:`2i c \times j` Hankel matrix and its product (2i / 4 times more
work and a large copy).

With many lags for the range (:math:`L^2` above :data:`WHOLE_RANGE` times its length: the
half-spectra's quarter of the record) the inverse DFT and the tail DFT above grow as
:math:`L^2`; the sums then come from one zero-padded transform of the whole range
(:func:`_whole_range`), exact to rounding as well.
"""

from __future__ import annotations

import numpy as np
import scipy.fft as sfft
import scipy.linalg as sla
from numpy.lib.stride_tricks import sliding_window_view

from modal_twin._types import ComplexArray, FloatArray, IntArray

__all__ = ["WHOLE_RANGE", "hankel_gram", "lag_sums"]

WHOLE_RANGE = 1.0
r"""Lags L with :math:`L^2` above this many times the range's length are summed from one
transform of the whole range (:func:`_whole_range`): the segmented path's inverse DFT
and tail DFT grow as :math:`L^2`, the whole transform as :math:`(n + L) \log(n + L)`."""


def lag_sums(
    x: FloatArray, y: FloatArray, n_lags: int, start: int, stop: int, n_valid: int
) -> FloatArray:
    r"""Exact :math:`C_d = \sum_{s=start}^{stop-1} x_s y_{s+d}^T` for d < n_lags.

    Parameters
    ----------
    x : ndarray, shape (c_x, n)
    y : ndarray, shape (c_y, n)
        Samples of y at index >= ``n_valid`` count as zero.
    n_lags : int
        Number of lags L.
    start, stop : int
        Summation range of s.
    n_valid : int
        First index of y treated as zero.

    Returns
    -------
    ndarray, shape (n_lags, c_x, c_y)
    """
    L = int(n_lags)
    ln = stop - start
    if WHOLE_RANGE * ln < L * L:  # many lags for the range: one transform of it
        return _whole_range(x, y, L, start, stop, n_valid)
    K = max(6 * L, 128)  # segments of ~6 L samples: FFT, products and inverse DFT balanced
    nfft = sfft.next_fast_len(K + L - 1, real=True)
    K = nfft - L + 1  # use the whole FFT length
    nseg = max(-(-ln // K), 1)
    cx, cy = x.shape[0], y.shape[0]
    F = nfft // 2 + 1
    # segments per pass: spectra of ~2 MB (cache), but >= 32 (inner size of the products)
    chunk = max(32, int(2e6 // (F * (cx + cy) * 16)))
    chunk = -(-nseg // -(-nseg // chunk))  # passes of equal size
    S = np.zeros((F, cx, cy), dtype=np.complex128)
    if x is y and n_valid >= stop:
        _self_spectra(S, x, L, K, nfft, start, stop, n_valid, nseg, chunk)
    else:
        _cross_spectra(S, x, y, L, K, nfft, start, stop, n_valid, nseg, chunk)
    # inverse DFT of the first L lags only, as one real GEMM over (line, re / im):
    # C_d = sum_f w_f (cos(2 pi f d / n) Re S_f - sin(2 pi f d / n) Im S_f)
    wgt = np.full(F, 2.0 / nfft)
    wgt[0] = 1.0 / nfft
    if nfft % 2 == 0:
        wgt[-1] = 1.0 / nfft
    ang = 2 * np.pi * np.outer(np.arange(L), np.arange(F)) / nfft
    Wcs = np.stack([np.cos(ang) * wgt, -np.sin(ang) * wgt], axis=-1).reshape(L, 2 * F)
    Sri = S.view(np.float64).reshape(F, cx * cy, 2).transpose(0, 2, 1).reshape(2 * F, -1)
    out: FloatArray = (Wcs @ Sri).reshape(L, cx, cy)
    return out


def _whole_range(x: FloatArray, y: FloatArray, L: int, start: int, stop: int,
                 n_valid: int) -> FloatArray:
    r""":func:`lag_sums` from one zero-padded transform of the whole range.

    With :math:`n_{fft} \ge (s_1 - s_0) + L - 1` the circular cross-correlation of the
    range of x with the samples of y from :math:`s_0` (to :math:`s_1 + L - 1`, zero from
    ``n_valid``) has no wrap at lags below L; one inverse transform per channel of x.
    """
    ln = stop - start
    nfft = sfft.next_fast_len(ln + L - 1, real=True)
    X = sfft.rfft(x[:, start:stop], n=nfft, axis=1)
    Y = sfft.rfft(y[:, start : max(min(stop + L - 1, n_valid), start)], n=nfft, axis=1)
    np.conjugate(X, out=X)
    out = np.empty((L, x.shape[0], y.shape[0]))
    for a in range(x.shape[0]):  # sum_s x_a,s y_{s+d} = IFFT(conj(X_a) Y)[d]
        out[:, a, :] = sfft.irfft(X[a] * Y, n=nfft, axis=1)[:, :L].T
    return out


def _cross_spectra(
    S: ComplexArray, x: FloatArray, y: FloatArray, L: int, K: int, nfft: int, start: int,
    stop: int, n_valid: int, nseg: int, chunk: int,
) -> None:
    r"""Add :math:`\sum_g \overline{X_g} Y_g^T` per line to S (segments of x, windows of y)."""
    cx, cy = x.shape[0], y.shape[0]
    # time on the FIRST axis: the transforms run along axis 0 (vectorised over the
    # channel and segment axes) and return the line-major layout the products need
    Xb = np.zeros((nfft, cx, chunk))
    Yb = np.zeros((nfft, chunk, cy))
    for g0 in range(0, nseg, chunk):
        G = min(nseg, g0 + chunk) - g0
        s0 = start + g0 * K
        xs = np.zeros((cx, G * K))  # segment g: x_s, s0 + g K <= s < s0 + (g + 1) K
        nx = min(G * K, stop - s0)
        xs[:, :nx] = x[:, s0 : s0 + nx]
        Xb[:K, :, :G] = xs.reshape(cx, G, K).transpose(2, 0, 1)
        ys = np.zeros((cy, G * K + L - 1))  # window g: the K + L - 1 samples from its start
        ny = max(min(G * K + L - 1, n_valid - s0), 0)
        ys[:, :ny] = y[:, s0 : s0 + ny]
        Yb[: K + L - 1, :G] = sliding_window_view(ys, K + L - 1, axis=1)[:, ::K].transpose(2, 1, 0)
        if chunk > G:  # last, shorter pass
            Xb[:, :, G:] = 0.0
            Yb[:, G:] = 0.0
        X = sfft.rfft(Xb, axis=0)  # (F, c_x, G)
        np.conjugate(X, out=X)
        # cross spectra summed over segments: one (c_x, G) @ (G, c_y) product per line
        S += np.matmul(X, sfft.rfft(Yb, axis=0))


def _self_spectra(
    S: ComplexArray, x: FloatArray, L: int, K: int, nfft: int, start: int, stop: int,
    n_valid: int, nseg: int, chunk: int,
) -> None:
    r""":func:`_cross_spectra` for y = x, with one transform per segment instead of two.

    The window of y at segment g is the segment itself (its samples up to ``n_valid``)
    plus the L - 1 samples after it at positions K .. K + L - 2, so its spectrum is
    :math:`C_g(f) + \sum_{t<L-1} x_{(g+1)K+t} e^{-2\pi i f (K + t) / n_{fft}}`: the
    transform of the segment plus a short DFT (one real GEMM for all segments). Only
    the segment holding ``stop`` differs between x (cut at ``stop``) and the window
    core (cut at ``n_valid``); it gets its own transform.
    """
    c = x.shape[0]
    F = nfft // 2 + 1
    ang = 2 * np.pi * np.outer(np.arange(F), K + np.arange(L - 1)) / nfft
    Wh = np.concatenate([np.cos(ang), -np.sin(ang)])  # (2F, L - 1): re, im of the DFT
    Cb = np.zeros((nfft, c, chunk))
    # work arrays reused by every pass (fewer fresh pages: the page faults of new large
    # arrays cost as much as the transforms here)
    Eb = np.empty((2 * F, chunk * c))
    Yb = np.empty((F, chunk, c), dtype=np.complex128)
    Sb = np.empty_like(S)
    for g0 in range(0, nseg, chunk):
        G = min(nseg, g0 + chunk) - g0
        s0 = start + g0 * K
        if s0 + (G + 1) * K <= n_valid:  # segments g0 .. g0 + G and the head after them
            seg = x[:, s0 : s0 + (G + 1) * K].reshape(c, G + 1, K)
        else:  # the record ends inside: zero padded copy
            xs = np.zeros((c, (G + 1) * K))
            nx = max(n_valid - s0, 0)
            xs[:, :nx] = x[:, s0 : s0 + nx]
            seg = xs.reshape(c, G + 1, K)
        Cb[:K, :, :G] = seg[:, :G].transpose(2, 0, 1)
        if chunk > G:  # last, shorter pass
            Cb[:, :, G:] = 0.0
        C = sfft.rfft(Cb, axis=0)[:, :, :G]  # (F, c, G)
        hd = np.ascontiguousarray(seg[:, 1:, : L - 1].transpose(2, 1, 0))  # (L-1, G, c)
        E = np.matmul(Wh, hd.reshape(L - 1, G * c), out=Eb[:, : G * c]).reshape(2, F, G, c)
        Y = Yb[:, :G]
        np.add(C.real.transpose(0, 2, 1), E[0], out=Y.real)
        np.add(C.imag.transpose(0, 2, 1), E[1], out=Y.imag)
        last = s0 + G * K > stop  # the segment holding stop: x cut there
        if last:
            xl = np.zeros((nfft, c))
            nl = stop - (s0 + (G - 1) * K)
            xl[:nl] = x[:, stop - nl : stop].T
            C[:, :, G - 1] = sfft.rfft(xl, axis=0)
        np.conjugate(C, out=C)
        S += np.matmul(C, Y, out=Sb)


def _edge_factor(z: FloatArray, e: int, L: int) -> FloatArray:
    r"""M with :math:`(M M^T)_{ab} = \sum_{s=e}^{e+a-1} z_s z_{s+b-a}^T` (a <= b), (L, c, L-1).

    Row (a, ch), column tau: :math:`z_{e+a-\tau}` for :math:`1 \le \tau \le a`, else 0
    (the part of the Hankel columns left of edge e that lies right of it).
    """
    c = z.shape[0]
    w = np.zeros((c, 2 * L - 1))
    hi = min(z.shape[1], e + L)
    if hi > e:
        w[:, L - 1 : L - 1 + hi - e] = z[:, e:hi]
    return sliding_window_view(w, L - 1, axis=1)[:, :L].transpose(1, 0, 2)


def hankel_gram(
    z: FloatArray,
    n_rows: int,
    edges: IntArray,
    groups: list[tuple[slice, slice]] | None = None,
    *,
    row_groups: int | None = None,
) -> list[FloatArray]:
    r"""Gram matrices of the block Hankel matrix of z over column ranges, exactly.

    :math:`\Phi_k` = block Toeplitz matrix of the lag sums over :math:`[t_0, t_1)` plus
    :math:`M_{t_1} M_{t_1}^T - M_{t_0} M_{t_0}^T` (:func:`_edge_factor`): each block
    :math:`\sum_{s=t_0+a}^{t_1+a-1} z_s z_{s+b-a}^T` differs from the lag sum over
    :math:`[t_0, t_1)` by fewer than L terms at each edge.

    Parameters
    ----------
    z : ndarray, shape (c, n)
        Signals (channels first).
    n_rows : int
        Block rows L of the Hankel matrix; column t holds :math:`[z_t; \dots; z_{t+L-1}]`,
        t < n - L + 1.
    edges : ndarray of int, shape (n_blocks + 1,)
        Column ranges :math:`[t_k, t_{k+1})` of the blocks.
    groups : list of (slice of blocks, slice of channels), optional
        Row order of the result: the rows of each group, block-major, one group after
        the other (default: all blocks, all channels).
    row_groups : int, optional
        Compute only the rows of the first ``row_groups`` groups (all columns); the
        rest follow by symmetry (N4SID never needs :math:`\Phi_{Y_f Y_f}`).

    Returns
    -------
    list of ndarray, each shape (n_rows_out, n_rows_out)
        :math:`\Phi_k`, entry ((a, ch), (b, ch')) = :math:`\sum_t z_{ch, t+a} z_{ch', t+b}`;
        their sum is the Gram matrix of all columns in ``edges[0]:edges[-1]``. With
        ``row_groups`` only the leading rows, shape (rows of those groups, n_rows_out).
    """
    c, n = z.shape
    L = int(n_rows)
    grp = [(slice(0, L), slice(0, c))] if groups is None else groups
    ng = len(grp) if row_groups is None else int(row_groups)
    ar, ch = np.arange(L), np.arange(c)
    rows = np.concatenate([(ar[b][:, None] * c + ch[q][None, :]).ravel() for b, q in grp])
    size = [len(ar[b]) * len(ch[q]) for b, q in grp]
    off = np.concatenate([[0], np.cumsum(size)])
    k, kr = int(off[-1]), int(off[ng])
    M = [_edge_factor(z, int(e), L).reshape(L * c, L - 1)[rows] for e in edges]
    out = []
    for kb in range(len(edges) - 1):
        D = lag_sums(z, z, L, int(edges[kb]), int(edges[kb + 1]), n)
        Dfull = np.concatenate([D[:0:-1].transpose(0, 2, 1), D])  # index L - 1 + (b - a)
        # block Toeplitz as a VIEW: T4[a, ch, b, ch'] = Dfull[L - 1 - a + b, ch, ch']
        T4 = sliding_window_view(Dfull, L, axis=0)[::-1].transpose(0, 1, 3, 2)
        Phi = np.empty((kr, k))
        for g1, (b1, q1) in enumerate(grp[:ng]):
            for g2, (b2, q2) in enumerate(grp):
                Phi[off[g1] : off[g1 + 1], off[g2] : off[g2 + 1]] = T4[b1, q1, b2, q2].reshape(
                    size[g1], size[g2])
        # edge corrections M_t1 M_t1^T - M_t0 M_t0^T: one GEMM accumulated in place (the
        # C-ordered Phi is the Fortran-ordered Phi^T: Phi^T += Mn Me^T)
        Me = np.hstack([M[kb + 1][:kr], M[kb][:kr]])
        Mn = np.hstack([M[kb + 1], -M[kb]])
        Phi = sla.blas.dgemm(1.0, Mn, Me, trans_b=1, beta=1.0, c=Phi.T, overwrite_c=1).T
        out.append(Phi)
    return out
