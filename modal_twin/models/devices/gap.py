"""Gap / dead band: no force inside the clearance, a contact spring (and dashpot) beyond.

Per direction, uncoupled, with the overlap ``d = u - g`` beyond ``u > g`` (``d = u + g_neg``
below ``u < -g_neg``): ``f = k d (|d| / g)^(n - 1) + c u'``, else 0. ``n = 1`` (the
default) is a linear contact spring, ``n = 1.5`` a Hertz contact (``k`` is then the secant
stiffness at an overlap of one clearance ``g``); ``g_neg = g`` by default: a symmetric dead
band; a ``g_neg`` beyond any drift the device sees: a stop on one side only. Plus an optional
linear spring-dashpot beside it (``kp``, ``cp`` per direction: a bearing that hits a stop,
zero by default).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from modal_twin.errors import ModelError
from modal_twin.models.devices.base import KIND_GAP, Device, carry_state, clear_outputs

__all__ = ["GapSpring", "law_gap"]


@njit(cache=True)
def law_gap(p, s, u, v, f, Kt, Ct, s_new):  # pragma: no cover - jitted
    """p = [k, g, c, n_dir, kpx, kpy, cpx, cpy, g_neg, n]."""
    k = p[0]
    g = p[1]
    g_neg = p[8]
    n = p[9]
    d_ref = g if g > 0.0 else 1.0
    c = p[2]
    nd = int(p[3])
    clear_outputs(f, Kt, Ct)
    for i in range(2):
        if i >= nd:
            continue
        x = u[i]
        f[i] = p[4 + i] * x + p[6 + i] * v[i]
        Kt[i, i] = p[4 + i]
        Ct[i, i] = p[6 + i]
        if x > g:
            d = x - g
        elif x < -g_neg:
            d = x + g_neg
        else:
            continue
        ratio = (abs(d) / d_ref) ** (n - 1.0) if n != 1.0 else 1.0
        f[i] += k * d * ratio + c * v[i]
        Kt[i, i] += k * n * ratio
        Ct[i, i] += c
    carry_state(s, u, s_new)


class GapSpring(Device):
    """Dead-band contact spring.

    Parameters
    ----------
    k : float
        Contact stiffness, N/m.
    g : float
        Clearance on the positive side (the half-width of a symmetric gap), m.
    c : float
        Contact damping (active only in contact), N s/m.
    n_dir : int
        1 or 2 (uncoupled) directions.
    name : str
        Label.
    kp, cp : sequence of two float, optional
        Linear spring and dashpot beside the gap, per direction (none by default).
    g_neg : float, optional
        Clearance on the negative side, m (default ``g``).
    n : float
        Contact exponent, >= 1 (1: linear contact spring; 1.5: Hertz).
    """

    kind = KIND_GAP

    def __init__(
        self, k: float, g: float, c: float = 0.0, *, n_dir: int = 1, name: str = "gap",
        kp: tuple[float, float] = (0.0, 0.0), cp: tuple[float, float] = (0.0, 0.0),
        g_neg: float | None = None, n: float = 1.0,
    ) -> None:
        gn = g if g_neg is None else float(g_neg)
        if k < 0 or g < 0 or c < 0 or min(kp) < 0 or min(cp) < 0 or not gn >= 0:
            msg = (f"k, g, c, kp, cp, g_neg: expected non-negative, got {k}, {g}, {c}, {kp}, "
                   f"{cp}, {g_neg}")
            raise ModelError(msg)
        if not 1.0 <= n <= 4.0:
            msg = f"n: expected a contact exponent in [1, 4], got {n}"
            raise ModelError(msg)
        super().__init__([k, g, c, float(n_dir), *map(float, kp), *map(float, cp), gn,
                          float(n)], n_dir=n_dir, name=name)

    def reference_stiffness(self) -> np.ndarray:
        """Return the spring beside the gap (the gap is open at rest)."""
        return np.diag(self.params[4:6])

    def reference_damping(self) -> np.ndarray:
        """Return the dashpot beside the gap (moved into the linear modal damping)."""
        return np.diag(self.params[6:8])
