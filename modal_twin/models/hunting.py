"""Hunting of the 3D vehicle: critical speed by an eigenvalue sweep, the hunting branch.

The linear vehicle (:class:`modal_twin.models.vehicle3d.Vehicle3D`) at speed ``V`` has the
state matrix ``A(V)``; its kinematic modes (wheelset lateral and yaw motion, Klingel's
oscillation coupled to the bogies and the carbody) lose damping as the creep damping
``~ 1 / V`` falls (:mod:`modal_twin.models.wheel_rail`). The critical speed is where the
least-damped kinematic mode's damping ratio crosses zero: a sweep brackets it and Brent's
method refines it. The mode that goes unstable is then followed back to lower speeds by
eigenvalue continuation (:func:`hunting_branch`), naming the hunting mode at speeds where
another mode is the least damped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.optimize

from modal_twin._types import FloatArray
from modal_twin.errors import ConvergenceError, OptionError
from modal_twin.models.vehicle3d import Vehicle3D

__all__ = ["HuntingResult", "critical_speed", "hunting_branch"]


@dataclass(frozen=True, slots=True)
class HuntingResult:
    """Eigenvalue sweep over speed and the hunting critical speed.

    Attributes
    ----------
    speeds : (n,) float array
        Swept speeds, m/s.
    zeta : (n,) float array
        Damping ratio of the least-damped oscillatory mode at each speed.
    f_hz : (n,) float array
        Its frequency, Hz.
    v_critical : float
        Speed where ``zeta`` crosses zero (refined by Brent's method), m/s; ``inf`` when it
        stays positive over the sweep.
    f_critical_hz : float
        Frequency of that mode at ``v_critical`` (nan when none).
    """

    speeds: FloatArray
    zeta: FloatArray
    f_hz: FloatArray
    v_critical: float
    f_critical_hz: float


def critical_speed(vehicle: Vehicle3D, speeds: FloatArray | None = None) -> HuntingResult:
    """Sweep the least-damped oscillatory mode over ``speeds`` and find the zero crossing.

    Parameters
    ----------
    vehicle : Vehicle3D
    speeds : (n,) float array, optional
        Increasing speeds, m/s (default 10 .. 200 m/s in 5 m/s steps).

    Raises
    ------
    OptionError
        Speeds not positive and increasing.
    ConvergenceError
        Brent's refinement does not converge.
    """
    V = np.arange(10.0, 200.01, 5.0) if speeds is None else np.asarray(speeds, dtype=float)
    if V.ndim != 1 or V.size < 2 or np.any(V <= 0) or np.any(np.diff(V) <= 0):
        msg = "speeds: expected at least two positive, increasing speeds (m/s)"
        raise OptionError(msg)
    res = [vehicle.least_damped(float(s)) for s in V]
    z = np.array([r[0] for r in res])
    f = np.array([r[1] for r in res])
    neg = np.flatnonzero(z < 0.0)
    if neg.size == 0:
        return HuntingResult(V, z, f, math.inf, math.nan)
    i = int(neg[0])
    if i == 0:
        return HuntingResult(V, z, f, float(V[0]), float(f[0]))
    try:
        vc = float(scipy.optimize.brentq(lambda s: vehicle.least_damped(s)[0],
                                         float(V[i - 1]), float(V[i]), xtol=1e-3))
    except (ValueError, RuntimeError) as err:
        msg = f"critical speed: Brent's method failed between {V[i - 1]} and {V[i]} m/s: {err}"
        raise ConvergenceError(msg) from err
    return HuntingResult(V, z, f, vc, vehicle.least_damped(vc)[1])


def hunting_branch(vehicle: Vehicle3D, hunting: HuntingResult, speeds: FloatArray, *,
                   step: float = 1.0) -> tuple[FloatArray, FloatArray]:
    """Follow the mode that loses stability at the critical speed down (or up) in speed.

    From the critical eigenvalue at ``hunting.v_critical`` the eigenvalue nearest to the
    previous one is taken at every ``step`` (m/s) towards each of ``speeds`` (continuation
    of one eigenvalue branch), so the hunting mode is named at speeds where another mode
    is the least damped.

    Returns
    -------
    zeta, f_hz : (n,) float arrays
        Damping ratio and frequency (Hz) of the branch at ``speeds`` (nan when there is
        no critical speed).

    Raises
    ------
    OptionError
        ``step`` not positive.
    """
    V = np.asarray(speeds, dtype=float)
    zeta, f = np.full(V.size, math.nan), np.full(V.size, math.nan)
    if not math.isfinite(hunting.v_critical):
        return zeta, f
    if not (math.isfinite(step) and step > 0.0):
        msg = f"step: expected a positive speed step (m/s), got {step!r}"
        raise OptionError(msg)
    vc = hunting.v_critical
    lam_c = complex(0.0, 2.0 * math.pi * hunting.f_critical_hz)
    for sign in (-1.0, 1.0):
        idx = np.flatnonzero((V - vc) * sign >= 0.0)
        if idx.size == 0:
            continue
        far = float(np.max(np.abs(V[idx] - vc)))
        path = vc + sign * np.append(np.arange(0.0, far, step), far)
        lam = lam_c
        found = {}
        for v in path:
            eig = vehicle.eigenvalues(float(v))
            lam = complex(eig[np.argmin(np.abs(eig - lam))])
            found[float(v)] = lam
        keys = np.array(sorted(found))
        for i in idx:
            k = keys[np.argmin(np.abs(keys - V[i]))]
            if abs(k - V[i]) > 1e-9:  # off the path: one more step onto it
                eig = vehicle.eigenvalues(float(V[i]))
                lam_i = complex(eig[np.argmin(np.abs(eig - found[float(k)]))])
            else:
                lam_i = found[float(k)]
            zeta[i] = -lam_i.real / abs(lam_i)
            f[i] = lam_i.imag / (2.0 * math.pi)
    return zeta, f
