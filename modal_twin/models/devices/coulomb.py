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
breakaway overshoot, i.e. 4 Fk X as kt -> infinity. An optional viscous ``c`` acts in parallel,
one value or one per direction (the dashpot of a bearing need not be isotropic, the friction
cone is).

Two optional extensions (off by default) express friction the classical law does not:

* a **speed-dependent** sliding limit (Stribeck): while sliding at speed ``s``, the limit is
  ``Fk + (Fs - Fk) exp(-(s / v_s)^2)`` (``v_s > 0``; ``v_s = 0``: ``Fk`` at once);
* a **linear spring beside the slider** (``kpx``, ``kpy``): the restoring spring of a
  sliding bearing, or the elastic part of a rubber bearing with friction.

With a regularising speed ``v_reg > 0`` the slider has no stuck state at all: the friction
force follows the velocity, ``f = mu(s) v / sqrt(s^2 + v_reg^2)`` with ``mu(s)`` the
speed-dependent limit above (a viscous-regularised Coulomb law: below ``v_reg`` it acts as
a very stiff dashpot, above it as friction); ``kt`` is then unused.
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
    """p = [Fs, Fk, kt, cx, n_dir, kpx, kpy, v_s, v_reg, cy]; s[2:4] force, s[4] slides."""
    Fs = p[0]
    Fk = p[1]
    kt = p[2]
    c = p[3]
    cy = p[9]
    nd = int(p[4])
    v_s = p[7]
    if p[8] > 0.0:
        _regularised(p, s, u, v, f, Kt, Ct, s_new)
        return
    dx = u[0] - s[0]
    dy = (u[1] - s[1]) if nd == 2 else 0.0
    tx = s[2] + kt * dx
    ty = s[3] + kt * dy
    sliding = s[4] > 0.5
    if sliding and dx * s[2] + dy * s[3] < 0.0:
        sliding = False  # motion turned back: stick again
    nt = math.sqrt(tx * tx + ty * ty)
    slide = Fk  # the sliding force: Fk, or falling from Fs with speed (Stribeck)
    if v_s > 0.0:
        speed = math.sqrt(v[0] * v[0] + (v[1] * v[1] if nd == 2 else 0.0))
        slide = Fk + (Fs - Fk) * math.exp(-(speed / v_s) ** 2)
    limit = slide if sliding else Fs
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
        limit = slide  # breaks loose, or keeps sliding
        nx = tx / nt
        ny = ty / nt
        fx = limit * nx
        fy = limit * ny
        g = limit * kt / nt
        Kt[0, 0] = g * (1.0 - nx * nx)
        if nd == 2:
            Kt[0, 1] = -g * nx * ny
            Kt[1, 0] = -g * nx * ny
            Kt[1, 1] = g * (1.0 - ny * ny)
        sliding = True
    f[0] = fx + c * v[0] + p[5] * u[0]
    f[1] = (fy + cy * v[1] + p[6] * u[1]) if nd == 2 else 0.0
    Kt[0, 0] += p[5]
    if nd == 2:
        Kt[1, 1] += p[6]
    Ct[0, 0] = c
    if nd == 2:
        Ct[1, 1] = cy
    for ic in range(s.shape[0]):  # explicit loop: s_new[:] = s is ~30 ns slower
        s_new[ic] = s[ic]
    s_new[0] = u[0]
    s_new[1] = u[1] if nd == 2 else 0.0
    s_new[2] = fx
    s_new[3] = fy
    s_new[4] = 1.0 if sliding else 0.0


@njit(cache=True)
def _regularised(p, s, u, v, f, Kt, Ct, s_new):  # pragma: no cover - jitted
    """Viscous-regularised friction (module docstring), p as :func:`law_coulomb`."""
    Fs = p[0]
    Fk = p[1]
    c = p[3]
    cy = p[9]
    nd = int(p[4])
    v_s = p[7]
    v_reg = p[8]
    vy = v[1] if nd == 2 else 0.0
    speed = math.sqrt(v[0] * v[0] + vy * vy)
    mu = Fk + (Fs - Fk) * math.exp(-(speed / v_s) ** 2) if v_s > 0.0 else Fk
    r = math.sqrt(speed * speed + v_reg * v_reg)
    fx = mu * v[0] / r
    fy = mu * vy / r
    for i in range(2):
        for j in range(2):
            Kt[i, j] = 0.0
            Ct[i, j] = 0.0
    Kt[0, 0] = p[5]
    Ct[0, 0] = c + mu / r - mu * v[0] * v[0] / r**3  # d f / d v at constant mu
    if nd == 2:
        Kt[1, 1] = p[6]
        Ct[1, 1] = cy + mu / r - mu * vy * vy / r**3
        Ct[0, 1] = -mu * v[0] * vy / r**3
        Ct[1, 0] = Ct[0, 1]
    f[0] = fx + c * v[0] + p[5] * u[0]
    f[1] = (fy + cy * vy + p[6] * u[1]) if nd == 2 else 0.0
    for ic in range(s.shape[0]):
        s_new[ic] = s[ic]
    s_new[0] = u[0]
    s_new[1] = u[1] if nd == 2 else 0.0
    s_new[2] = fx
    s_new[3] = fy
    s_new[4] = 1.0


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
    c : float or pair of float
        Parallel viscous damping, N s/m: one value for every direction, or one per direction.
    n_dir : int
        1 or 2 (isotropic) directions.
    name : str
        Label.
    kp : pair of float, optional
        Linear spring beside the slider per direction, N/m (none by default).
    v_s : float, optional
        Stribeck speed, m/s: the sliding limit falls from Fs to Fk with speed (0: classical).
    v_reg : float, optional
        Regularising speed, m/s (0: the stick-slip law; > 0: viscous-regularised friction).
    """

    kind = KIND_COULOMB

    def __init__(
        self,
        Fs: float,
        Fk: float,
        kt: float,
        c: float | tuple[float, float] = 0.0,
        *,
        n_dir: int = 1,
        name: str = "coulomb",
        kp: tuple[float, float] = (0.0, 0.0),
        v_s: float = 0.0,
        v_reg: float = 0.0,
    ) -> None:
        cx, cy = (float(c), float(c)) if np.ndim(c) == 0 else map(float, c)  # type: ignore[arg-type]
        if not (0 < Fk <= Fs and kt > 0 and min(cx, cy) >= 0 and min(kp) >= 0 and v_s >= 0
                and v_reg >= 0):
            msg = (
                f"Fs, Fk, kt, c, kp, v_s, v_reg: expected 0 < Fk <= Fs, kt > 0, c, kp, v_s, "
                f"v_reg >= 0, got {Fs}, {Fk}, {kt}, {c}, {kp}, {v_s}, {v_reg}"
            )
            raise ModelError(msg)
        super().__init__([Fs, Fk, kt, cx, float(n_dir), *map(float, kp), float(v_s),
                          float(v_reg), cy], n_dir=n_dir, name=name)

    def reference_stiffness(self) -> FloatArray:
        """Return the spring beside the slider (the stuck stiffness is left to Newton)."""
        return np.diag(self.params[5:7])

    def reference_damping(self) -> FloatArray:
        """Return diag(cx, cy)."""
        return np.diag([self.params[3], self.params[9] if self.n_dir == 2 else 0.0])
