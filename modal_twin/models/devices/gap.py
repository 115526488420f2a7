"""Gap / dead band: no force inside |u| <= g, a contact spring (and dashpot) beyond.

Per direction, uncoupled: ``f = k (u - g sign(u)) + c u'`` for |u| > g, else 0.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from modal_twin.errors import ModelError
from modal_twin.models.devices.base import KIND_GAP, Device, carry_state

__all__ = ["GapSpring", "law_gap"]


@njit(cache=True)
def law_gap(p, s, u, v, f, Kt, Ct, s_new):  # pragma: no cover - jitted
    """p = [k, g, c, n_dir]."""
    k = p[0]
    g = p[1]
    c = p[2]
    nd = int(p[3])
    for i in range(2):
        for j in range(2):
            Kt[i, j] = 0.0
            Ct[i, j] = 0.0
        f[i] = 0.0
        if i >= nd:
            continue
        x = u[i]
        if x > g:
            f[i] = k * (x - g) + c * v[i]
        elif x < -g:
            f[i] = k * (x + g) + c * v[i]
        else:
            continue
        Kt[i, i] = k
        Ct[i, i] = c
    carry_state(s, u, s_new)


class GapSpring(Device):
    """Dead-band contact spring.

    Parameters
    ----------
    k : float
        Contact stiffness, N/m.
    g : float
        Half-width of the gap, m.
    c : float
        Contact damping (active only in contact), N s/m.
    n_dir : int
        1 or 2 (uncoupled) directions.
    name : str
        Label.
    """

    kind = KIND_GAP

    def __init__(
        self, k: float, g: float, c: float = 0.0, *, n_dir: int = 1, name: str = "gap"
    ) -> None:
        if k < 0 or g < 0 or c < 0:
            msg = f"k, g, c: expected non-negative, got {k}, {g}, {c}"
            raise ModelError(msg)
        super().__init__([k, g, c, float(n_dir)], n_dir=n_dir, name=name)

    def reference_stiffness(self) -> np.ndarray:
        """Return zeros (open gap at rest)."""
        return np.zeros((2, 2))
