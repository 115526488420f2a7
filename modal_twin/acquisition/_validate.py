"""Shared argument checks of the acquisition and identification stages (private)."""

from __future__ import annotations

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.errors import OptionError, ShapeError, SignalError

__all__ = ["as_channels", "check_positive", "check_rank"]


def as_channels(
    x: object, name: str, *, min_samples: int = 2, allow_constant: bool = True
) -> FloatArray:
    """Return ``x`` as a finite float array of shape (n_channels, n_samples).

    A 1-D input is one channel. Raises :class:`ShapeError` for other ranks or too few
    samples and :class:`SignalError` for NaN / Inf or (if not allowed) constant channels.
    """
    a = np.asarray(x, dtype=np.float64)
    if a.ndim == 1:
        a = a[np.newaxis, :]
    if a.ndim != 2:
        msg = f"{name}: expected (n_channels, n_samples) or (n_samples,), got shape {a.shape}"
        raise ShapeError(msg)
    if a.shape[1] < min_samples:
        msg = f"{name}: expected at least {min_samples} samples, got {a.shape[1]}"
        raise ShapeError(msg)
    if a.shape[0] < 1:
        msg = f"{name}: expected at least 1 channel, got shape {a.shape}"
        raise ShapeError(msg)
    bad = ~np.isfinite(a)
    if bad.any():
        ch = np.unique(np.nonzero(bad)[0]).tolist()
        msg = f"{name}: expected finite samples, got NaN/Inf in channel(s) {ch}"
        raise SignalError(msg)
    if not allow_constant:
        spread = np.ptp(a, axis=1)
        scale = np.max(np.abs(a), axis=1)
        const = spread <= 1e-12 * np.maximum(scale, np.finfo(float).tiny)
        if const.any():
            ch = np.nonzero(const)[0].tolist()
            msg = f"{name}: expected varying channels, got constant channel(s) {ch}"
            raise SignalError(msg)
    return a


def check_positive(value: float, name: str) -> float:
    """Return ``value`` as float if finite and > 0, else raise :class:`OptionError`."""
    v = float(value)
    if not np.isfinite(v) or v <= 0.0:
        msg = f"{name}: expected a finite value > 0, got {value!r}"
        raise OptionError(msg)
    return v


def check_rank(x: FloatArray, name: str, *, rtol: float = 1e-10) -> None:
    """Raise :class:`SignalError` if the channels of ``x`` are linearly dependent.

    The test is on the singular values of the channel matrix relative to the largest.
    """
    s = np.linalg.svd(x - x.mean(axis=1, keepdims=True), compute_uv=False)
    if s.size == 0 or s[0] == 0.0:
        msg = f"{name}: expected non-zero signals, got all channels constant"
        raise SignalError(msg)
    rank = int(np.sum(s > rtol * s[0]))
    if rank < x.shape[0]:
        msg = (
            f"{name}: expected {x.shape[0]} linearly independent channels, got rank {rank} "
            f"(singular value ratio {s[-1] / s[0]:.2e})"
        )
        raise SignalError(msg)
