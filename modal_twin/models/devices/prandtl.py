"""Prandtl slip hysteresis joint of [003]: cubic stiffness, damping and slip memory.

Eq. (3) of [003] (diagonal joint force)::

    F = K1 x + D1 x' + K2 x^2 + K3 x^3 + F_M(x, x')

with the slip memory F_M of Eqs. (6)-(12) of [003]: after a reversal at ``x = -sign(x') dn``
the force leaves with the initial (stuck) slope Kb and reaches the slip force Fs at
``x = sign(x') dc`` along the cubic in ``xi = |x - sign(x') dc|`` with coefficients
C1 = Kb exp(-|dn - dc| / dc) (Eq. 9), C2 (Eq. 10), C3 (Eq. 11), dc = Fs / Kb (Eq. 7),
dn = |x| at the reversal (Eq. 8); below dc the joint is linear (first case of Eq. 6).

Sign convention: [003] writes F_M as the force on the joint (``-Kb x`` when stuck); here the
restoring force ``r = -F_M`` is used so that it adds to K1 x (stuck stiffness K1 + Kb,
softening to K1 when slipping), which is the behaviour [003] reports.

Generalisation (documented, not in [003]): Eq. (6) assumes symmetric cycles (reversal at
-sign(x') dn with force -sign(x') Fs). For general paths the branch is the cubic Hermite
from the actual reversal point (x_r, r_r, slope Kb) to (sign(x') dc, sign(x') Fs, slope C1);
for symmetric cycles its coefficients reduce exactly to Eqs. (10)-(11). A reversal beyond
the target point reloads with slope Kb up to the slip force. Reversals are detected on the
displacement increment between committed steps. For dn > ~5 dc the cubic of Eq. (6)
overshoots Fs (a property of the published law).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from modal_twin._types import FloatArray
from modal_twin.errors import ModelError
from modal_twin.models.devices.base import KIND_PRANDTL, N_STATE, Device, copy_state

__all__ = ["PrandtlJoint", "law_prandtl", "prandtl_branch", "table2_mode_bay"]


@njit(cache=True)
def prandtl_branch(x, d, xr, rr, elastic, Fs, Kb):  # pragma: no cover - jitted
    """Return (r, dr/dx) of the slip element on the branch (direction d, reversal xr, rr)."""
    dc = Fs / Kb  # Eq. (7) of [003]
    if elastic > 0.5:
        r = Kb * x  # Eq. (6) of [003], first case (stuck, r = -F_M)
        if d * r >= Fs:
            return d * Fs, 0.0  # Eq. (6), third / fifth cases
        return r, Kb
    if d * xr < dc:
        L = dc - d * xr  # = dn + dc for a symmetric cycle
        xi = dc - d * x  # Eq. (12) of [003], xi = |x - sign(x') dc| on the branch
        if xi <= 0.0:
            return d * Fs, 0.0
        D = Fs - d * rr  # force change along the branch (= 2 Fs in Eq. (6))
        dn = abs(xr)  # Eq. (8) of [003]
        C1 = Kb * math.exp(-abs(dn - dc) / dc)  # Eq. (9) of [003]
        C2 = (3.0 * D - Kb * L) / (L * L) - 2.0 * C1 / L  # Eq. (10) of [003] (D = 2 Fs)
        C3 = (-2.0 * D + Kb * L) / (L * L * L) + C1 / (L * L)  # Eq. (11) of [003]
        pv = ((C3 * xi + C2) * xi + C1) * xi
        dp = (3.0 * C3 * xi + 2.0 * C2) * xi + C1
        return d * Fs - d * pv, dp  # Eq. (6) of [003], second / fourth cases
    r = rr + Kb * (x - xr)
    if d * r >= Fs:
        return d * Fs, 0.0
    return r, Kb


@njit(cache=True)
def law_prandtl(p, s, u, v, f, Kt, Ct, s_new):  # pragma: no cover - jitted
    """Eq. (3) of [003] with F_M of Eqs. (6)-(12); p = [K1, K2, K3, D1, Fs, Kb].

    State: s[0] x_prev, s[2] direction, s[3] x_r, s[4] r_r, s[5] r_prev, s[6] elastic flag.
    """
    K1 = p[0]
    K2 = p[1]
    K3 = p[2]
    D1 = p[3]
    Fs = p[4]
    Kb = p[5]
    x = u[0]
    copy_state(s, s_new)
    d = s[2]
    xr = s[3]
    rr = s[4]
    el = s[6]
    dx = x - s[0]
    nd = 1.0 if dx > 0.0 else (-1.0 if dx < 0.0 else d)
    if nd != d:
        if d != 0.0:  # Eq. (8) of [003]: reversal, memory set at the last committed point
            xr = s[0]
            rr = s[5]
            el = 1.0 if (abs(xr) < Fs / Kb and abs(rr - Kb * xr) <= 1e-9 * Fs) else 0.0
        d = nd
    if Fs > 0.0 and d != 0.0:
        r, kr = prandtl_branch(x, d, xr, rr, el, Fs, Kb)
    else:
        r = Kb * x if Fs > 0.0 else 0.0
        kr = Kb if Fs > 0.0 else 0.0
    f[0] = K1 * x + D1 * v[0] + K2 * x * x + K3 * x * x * x + r  # Eq. (3) of [003]
    f[1] = 0.0
    for i in range(2):
        for j in range(2):
            Kt[i, j] = 0.0
            Ct[i, j] = 0.0
    Kt[0, 0] = K1 + 2.0 * K2 * x + 3.0 * K3 * x * x + kr
    Ct[0, 0] = D1
    s_new[0] = x
    s_new[1] = 0.0
    s_new[2] = d
    s_new[3] = xr
    s_new[4] = rr
    s_new[5] = r
    s_new[6] = el


class PrandtlJoint(Device):
    """Uniaxial joint of Eq. (3) of [003]: cubic stiffness, damping, Prandtl slip memory.

    Parameters
    ----------
    K1, K2, K3 : float
        Polynomial stiffness coefficients, N/m, N/m^2, N/m^3.
    D1 : float
        Linear damping, N s/m.
    Fs : float
        Slip force, N (0 disables the memory term).
    Kb : float
        Stuck (initial) slip-element stiffness, N/m.
    name : str
        Label.
    """

    kind = KIND_PRANDTL

    def __init__(
        self,
        K1: float,
        K2: float,
        K3: float,
        D1: float,
        Fs: float,
        Kb: float,
        *,
        name: str = "prandtl",
    ) -> None:
        if Fs < 0 or Kb <= 0 or D1 < 0:
            msg = f"Fs, Kb, D1: expected Fs >= 0, Kb > 0, D1 >= 0, got {Fs}, {Kb}, {D1}"
            raise ModelError(msg)
        super().__init__([K1, K2, K3, D1, Fs, Kb], n_dir=1, name=name)

    def initial_state(self) -> FloatArray:
        """Return the virgin state: no direction yet, on the stuck (elastic) line."""
        s = np.zeros(N_STATE)
        s[6] = 1.0
        return s

    def reference_damping(self) -> FloatArray:
        """Return diag(D1, 0)."""
        return np.diag([self.params[3], 0.0])


# Table 2 of [003], low preload, diagonal terms F11, F22, F44, F55, F66 (SI).
_TABLE2_LOW = {
    "F11": (1.471e5, -8.894e7, -1.008e12, 1.121e2, 1.586, 6.201e4),
    "F22": (1.607e5, -1.729e7, -1.157e12, 1.193e2, 1.292, 6.219e4),
    "F44": (4.965e4, 1.780e6, -1.114e11, 2.290e1, 0.412, 6.908e3),
    "F55": (4.840e4, -1.039e7, -8.823e10, 2.209e1, 0.525, 7.775e3),
    "F66": (3.023e3, -1.799e4, -1.205e8, 2.269e0, 0.338, 1.352e3),
}


def table2_mode_bay(term: str) -> PrandtlJoint:
    """Return a low-preload MODE-bay diagonal joint term, Table 2 of [003] (SI units).

    Raises
    ------
    ModelError
        For an unknown term label.
    """
    if term not in _TABLE2_LOW:
        msg = f"term: expected one of {sorted(_TABLE2_LOW)}, got {term!r}"
        raise ModelError(msg)
    return PrandtlJoint(*_TABLE2_LOW[term], name=term)
