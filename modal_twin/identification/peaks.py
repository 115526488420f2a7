r"""Whether a mode stands on a peak of a response spectrum: the one test of both selections.

A pole that a model fits consistently over its orders is a mode of the response only where
a spectrum of the response rises to a peak at its frequency: the highest line within the
mode's half-width w is a local maximum standing at least a given ratio above the median
of the spectrum on its flanks, :data:`FLANK` = 3w-6w on both sides (as the prominence of
an FDD peak; the median of the flanks, not their lowest point, so that the scatter of a
Welch estimate on a neighbour's flank does not make a peak), or, on a smooth spectrum, any
local maximum within w whose topographic prominence (:func:`scipy.signal.find_peaks`:
its height above the higher of the lowest points between it and higher ground on either
side) is that ratio. Used by the clustering of
the subspace methods (:func:`~modal_twin.identification.clustering.spectral_peak`: the
output PSD projected on the mode's shape, the enhanced FDD spectrum of Brincker et al.
2001) and by output-only PolyMAX
(:func:`~modal_twin.identification.polymax_oma.spectral_support`: the first singular
value of the half-spectra's PSD, smooth by the lag window: topographic prominence; the
flanks' median there drops 1 and adds 1 mode seen by neither reference on the real
records, ``test/benchmarks/bench_real_modes.py``).
"""

from __future__ import annotations

import numpy as np
import scipy.signal as sig
from numpy.typing import ArrayLike

from modal_twin._types import BoolArray

__all__ = ["FLANK", "on_peak"]

FLANK = (3.0, 6.0)
"""The flanks a peak is measured against: 3 to 6 half-widths from the mode, beyond its
own half-power band and before the next mode's in most spectra."""


def on_peak(f_hz: ArrayLike, p: ArrayLike, f0_hz: ArrayLike, half_hz: ArrayLike,
            ratio: float, flank: tuple[float, float] | None = FLANK) -> BoolArray:
    """Whether each frequency ``f0_hz`` stands on a peak of the spectrum ``p`` (module text).

    Parameters
    ----------
    f_hz : (n_f,) array
        Lines.
    p : (n_f,) array
        Power spectrum (linear, >= 0) on those lines.
    f0_hz, half_hz : array_like, broadcast to (n_modes,)
        Modes' frequencies and the half-width w in which their peak must lie.
    ratio : float
        Least height of the peak over its surroundings (> 1).
    flank : (float, float) or None
        The surroundings: the median of ``p`` this many half-widths from ``f0_hz`` on both
        sides; None: the peak's topographic prominence over the whole spectrum.

    Returns
    -------
    BoolArray, (n_modes,)
        Whether a local maximum within w stands ``ratio`` above its surroundings. With
        ``flank``: the highest line within w, and True where no line lies within w or none
        on the flanks (not judged).

    Examples
    --------
    >>> f = np.linspace(0.0, 10.0, 201)
    >>> p = 1.0 / ((f**2 - 4.0) ** 2 + (0.1 * f) ** 2)   # one resonance at 2 Hz
    >>> on_peak(f, p, [2.02, 2.6, 5.0], [0.05, 0.05, 0.05], 2.0).tolist()
    [True, False, False]
    >>> on_peak(f, p, [2.02, 2.6, 5.0], [0.05, 0.05, 0.05], 2.0, flank=None).tolist()
    [True, False, False]
    """
    f = np.asarray(f_hz, dtype=float)
    pw = np.asarray(p, dtype=float)
    f0, half = np.broadcast_arrays(np.atleast_1d(np.asarray(f0_hz, dtype=float)),
                                   np.asarray(half_hz, dtype=float))
    if flank is None:
        db = 10.0 * np.log10(np.maximum(pw, 1e-300))
        fp = f[sig.find_peaks(db, prominence=10.0 * np.log10(ratio))[0]]
        if fp.size == 0:
            return np.zeros(f0.shape, dtype=bool)
        gap: BoolArray = np.min(np.abs(fp[None, :] - f0[:, None]), axis=1) <= half
        return gap
    out = np.ones(f0.shape, dtype=bool)
    for m, (fm, w) in enumerate(zip(f0, half, strict=True)):
        d = np.abs(f - fm)
        core, side = np.nonzero(d <= w)[0], (d >= flank[0] * w) & (d <= flank[1] * w)
        if core.size == 0 or not side.any():
            continue
        k = int(core[np.argmax(pw[core])])
        inner = 0 < k < pw.size - 1 and pw[k] >= pw[k - 1] and pw[k] >= pw[k + 1]
        out[m] = bool(inner and pw[k] >= ratio * np.median(pw[side]))
    return out
