"""Exact lag sums and block-Hankel Gram matrices by segmented FFT (private).

Shared by :mod:`.n4sid` and :mod:`.ssi_cov`. The lag sums

.. math:: C_d = \\sum_{s=s_0}^{s_1 - 1} x_s\\, y_{s+d}^T, \\qquad d = 0, \\dots, L - 1

(``y`` zero from ``n_valid`` on) are the only data passes of both methods. Computed lag by
lag they cost :math:`L\\, c_x c_y (s_1 - s_0)` multiply-adds; here the range is cut into
segments of K samples, each correlated with the K + L - 1 samples from its start by FFT
of length :math:`n_{fft} \\ge K + L - 1` (no circular wrap, so the sums are exact to
rounding), and the cross spectra of all segments are accumulated by one batched matrix
product per frequency line: about :math:`c_x c_y (s_1 - s_0)` complex multiply-adds,
independent of L (Welch-style overlap-save; e.g. Bendat & Piersol, 2010, sec. 11.6).

The Gram matrix of the block Hankel matrix with 2i block rows of :math:`z_t`,
:math:`\\Phi_{ab} = \\sum_{t=t_0}^{t_1-1} z_{t+a} z_{t+b}^T`, follows EXACTLY from the lag
sums over :math:`[t_0, t_1)` and two short edge corrections (:func:`hankel_gram`), instead
of forming the :math:`2i c \\times j` Hankel matrix and its product (2i / 4 times more
work and a large copy).
"""

from __future__ import annotations

import numpy as np
import scipy.fft as sfft
from numpy.lib.stride_tricks import sliding_window_view

from modal_twin._types import FloatArray, IntArray

__all__ = ["hankel_gram", "lag_sums"]


