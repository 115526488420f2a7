"""Scalar updating objectives of the seed papers, evaluated on a :class:`ModePairing`.

* :func:`frequency_mac_damping_cost` -- Eq. (3) of [004]: relative frequency error +
  ``w_mac (1 - MAC)`` + ``w_zeta`` relative damping error, summed over the identified modes
  (``inf`` when one is unmatched, Sec. 5.1 of [004]).
* :func:`weighted_frequency_mac_cost` -- Eqs. (11)-(12) of [002]: weighted mean of ``|df|``
  (percent) times ``alpha`` plus ``beta`` times the mean ``1 - MAC`` (percent).
* :func:`frequency_figure_of_merit` -- Eq. (1) of [000]: sum of squared relative frequency
  errors, and :func:`frequencies_converged`, the test of Eq. (2) of [000].
* :func:`close_match` -- the "close" criteria of Eqs. (6a)-(6c) of [004].
* :func:`relaxed_cost` -- Eq. (7) of [004], zero exactly when the close criteria hold.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from modal_twin._types import FloatArray
from modal_twin.errors import OptionError, ShapeError
from modal_twin.updating.matching import ModePairing

__all__ = [
    "close_match",
    "frequencies_converged",
    "frequency_figure_of_merit",
    "frequency_mac_damping_cost",
    "relaxed_cost",
    "weighted_frequency_mac_cost",
]


def _weights(w: ArrayLike | float, n: int, name: str) -> FloatArray:
    arr = np.broadcast_to(np.asarray(w, dtype=float), (n,)) if np.ndim(w) == 0 else \
        np.asarray(w, dtype=float)
    if arr.shape != (n,) or np.any(arr < 0.0) or not np.all(np.isfinite(arr)):
        msg = f"{name}: expected a scalar or ({n},) of finite values >= 0, got {np.shape(w)}"
        raise OptionError(msg)
    return np.asarray(arr, dtype=float)


def frequency_mac_damping_cost(pairing: ModePairing, *, w_mac: ArrayLike | float = 1.0,
             w_zeta: ArrayLike | float = 0.0) -> float:
    """Eq. (3) of [004]: ``J = sum_i |df_i| + w_mac_i (1 - MAC_i) + w_zeta_i |dzeta_i|``.

    Returns ``inf`` when any identified mode is unmatched. ``w_zeta > 0`` needs damping in
    the pairing.

    Examples
    --------
    >>> from modal_twin.updating.matching import match_modes
    >>> p = match_modes([1.0], [[1.0], [0.0]], [1.1], [[1.0], [0.0]])
    >>> round(frequency_mac_damping_cost(p), 6)
    0.1
    """
    n = pairing.fem_index.size
    wm = _weights(w_mac, n, "w_mac")
    wz = _weights(w_zeta, n, "w_zeta")
    if pairing.n_matched < n:
        return math.inf
    dz = np.where(wz > 0.0, np.abs(pairing.dzeta_rel), 0.0)
    if np.any(np.isnan(dz)):
        msg = "w_zeta: damping weights > 0 need zeta_id and zeta_fem in the pairing"
        raise OptionError(msg)
    J = np.abs(pairing.df_rel) + wm * (1.0 - pairing.mac) + wz * dz  # Eq. (3b) of [004]
    return float(J.sum())  # Eq. (3a) of [004]


def weighted_frequency_mac_cost(pairing: ModePairing, *, alpha: float = 1.0, beta: float = 0.25,
             gamma: ArrayLike | float = 1.0) -> float:
    """Eq. (11) of [002]: ``100 a / sum(g) sum(g |df|) + 100 b / n sum(1 - MAC)``.

    ``df`` is Eq. (12) of [002] (relative to the test frequency); [002] uses ``alpha = 1``,
    ``beta = 0.25`` and mode weights ``gamma`` in [0, 1]. ``inf`` if a mode is unmatched.
    """
    n = pairing.fem_index.size
    g = _weights(gamma, n, "gamma")
    if g.sum() <= 0.0:
        msg = "gamma: expected at least one positive mode weight, got all zero"
        raise OptionError(msg)
    if pairing.n_matched < n:
        return math.inf
    df = np.abs(pairing.df_rel)  # Eq. (12) of [002]: |f_test - f_fem| / f_test
    return float(100.0 * alpha / g.sum() * np.sum(g * df)
                 + 100.0 * beta / n * np.sum(1.0 - pairing.mac))  # Eq. (11) of [002]


def frequency_figure_of_merit(f_num: ArrayLike, f_exp: ArrayLike) -> float:
    """Eq. (1) of [000]: ``FOM = sum_j ((f_num_j - f_exp_j) / f_exp_j)^2``.

    Raises
    ------
    ShapeError
        Different lengths or a non-positive measured frequency.
    """
    a = np.asarray(f_num, dtype=float).ravel()
    b = np.asarray(f_exp, dtype=float).ravel()
    if a.shape != b.shape or b.size == 0 or np.any(b <= 0.0):
        msg = f"f_exp: expected {a.size} positive frequencies as f_num, got {b.tolist()}"
        raise ShapeError(msg)
    return float(np.sum(((a - b) / b) ** 2))  # Eq. (1) of [000]


def frequencies_converged(f_num: ArrayLike, f_exp: ArrayLike, eps: float = 0.01) -> bool:
    """Eq. (2) of [000]: ``sqrt(FOM) <= eps``."""
    return math.sqrt(frequency_figure_of_merit(f_num, f_exp)) <= eps  # Eq. (2) of [000]


def close_match(pairing: ModePairing, *, tol: float = 0.05, w_mac: float = 1.0,
                w_zeta: float = 0.0) -> bool:
    """Eqs. (6a)-(6c) of [004]: every pair within ``tol`` in frequency, MAC and damping.

    A criterion whose weight is zero is ignored, as in [004].
    """
    if pairing.n_matched < pairing.fem_index.size:
        return False
    ok = bool(np.all(np.abs(pairing.df_rel) < tol))  # Eq. (6a) of [004]
    if w_zeta > 0.0:
        ok &= bool(np.all(np.abs(pairing.dzeta_rel) < tol))  # Eq. (6b) of [004]
    if w_mac > 0.0:
        ok &= bool(np.all(1.0 - pairing.mac < tol))  # Eq. (6c) of [004]
    return ok


def relaxed_cost(pairing: ModePairing, *, tol: float = 0.05, w_mac: float = 1.0,
                 w_zeta: float = 0.0) -> float:
    """Eq. (7) of [004]: the relaxed cost that vanishes when Eqs. (6) hold.

    The printed Eq. (7) reads ``max{0, 0.05 - |error|}``, which would vanish for *large*
    errors; the text ("converged to 0, indicating that the close criteria (6) were met")
    fixes the sign used here: ``sum max{0, |error| - tol}``. ``inf`` if a mode is unmatched.
    """
    if pairing.n_matched < pairing.fem_index.size:
        return math.inf
    out = np.sum(np.maximum(0.0, np.abs(pairing.df_rel) - tol))
    out += w_mac * np.sum(np.maximum(0.0, (1.0 - pairing.mac) - tol))
    if w_zeta > 0.0:
        out += w_zeta * np.sum(np.maximum(0.0, np.abs(pairing.dzeta_rel) - tol))
    return float(out)  # Eq. (7) of [004]
