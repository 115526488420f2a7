"""Cubic (Duffing) stiffness, or any odd power: hardening (k3 > 0) or softening (k3 < 0).

Per direction, uncoupled: ``f = k1 u + k3 u |u|^(m - 1) + c u'``; with the default ``m = 3``
the K1, K3, D1 terms of Eq. (3) of [003] (``k3 u^3``; a softening spring then loses
stability beyond |u| = sqrt(k1 / (3 |k3|))). A free exponent ``m`` expresses elastic
nonlinearities of other smoothness (a quintic spring, a stiffening mount) with one more
parameter; ``k3`` is then in N/m^m.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from modal_twin._types import FloatArray
from modal_twin.errors import ModelError
from modal_twin.models.devices.base import KIND_CUBIC, Device, carry_state, clear_outputs

__all__ = ["CubicSpring", "law_cubic"]


@njit(cache=True)
def law_cubic(p, s, u, v, f, Kt, Ct, s_new):  # pragma: no cover - jitted
    """p = [k1, k3, cx, cy, n_dir, m, k1y]."""
    nd = int(p[4])
    m = p[5]
    clear_outputs(f, Kt, Ct)
    for i in range(2):
        if i >= nd:
            continue
        x = u[i]
        k1 = p[0] if i == 0 else p[6]
        if m == 3.0:
            f[i] = k1 * x + p[1] * x * x * x + p[2 + i] * v[i]  # Eq. (3) of [003]
            Kt[i, i] = k1 + 3.0 * p[1] * x * x
        else:
            a = abs(x) ** (m - 1.0)
            f[i] = k1 * x + p[1] * x * a + p[2 + i] * v[i]
            Kt[i, i] = k1 + m * p[1] * a
        Ct[i, i] = p[2 + i]
    carry_state(s, u, s_new)


class CubicSpring(Device):
    """Cubic spring with viscous damping in 1 or 2 uncoupled directions.

    Parameters
    ----------
    k1 : float
        Linear stiffness, N/m.
    k3 : float
        Coefficient of the power, N/m^m (positive hardening, negative softening).
    c : sequence of float
        Damping per direction, N s/m (length n_dir).
    name : str
        Label.
    m : float
        Exponent of the nonlinear term, in [2, 9] (3: Duffing).
    k1y : float, optional
        Linear stiffness in the second direction, N/m (default ``k1``).
    """

    kind = KIND_CUBIC

    def __init__(self, k1: float, k3: float, c: list[float], *, name: str = "cubic",
                 m: float = 3.0, k1y: float | None = None) -> None:
        c = [float(x) for x in np.atleast_1d(c)]
        if k1 < 0 or min(c) < 0 or len(c) not in (1, 2):
            msg = f"k1, c: expected k1 >= 0, c >= 0 with 1 or 2 entries, got {k1}, {c}"
            raise ModelError(msg)
        n = len(c)
        if not 2.0 <= m <= 9.0:
            msg = f"m: expected an exponent in [2, 9], got {m}"
            raise ModelError(msg)
        cc = c + [0.0] * (2 - n)
        ky = k1 if k1y is None else float(k1y)
        if ky < 0:
            msg = f"k1y: expected >= 0, got {k1y}"
            raise ModelError(msg)
        super().__init__([k1, k3, *cc, float(n), float(m), ky], n_dir=n, name=name)

    def reference_damping(self) -> FloatArray:
        """Return diag(c)."""
        return np.diag(self.params[2:4])
