r"""H1 / H2 frequency response function estimators with coherence (Welch averaging).

With input spectra :math:`X` (n_in) and output spectra :math:`Y` (n_out) per block and
averages :math:`\langle\cdot\rangle` over blocks (Welch segments or repeated hits):

* :math:`S_{xx} = \langle X X^H \rangle`, :math:`S_{yx} = \langle Y X^H \rangle`,
  :math:`S_{yy} = \langle |Y|^2 \rangle`;
* :math:`H_1 = S_{yx} S_{xx}^{-1}` (noise on the outputs averages out);
* :math:`H_2 = S_{yy} / S_{xy}` (single input only; noise on the input averages out);
* multiple coherence :math:`\gamma^2_o = (H_1 S_{xy})_{oo} / S_{yy,oo}` in [0, 1]
  (the ordinary coherence :math:`|S_{yx}|^2 / (S_{xx} S_{yy}) = H_1 / H_2` for one input).

Spectral densities are one-sided, in unit^2/Hz (the ``density`` scaling of
:func:`scipy.signal.welch`); channels on the first axes, frequency on the last.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.signal as sig
from numpy.typing import ArrayLike

from modal_twin._types import ComplexArray, FloatArray
from modal_twin.errors import OptionError, ShapeError
from modal_twin.validation import as_channels, check_positive, check_rank

__all__ = ["FRFEstimate", "frf"]


@dataclass(frozen=True, slots=True)
class FRFEstimate:
    """FRFs, coherence and the averaged spectra they come from.

    Attributes
    ----------
    f_hz : ndarray, shape (n_f,)
        Frequencies in Hz.
    H1 : ndarray of complex, shape (n_out, n_in, n_f)
        H1 estimate (output unit per input unit). NaN at bins where :math:`S_{xx}` is
        singular (e.g. DC after detrending).
    H2 : ndarray of complex, shape (n_out, n_in, n_f)
        H2 estimate for a single input; all NaN when ``n_in > 1`` (not defined).
    coherence : ndarray, shape (n_out, n_f)
        Multiple coherence of each output with all inputs, in [0, 1].
    Sxx : ndarray of complex, shape (n_in, n_in, n_f)
    Syx : ndarray of complex, shape (n_out, n_in, n_f)
    Syy : ndarray, shape (n_out, n_f)
    n_averages : int
        Number of blocks averaged.
    """

    f_hz: FloatArray
    H1: ComplexArray
    H2: ComplexArray
    coherence: FloatArray
    Sxx: ComplexArray
    Syx: ComplexArray
    Syy: FloatArray
    n_averages: int


def _blocks(a: object, name: str, nperseg: int | None, noverlap: int | None) -> FloatArray:
    """Return blocks of shape (n_blocks, n_ch, n_per)."""
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim == 3:
        if nperseg is not None or noverlap is not None:
            msg = f"{name}: nperseg / noverlap must be None for repeated hits (3-D input)"
            raise OptionError(msg)
        for k in range(arr.shape[0]):
            as_channels(arr[k], f"{name}[{k}]")
        return arr
    x = as_channels(arr, name)
    n = x.shape[1]
    nps = n // 8 if nperseg is None else int(nperseg)
    if not 2 <= nps <= n:
        msg = f"nperseg: expected 2 <= nperseg <= n_samples = {n}, got {nps}"
        raise OptionError(msg)
    nov = nps // 2 if noverlap is None else int(noverlap)
    if not 0 <= nov < nps:
        msg = f"noverlap: expected 0 <= noverlap < nperseg = {nps}, got {nov}"
        raise OptionError(msg)
    view = np.lib.stride_tricks.sliding_window_view(x, nps, axis=-1)[:, :: nps - nov, :]
    return np.ascontiguousarray(view.transpose(1, 0, 2))


def frf(
    x: ArrayLike,
    y: ArrayLike,
    fs_hz: float,
    *,
    nperseg: int | None = None,
    noverlap: int | None = None,
    window: str | tuple[str, float] | None = None,
    detrend: Literal["constant", "linear", False] = "constant",
) -> FRFEstimate:
    """Estimate H1, H2 and coherence from inputs ``x`` and outputs ``y``.

    Parameters
    ----------
    x : array_like, shape (n_in, n_samples) or (n_hits, n_in, n_samples)
        Inputs (forces, base accelerations). A 3-D array holds repeated hits / bursts:
        each hit is one block and the estimate averages over hits.
    y : array_like, shape (n_out, n_samples) or (n_hits, n_out, n_samples)
        Outputs, same layout as ``x``.
    fs_hz : float
        Sample rate in Hz.
    nperseg, noverlap : int, optional
        Welch segment length (default ``n_samples // 8``) and overlap (default half).
        Must be None for 3-D input.
    window : str or tuple, optional
        Any :func:`scipy.signal.get_window` spec; default ``"hann"`` for Welch segments and
        ``"boxcar"`` for hits.
    detrend : {"constant", "linear", False}
        Detrending of each block before the FFT.

    Returns
    -------
    FRFEstimate

    Raises
    ------
    ShapeError
        ``x`` and ``y`` differ in samples or hits, or fewer blocks than inputs.
    SignalError
        NaN / Inf or linearly dependent inputs (H1 undefined).
    OptionError
        Bad segment options or unknown ``detrend``.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(4096)
    >>> est = frf(u, 2.0 * u, 100.0, nperseg=256)
    >>> bool(np.allclose(est.H1[0, 0, 1:], 2.0)), bool(np.allclose(est.coherence[0, 1:], 1.0))
    (True, True)
    """
    fs = check_positive(fs_hz, "fs_hz")
    if detrend not in ("constant", "linear", False):
        msg = f"detrend: expected one of ('constant', 'linear', False), got {detrend!r}"
        raise OptionError(msg)
    xa, ya = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    if (
        xa.ndim != ya.ndim
        or xa.shape[-1] != ya.shape[-1]
        or (xa.ndim == 3 and xa.shape[0] != ya.shape[0])
    ):
        msg = f"x, y: expected the same hits and samples, got shapes {xa.shape} and {ya.shape}"
        raise ShapeError(msg)
    xb = _blocks(xa, "x", nperseg, noverlap)
    yb = _blocks(ya, "y", nperseg, noverlap)
    n_blk, n_in, n_per = xb.shape
    if n_blk < n_in:
        msg = f"x: expected at least n_in = {n_in} averages for H1, got {n_blk} blocks"
        raise ShapeError(msg)
    check_rank(xb.transpose(1, 0, 2).reshape(n_in, -1), "x")
    win = ("boxcar" if xa.ndim == 3 else "hann") if window is None else window
    w = sig.get_window(win, n_per)
    if detrend:
        xb = sig.detrend(xb, axis=-1, type=detrend)
        yb = sig.detrend(yb, axis=-1, type=detrend)
    X = np.fft.rfft(xb * w, axis=-1)
    Y = np.fft.rfft(yb * w, axis=-1)
    scale = np.full(X.shape[-1], 2.0 / (fs * np.sum(w**2) * n_blk))
    scale[0] /= 2.0
    if n_per % 2 == 0:
        scale[-1] /= 2.0
    Sxx = np.einsum("bif,bjf->ijf", X, X.conj()) * scale
    Syx = np.einsum("bof,bif->oif", Y, X.conj()) * scale
    Syy = np.einsum("bof,bof->of", Y, Y.conj()).real * scale
    # bins where Sxx is numerically singular (DC after detrend, notches of the input)
    Sf = np.moveaxis(Sxx, -1, 0)
    ev = np.linalg.eigvalsh(Sf)
    ok = ev[:, 0] > 1e-10 * max(float(ev[:, -1].max()), np.finfo(float).tiny)
    H1 = np.full(Syx.shape, np.nan + 1j * np.nan)
    sol = np.linalg.solve(Sf[ok].conj(), np.moveaxis(Syx, -1, 0)[ok].transpose(0, 2, 1))
    H1[..., ok] = sol.transpose(2, 1, 0)  # H1 = Syx Sxx^-1 (Sxx Hermitian)
    gam = np.einsum("oif,oif->of", H1, Syx.conj()).real
    with np.errstate(invalid="ignore", divide="ignore"):
        coh = np.where(Syy > 0, gam / np.where(Syy > 0, Syy, 1.0), 0.0)
    coh = np.clip(np.nan_to_num(coh, nan=0.0), 0.0, 1.0)
    H2 = np.full(Syx.shape, np.nan + 1j * np.nan)
    if n_in == 1:
        with np.errstate(invalid="ignore", divide="ignore"):
            H2[:, 0, :] = np.where(ok, Syy / Syx[:, 0, :].conj(), np.nan)
    f = np.asarray(np.fft.rfftfreq(n_per, 1.0 / fs), dtype=np.float64)
    return FRFEstimate(f, H1, H2, coh, Sxx, Syx, Syy, int(n_blk))