def lag_sums(
    x: FloatArray, y: FloatArray, n_lags: int, start: int, stop: int, n_valid: int
) -> FloatArray:
    """Exact :math:`C_d = \\sum_{s=start}^{stop-1} x_s y_{s+d}^T` for d < n_lags.

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
    K = max(16 * L, 256)  # long segments: few transforms, ~n/2 lines x segments
    nfft = sfft.next_fast_len(K + L - 1, real=True)
    K = nfft - L + 1  # use the whole FFT length
    nseg = max(-(-ln // K), 1)
    cx, cy = x.shape[0], y.shape[0]
    xs = np.zeros((cx, nseg * K))
    xs[:, :ln] = x[:, start:stop]
    yw = nseg * K + L - 1
    ys = np.zeros((cy, yw))
    hi = min(n_valid, start + yw)
    if hi > start:
        ys[:, : hi - start] = y[:, start:hi]
    F = nfft // 2 + 1
    S = np.zeros((F, cx, cy), dtype=np.complex128)
    chunk = 16  # segments per pass: the spectra of a chunk stay in cache
    Xb = np.zeros((cx, chunk, nfft))
    for g0 in range(0, nseg, chunk):
        g1 = min(nseg, g0 + chunk)
        G = g1 - g0
        Xb[:, :G, :K] = xs[:, g0 * K : g1 * K].reshape(cx, G, K)
        X = sfft.rfft(Xb[:, :G], axis=-1)
        Yw = sliding_window_view(ys[:, g0 * K : g1 * K + L - 1], K + L - 1, axis=1)[:, ::K]
        Y = sfft.rfft(Yw[:, :G], nfft, axis=-1)
        # lines first: each line is one contiguous (c_x, G) @ (G, c_y) product
        Xt = np.ascontiguousarray(X.transpose(2, 0, 1))
        np.conjugate(Xt, out=Xt)
        Yt = np.ascontiguousarray(Y.transpose(2, 1, 0))
        S += np.matmul(Xt, Yt)  # cross spectra summed over segments, batched per line
    # inverse DFT of the first L lags only, as one real GEMM on the interleaved (re, im)
    wgt = np.full(F, 2.0 / nfft)
    wgt[0] = 1.0 / nfft
    if nfft % 2 == 0:
        wgt[-1] = 1.0 / nfft
    ang = 2 * np.pi * np.outer(np.arange(L), np.arange(F)) / nfft
    Wri = np.concatenate([np.cos(ang) * wgt, -np.sin(ang) * wgt])  # (2L, F)
    P = Wri @ S.view(np.float64).reshape(F, -1)  # (2L, c_x c_y 2)
    out: FloatArray = (P[:L, 0::2] + P[L:, 1::2]).reshape(L, cx, cy)
    return out


def _edge_factor(z: FloatArray, e: int, L: int) -> FloatArray:
    """M with :math:`(M M^T)_{ab} = \\sum_{s=e}^{e+a-1} z_s z_{s+b-a}^T` (a <= b), (L, c, L-1).

    Row (a, ch), column tau: :math:`z_{e+a-\\tau}` for :math:`1 \\le \\tau \\le a`, else 0
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
) -> list[FloatArray]:
    """Gram matrices of the block Hankel matrix of z over column ranges, exactly.

    :math:`\\Phi_k` = block Toeplitz matrix of the lag sums over :math:`[t_0, t_1)` plus
    :math:`M_{t_1} M_{t_1}^T - M_{t_0} M_{t_0}^T` (:func:`_edge_factor`): each block
    :math:`\\sum_{s=t_0+a}^{t_1+a-1} z_s z_{s+b-a}^T` differs from the lag sum over
    :math:`[t_0, t_1)` by fewer than L terms at each edge.

    Parameters
    ----------
    z : ndarray, shape (c, n)
        Signals (channels first).
    n_rows : int
        Block rows L of the Hankel matrix; column t holds :math:`[z_t; \\dots; z_{t+L-1}]`,
        t < n - L + 1.
    edges : ndarray of int, shape (n_blocks + 1,)
        Column ranges :math:`[t_k, t_{k+1})` of the blocks.
    groups : list of (slice of blocks, slice of channels), optional
        Row order of the result: the rows of each group, block-major, one group after
        the other (default: all blocks, all channels).

    Returns
    -------
    list of ndarray, each shape (n_rows_out, n_rows_out)
        :math:`\\Phi_k`, entry ((a, ch), (b, ch')) = :math:`\\sum_t z_{ch, t+a} z_{ch', t+b}`;
        their sum is the Gram matrix of all columns in ``edges[0]:edges[-1]``.
    """
    c, n = z.shape
    L = int(n_rows)
    grp = [(slice(0, L), slice(0, c))] if groups is None else groups
    ar, ch = np.arange(L), np.arange(c)
    rows = np.concatenate([(ar[b][:, None] * c + ch[q][None, :]).ravel() for b, q in grp])
    size = [len(ar[b]) * len(ch[q]) for b, q in grp]
    off = np.concatenate([[0], np.cumsum(size)])
    k = int(off[-1])
    M = [_edge_factor(z, int(e), L).reshape(L * c, L - 1)[rows] for e in edges]
    out = []
    for kb in range(len(edges) - 1):
        D = lag_sums(z, z, L, int(edges[kb]), int(edges[kb + 1]), n)
        Dfull = np.concatenate([D[:0:-1].transpose(0, 2, 1), D])  # index L - 1 + (b - a)
        T4 = np.empty((L, L, c, c))
        for a in range(L):
            T4[a] = Dfull[L - 1 - a : 2 * L - 1 - a]
        Phi = np.empty((k, k))
        for g1, (b1, q1) in enumerate(grp):
            for g2, (b2, q2) in enumerate(grp):
                blk = T4[b1, b2][:, :, q1, q2].transpose(0, 2, 1, 3)
                Phi[off[g1] : off[g1 + 1], off[g2] : off[g2 + 1]] = blk.reshape(
                    size[g1], size[g2])
        Me = np.hstack([M[kb + 1], M[kb]])
        Phi += Me @ np.hstack([M[kb + 1], -M[kb]]).T  # edge corrections, one GEMM
        out.append(Phi)
    return out
