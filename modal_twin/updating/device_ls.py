"""Isolator stiffness and damping from measured force and drift: Eqs. (1)-(2) of [004].

Each device direction is modelled as a linear spring-dashpot (Eq. (1) of [004])::

    f(t_l) = k x(t_l) + c x'(t_l)                                           (1)

and the ``N`` samples stacked give ``f = A [k c]'`` with ``A = [a_k a_c] = [x x']``
(Eq. (2) of [004]). [004] solves it with the pseudo-inverse; here the same least squares
is solved with the bounds ``k, c >= 0`` (``scipy.optimize.lsq_linear``), identical when the
unconstrained solution is physical. With the residue ``r = A [k c]' - f`` and its relative
size ``err_kc = ||r|| / ||f||`` (Table 6 of [004]), the updating bounds of [004] Sec. 4 are
the tightest range for which ``||r + a_k dk|| = rho ||r||`` (``rho = 1.5`` in [004])::

    dk_+- = (-r' a_k +- sqrt((r' a_k)^2 + (rho^2 - 1) ||a_k||^2 ||r||^2)) / ||a_k||^2

``LB = max(0, k + dk_-)``, ``UB = k + dk_+``; likewise for ``c`` with ``a_c``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import scipy.optimize as so
from numpy.typing import ArrayLike

from modal_twin._types import FloatArray
from modal_twin.errors import OptionError, ShapeError, SignalError

__all__ = ["DeviceKC", "device_kc", "fit_devices", "kc_bounds", "kc_nominal"]


@dataclass(frozen=True, slots=True)
class DeviceKC:
    """Linear spring-dashpot fit of one device direction (Table 6 of [004]).

    Attributes
    ----------
    k : float
        Stiffness, N/m.
    c : float
        Damping coefficient, N s/m.
    err_kc : float
        ``||r|| / ||f||``, the relative force prediction error.
    k_bounds, c_bounds : (float, float)
        Updating bounds (module docstring).
    n_samples : int
    """

    k: float
    c: float
    err_kc: float
    k_bounds: tuple[float, float]
    c_bounds: tuple[float, float]
    n_samples: int


def _bound(r: FloatArray, a: FloatArray, value: float, rho: float) -> tuple[float, float]:
    aa = float(a @ a)
    ra = float(r @ a)
    rr = float(r @ r)
    disc = math.sqrt(ra * ra + (rho * rho - 1.0) * aa * rr)  # Sec. 4 of [004]
    lo, hi = (-ra - disc) / aa, (-ra + disc) / aa
    return max(0.0, value + lo), value + hi


def device_kc(
    drift: ArrayLike, force: ArrayLike, *, velocity: ArrayLike | None = None,
    fs_hz: float | None = None, rho: float = 1.5, nonnegative: bool = True,
) -> DeviceKC:
    """Fit ``f = k x + c x'`` to one device direction (Eqs. (1)-(2) of [004]).

    Parameters
    ----------
    drift : (N,) array_like
        Drift across the device ``x``, m.
    force : (N,) array_like
        Restoring force ``f``, N.
    velocity : (N,) array_like, optional
        ``x'`` in m/s; if absent, central differences of ``drift`` at ``fs_hz``.
    fs_hz : float, optional
        Sample rate (needed without ``velocity``).
    rho : float
        Allowed residual growth of the bounds (1.5 in [004]); > 1.
    nonnegative : bool
        Solve with ``k, c >= 0``.

    Returns
    -------
    DeviceKC

    Raises
    ------
    ShapeError
        Different lengths or fewer than 3 samples.
    OptionError
        Neither ``velocity`` nor a positive ``fs_hz``; ``rho <= 1``.
    SignalError
        Non-finite samples, or a drift (or velocity) that is identically zero.

    Examples
    --------
    >>> t = np.arange(2000) / 100.0
    >>> x = 0.01 * np.sin(2 * np.pi * 0.7 * t)
    >>> fit = device_kc(x, 1.2e6 * x + 3e4 * np.gradient(x, 0.01), fs_hz=100.0)
    >>> round(fit.k / 1e6, 4), round(fit.c / 1e4, 4)
    (1.2, 3.0)
    """
    x = np.asarray(drift, dtype=float).ravel()
    f = np.asarray(force, dtype=float).ravel()
    if x.shape != f.shape or x.size < 3:
        msg = f"drift, force: expected equal lengths >= 3, got {x.size} and {f.size}"
        raise ShapeError(msg)
    if not rho > 1.0:
        msg = f"rho: expected a residual growth factor > 1, got {rho!r}"
        raise OptionError(msg)
    if velocity is None:
        if fs_hz is None or not fs_hz > 0.0:
            msg = f"fs_hz: expected a sample rate > 0 when velocity is not given, got {fs_hz!r}"
            raise OptionError(msg)
        v = np.gradient(x, 1.0 / fs_hz)
    else:
        v = np.asarray(velocity, dtype=float).ravel()
        if v.shape != x.shape:
            msg = f"velocity: expected {x.size} samples as drift, got {v.size}"
            raise ShapeError(msg)
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(f)) and np.all(np.isfinite(v))):
        msg = "drift, force, velocity: expected finite samples, got NaN or Inf"
        raise SignalError(msg)
    if not (np.any(x != 0.0) and np.any(v != 0.0)):
        msg = "drift: expected a moving device (non-zero drift and velocity), got all zeros"
        raise SignalError(msg)
    A = np.column_stack([x, v])  # Eq. (2) of [004]
    # columns scaled to unit norm so the solver sees a well-conditioned problem
    s = np.linalg.norm(A, axis=0)
    lb = 0.0 if nonnegative else -np.inf
    sol = so.lsq_linear(A / s, f, bounds=(lb, np.inf), method="bvls")
    k, c = (sol.x / s).tolist()
    r = A @ np.array([k, c]) - f  # residue of Eq. (2) of [004]
    nf = float(np.linalg.norm(f))
    return DeviceKC(k=float(k), c=float(c), err_kc=float(np.linalg.norm(r)) / nf if nf else 0.0,
                    k_bounds=_bound(r, x, k, rho), c_bounds=_bound(r, v, c, rho),
                    n_samples=int(x.size))


def fit_devices(
    drifts: Mapping[str, ArrayLike], forces: Mapping[str, ArrayLike], *, fs_hz: float,
    rho: float = 1.5,
) -> dict[str, DeviceKC]:
    """Fit every device direction (keys such as ``"RB1_x"``) with :func:`device_kc`.

    Raises
    ------
    OptionError
        A drift without a force (or the reverse).
    """
    if set(drifts) != set(forces):
        msg = (f"forces: expected the keys of drifts {sorted(drifts)}, got "
               f"{sorted(forces)}")
        raise OptionError(msg)
    return {key: device_kc(drifts[key], forces[key], fs_hz=fs_hz, rho=rho) for key in drifts}


def kc_nominal(fits: Mapping[str, DeviceKC]) -> dict[str, float]:
    """Nominal values ``{"k_<key>": k, "c_<key>": c}`` (parameter names of the building)."""
    out: dict[str, float] = {}
    for key, fit in fits.items():
        out[f"k_{key}"] = fit.k
        out[f"c_{key}"] = fit.c
    return out


def kc_bounds(fits: Mapping[str, DeviceKC], *, min_rel: float = 0.0
              ) -> dict[str, tuple[float, float]]:
    """Return updating bounds ``{"k_<key>": (LB, UB), "c_<key>": ...}`` (Table 6 of [004]).

    ``min_rel`` widens a range to at least ``value (1 -/+ min_rel)`` (a nearly exact fit gives
    a range too tight to absorb the modelling error of the rest of the structure).
    """
    out: dict[str, tuple[float, float]] = {}
    for key, fit in fits.items():
        for name, val, (lo, hi) in ((f"k_{key}", fit.k, fit.k_bounds),
                                    (f"c_{key}", fit.c, fit.c_bounds)):
            out[name] = (max(0.0, min(lo, val * (1.0 - min_rel))), max(hi, val * (1.0 + min_rel)))
    return out
