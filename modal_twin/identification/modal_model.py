"""Result records of the identification stage (frozen, slotted dataclasses).

Conventions: frequencies in Hz, damping ratio ``zeta`` as a fraction of critical, mode
shapes complex with channels on the first axis and modes on the last, each normalised so
that its largest entry is 1 (real).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modal_twin._types import BoolArray, ComplexArray, FloatArray, IntArray

__all__ = ["ModalModel", "PoleSet", "PoleSweep", "StabilizationDiagram", "normalize_shapes"]


def normalize_shapes(shapes: ComplexArray) -> ComplexArray:
    """Scale each column so that its entry of largest modulus is 1 (real).

    Parameters
    ----------
    shapes : ndarray of complex, shape (n_ch, n_modes)

    Returns
    -------
    ndarray of complex, shape (n_ch, n_modes)
    """
    s = np.asarray(shapes, dtype=np.complex128)
    if s.size == 0:
        return s.reshape(s.shape[0] if s.ndim == 2 else 0, -1)
    k = np.argmax(np.abs(s), axis=0)
    ref = s[k, np.arange(s.shape[1])]
    ref = np.where(ref == 0, 1.0, ref)
    out: ComplexArray = s / ref
    return out


@dataclass(frozen=True, slots=True)
class PoleSet:
    r"""Poles of one model order (one of each complex-conjugate pair, Im > 0).

    Attributes
    ----------
    order : int
        Model order (state dimension for SSI, polynomial order for PolyMAX).
    f_hz : ndarray, shape (n_poles,)
        Undamped natural frequencies :math:`|\lambda| / 2\pi` in Hz.
    zeta : ndarray, shape (n_poles,)
        Damping ratios :math:`-\mathrm{Re}\,\lambda / |\lambda|`.
    shapes : ndarray of complex, shape (n_ch, n_poles)
        Mode shapes at the output channels.
    std_f_hz, std_zeta : ndarray, shape (n_poles,)
        Standard deviations (NaN when not estimated).
    """

    order: int
    f_hz: FloatArray
    zeta: FloatArray
    shapes: ComplexArray
    std_f_hz: FloatArray
    std_zeta: FloatArray


@dataclass(frozen=True, slots=True)
class PoleSweep:
    """Poles of an estimator over a range of model orders.

    Attributes
    ----------
    method : str
        ``"n4sid"``, ``"ssi-cov"`` or ``"polymax"``.
    orders : ndarray of int, shape (n_orders,)
    poles : tuple of PoleSet, length n_orders
    singular_values : ndarray, shape (n_sv,)
        Singular values of the factorised matrix (SSI), descending; with more than 500
        observability rows only the leading max(2 n_max, 100); empty for PolyMAX.
    n_blocks_std : int
        Number of data blocks behind the standard deviations (0 = not estimated).
    """

    method: str
    orders: IntArray
    poles: tuple[PoleSet, ...]
    singular_values: FloatArray
    n_blocks_std: int


@dataclass(frozen=True, slots=True)
class StabilizationDiagram:
    """Poles over model orders with the stability flags of [004] sec. 3.

    Attributes
    ----------
    method : str
    orders : ndarray of int, shape (n_orders,)
    poles : tuple of PoleSet, length n_orders
    stable_f, stable_zeta, stable_mac : tuple of bool ndarray, one per order
        Per pole: frequency / damping / MAC criterion met against the next order
        (the last order is compared with the one below).
    stable : tuple of bool ndarray
        All three criteria met.
    rel_tol_f, rel_tol_zeta, mac_min : float
        Criteria used.
    """

    method: str
    orders: IntArray
    poles: tuple[PoleSet, ...]
    stable_f: tuple[BoolArray, ...]
    stable_zeta: tuple[BoolArray, ...]
    stable_mac: tuple[BoolArray, ...]
    stable: tuple[BoolArray, ...]
    rel_tol_f: float
    rel_tol_zeta: float
    mac_min: float


@dataclass(frozen=True, slots=True)
class ModalModel:
    """Identified physical modes.

    Attributes
    ----------
    f_hz : ndarray, shape (n_modes,)
        Natural frequencies in Hz, ascending.
    zeta : ndarray, shape (n_modes,)
        Damping ratios (fraction).
    shapes : ndarray of complex, shape (n_ch, n_modes)
        Complex mode shapes at the output channels (largest entry = 1).
    std_f_hz, std_zeta : ndarray, shape (n_modes,)
        Standard deviations (NaN when not estimated).
    method : str
        Estimator that produced the poles.
    order : int
        Highest model order whose pole represents a mode.
    mode_orders : ndarray of int, shape (n_modes,)
        Model order of each representative pole.
    n_support : ndarray of int, shape (n_modes,)
        Number of stable poles in each mode's cluster.
    """

    f_hz: FloatArray
    zeta: FloatArray
    shapes: ComplexArray
    std_f_hz: FloatArray
    std_zeta: FloatArray
    method: str
    order: int
    mode_orders: IntArray
    n_support: IntArray
