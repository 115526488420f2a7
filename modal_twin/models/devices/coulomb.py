"""Coulomb friction with stick-slip (static coefficient above kinetic), 1 or 2 directions.

Event-correct stick detection by return mapping on a stiff stuck contact (a Jenkins
element: contact stiffness ``kt`` in series with a slider), not a smoothed sign function.
Per step, trial force ``f_tr = f_prev + kt du``:

* stuck: stays stuck while ``|f_tr| <= Fs`` (static limit), else breaks loose and slides
  with ``f = Fk f_tr / |f_tr|``;
* sliding: keeps sliding at ``Fk`` while the motion does not turn back against the
  friction force (``du . f_prev >= 0``); when it does, the contact sticks again and the
  static limit applies to the next breakaway.

Bidirectional use is isotropic (circular friction cone). Stick/slip changes are resolved to
one time step; a prescribed cycle of amplitude X dissipates ``4 Fk (X - Fk / kt)`` plus the
breakaway overshoot, i.e. 4 Fk X as kt -> infinity. An optional viscous ``c`` acts in parallel.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from modal_twin._types import FloatArray
from modal_twin.errors import ModelError
from modal_twin.models.devices.base import KIND_COULOMB, Device

__all__ = ["CoulombFriction", "law_coulomb"]


@njit(cache=True)
def law_coulomb(p, s, u, v, f, Kt, Ct, s_new):  # pragma: no cover - jitted
    """p = [Fs, Fk, kt, c, n_dir]; s[2:4] friction force, s[4] sliding flag."""
    Fs = p[0]
    Fk = p[1]
    kt = p[2]
    c = p[3]
    nd = int(p[4])
    dx = u[0] - s[0]
    dy = (u[1] - s[1]) if nd == 2 else 0.0
    tx = s[2] + kt * dx
    ty = s[3] + kt * dy
    sliding = s[4] > 0.5
    if sliding and dx * s[2] + dy * s[3] < 0.0:
        sliding = False  # motion turned back: stick again
    nt = math.sqrt(tx * tx + ty * ty)
    limit = Fk if sliding else Fs
    for i in range(2):
        for j in range(2):
            Kt[i, j] = 0.0
            Ct[i, j] = 0.0
    if nt <= limit:
        fx = tx
        fy = ty
        Kt[0, 0] = kt
        if nd == 2:
            Kt[1, 1] = kt
        sliding = False
    else:
        nx = tx / nt
        ny = ty / nt
        fx = Fk * nx
        fy = Fk * ny
        g = Fk * kt / nt
        Kt[0, 0] = g * (1.0 - nx * nx)
        if nd == 2:
            Kt[0, 1] = -g * nx * ny
            Kt[1, 0] = -g * nx * ny
            Kt[1, 1] = g * (1.0 - ny * ny)
        sliding = True
    f[0] = fx + c * v[0]
    f[1] = (fy + c * v[1]) if nd == 2 else 0.0
    Ct[0, 0] = c
    if nd == 2:
        Ct[1, 1] = c
    for ic in range(s.shape[0]):  # explicit loop: s_new[:] = s is ~30 ns slower
        s_new[ic] = s[ic]
    s_new[0] = u[0]
    s_new[1] = u[1] if nd == 2 else 0.0
    s_new[2] = fx
    s_new[3] = fy
    s_new[4] = 1.0 if sliding else 0.0


class CoulombFriction(Device):
    """Stick-slip Coulomb friction (static force Fs >= kinetic force Fk).

    Parameters
    ----------
    Fs : float
        Static (breakaway) friction force mu_s N, N.
    Fk : float
        Kinetic friction force mu_k N, N (0 < Fk <= Fs).
    kt : float
        Stuck contact stiffness, N/m (large: Fk / kt is the pre-slip displacement).
    c : float
        Parallel viscous damping, N s/m.
    n_dir : int
        1 or 2 (isotropic) directions.
    name : str
        Label.
    """

    kind = KIND_COULOMB

    def __init__(
        self,
        Fs: float,
        Fk: float,
        kt: float,
        c: float = 0.0,
        *,
        n_dir: int = 1,
        name: str = "coulomb",
    ) -> None:
        if not (0 < Fk <= Fs and kt > 0 and c >= 0):
            msg = (
                f"Fs, Fk, kt, c: expected 0 < Fk <= Fs, kt > 0, c >= 0, "
                f"got {Fs}, {Fk}, {kt}, {c}"
            )
            raise ModelError(msg)
        super().__init__([Fs, Fk, kt, c, float(n_dir)], n_dir=n_dir, name=name)

    def reference_stiffness(self) -> FloatArray:
        """Return zeros (the stuck stiffness is left to the Newton iteration)."""
        return np.zeros((2, 2))

    def reference_damping(self) -> FloatArray:
        """Return c I."""
        return np.diag([self.params[3], self.params[3] if self.n_dir == 2 else 0.0])
