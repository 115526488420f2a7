"""Detrending: remove the mean or a (piecewise) linear trend from each channel."""

from __future__ import annotations

from typing import Literal

import numpy as np
import scipy.signal as sig
from numpy.typing import ArrayLike

from modal_twin._types import FloatArray
from modal_twin.errors import OptionError
from modal_twin.validation import as_channels

__all__ = ["detrend"]

_KINDS = ("constant", "linear")


def detrend(
    x: ArrayLike,
    *,
    kind: Literal["constant", "linear"] = "linear",
    breakpoints: ArrayLike | None = None,
) -> FloatArray:
    """Remove the mean (``"constant"``) or a least-squares line (``"linear"``) per channel.

    Thin validated wrapper of :func:`scipy.signal.detrend` along the last (time) axis,
    as applied before filtering in sec. 3 of [004].

    Parameters
    ----------
    x : array_like, shape (n_channels, n_samples) or (n_samples,)
    kind : {"constant", "linear"}
    breakpoints : array_like of int, optional
        Sample indices where a piecewise linear trend may break (``kind="linear"`` only).

    Returns
    -------
    ndarray, shape (n_channels, n_samples)

    Raises
    ------
    OptionError
        If ``kind`` is unknown or a breakpoint lies outside the record.

    Examples
    --------
    >>> bool(np.abs(detrend([1.0, 2.0, 3.0])).max() < 1e-12)
    True
    """
    if kind not in _KINDS:
        msg = f"kind: expected one of {_KINDS}, got {kind!r}"
        raise OptionError(msg)
    a = as_channels(x, "x", min_samples=2)
    bp: int | np.ndarray = 0
    if breakpoints is not None:
        bp = np.asarray(breakpoints, dtype=np.int64)
        if np.any(bp <= 0) or np.any(bp >= a.shape[1]):
            msg = f"breakpoints: expected indices in (0, {a.shape[1]}), got {bp.tolist()}"
            raise OptionError(msg)
    out: FloatArray = sig.detrend(a, axis=-1, type=kind, bp=bp)
    return out
