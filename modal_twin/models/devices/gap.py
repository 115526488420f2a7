"""Gap / dead band: no force inside |u| <= g, a contact spring (and dashpot) beyond.

Per direction, uncoupled: ``f = k (u - g sign(u)) + c u'`` for |u| > g, else 0; plus an
optional linear spring-dashpot beside it (``kp``, ``cp`` per direction: a bearing that
hits a stop, zero by default).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from modal_twin.errors import ModelError
from modal_twin.models.devices.base import KIND_GAP, Device, carry_state

__all__ = ["GapSpring", "law_gap"]


@njit(cache=True)
def law_gap(p, s, u, v, f, Kt, Ct, s_new):  # pragma: no cover - jitted
    """p = [k, g, c, n_dir, kpx, kpy, cpx, cpy]."""
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
        f[i] = p[4 + i] * x + p[6 + i] * v[i]
        Kt[i, i] = p[4 + i]
        Ct[i, i] = p[6 + i]
        if x > g:
            f[i] += k * (x - g) + c * v[i]
        elif x < -g:
            f[i] += k * (x + g) + c * v[i]
        else:
            continue
        Kt[i, i] += k
        Ct[i, i] += c
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
    kp, cp : sequence of two float, optional
        Linear spring and dashpot beside the gap, per direction (none by default).
    """

    kind = KIND_GAP

    def __init__(
        self, k: float, g: float, c: float = 0.0, *, n_dir: int = 1, name: str = "gap",
        kp: tuple[float, float] = (0.0, 0.0), cp: tuple[float, float] = (0.0, 0.0),
    ) -> None:
        if k < 0 or g < 0 or c < 0 or min(kp) < 0 or min(cp) < 0:
            msg = f"k, g, c, kp, cp: expected non-negative, got {k}, {g}, {c}, {kp}, {cp}"
            raise ModelError(msg)
        super().__init__([k, g, c, float(n_dir), *map(float, kp), *map(float, cp)],
                         n_dir=n_dir, name=name)

    def reference_stiffness(self) -> np.ndarray:
        """Return the spring beside the gap (the gap is open at rest)."""
        return np.diag(self.params[4:6])

    def reference_damping(self) -> np.ndarray:
        """Return the dashpot beside the gap (moved into the linear modal damping)."""
        return np.diag(self.params[6:8])
