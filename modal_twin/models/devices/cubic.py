"""Cubic (Duffing) stiffness: hardening (k3 > 0) or softening (k3 < 0), Eq. (3) of [003].

Per direction, uncoupled: ``f = k1 u + k3 u^3 + c u'`` (the K1, K3, D1 terms of Eq. (3) of
[003]; a softening spring loses stability beyond |u| = sqrt(k1 / (3 |k3|))).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from modal_twin._types import FloatArray
from modal_twin.errors import ModelError
from modal_twin.models.devices.base import KIND_CUBIC, Device, carry_state

__all__ = ["CubicSpring", "law_cubic"]


@njit(cache=True)
def law_cubic(p, s, u, v, f, Kt, Ct, s_new):  # pragma: no cover - jitted
    """p = [k1, k3, cx, cy, n_dir]."""
    nd = int(p[4])
    for i in range(2):
        for j in range(2):
            Kt[i, j] = 0.0
            Ct[i, j] = 0.0
        f[i] = 0.0
        if i >= nd:
            continue
        x = u[i]
        f[i] = p[0] * x + p[1] * x * x * x + p[2 + i] * v[i]  # Eq. (3) of [003]
        Kt[i, i] = p[0] + 3.0 * p[1] * x * x
        Ct[i, i] = p[2 + i]
    carry_state(s, u, s_new)


class CubicSpring(Device):
    """Cubic spring with viscous damping in 1 or 2 uncoupled directions.

    Parameters
    ----------
    k1 : float
        Linear stiffness, N/m.
    k3 : float
        Cubic coefficient, N/m^3 (positive hardening, negative softening).
    c : sequence of float
        Damping per direction, N s/m (length n_dir).
    name : str
        Label.
    """

    kind = KIND_CUBIC

    def __init__(self, k1: float, k3: float, c: list[float], *, name: str = "cubic") -> None:
        c = [float(x) for x in np.atleast_1d(c)]
        if k1 < 0 or min(c) < 0 or len(c) not in (1, 2):
            msg = f"k1, c: expected k1 >= 0, c >= 0 with 1 or 2 entries, got {k1}, {c}"
            raise ModelError(msg)
        n = len(c)
        cc = c + [0.0] * (2 - n)
        super().__init__([k1, k3, *cc, float(n)], n_dir=n, name=name)

    def reference_damping(self) -> FloatArray:
        """Return diag(c)."""
        return np.diag(self.params[2:4])
