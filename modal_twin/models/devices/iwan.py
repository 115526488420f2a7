"""Iwan microslip joint: parallel Jenkins elements with uniformly distributed slip, Masing memory.

A joint whose contact slips a little at a time (a bolted lap, a bearing's pad, a rubber
isolator's steel shims) is the parallel set of Jenkins elements (a spring in series with
a Coulomb slider) of Iwan (1966): element ``j`` has stiffness ``dk`` and slips when its
spring is stretched by ``phi_j``. With the slip displacements distributed with density
``rho(phi)`` (``k = int rho dphi`` the stuck stiffness), the virgin loading curve is
(Iwan 1966, Eq. (5); Segalman 2005, Eq. (2))::

    B(u) = int_0^u phi rho(phi) dphi + u int_u^inf rho(phi) dphi

This law takes the uniform density ``rho = k / uy`` on ``(0, uy]`` (the Segalman
four-parameter density with chi = 0 and no spike at ``uy``), for which the backbone is the
parabola up to full slip and flat beyond::

    B(u) = k (u - u^2 / (2 uy)),  0 <= u <= uy;    B(u) = k uy / 2 = F_y,  u >= uy

i.e. ``B(u) = k u - k^2 u^2 / (4 F_y)``: tangent ``k`` when stuck, falling linearly to 0
at full slip ``u = uy``. The joint then unloads and reloads by Masing's rule (Iwan 1966,
Eq. (8); exact for any parallel Jenkins set): from a reversal at ``(u_r, F_r)`` in the
direction ``d``::

    F(u) = F_r + 2 d B(|u - u_r| / 2)

and a branch that passes the reversal it was heading for closes that loop and carries on
along the branch before it (Madelung's memory rule); past the largest drift of the
virgin curve it carries on along the backbone. The energy of a symmetric cycle of
amplitude ``a <= uy`` is ``2 k a^3 / (3 uy)`` (the a^3 power law of a uniform density,
Segalman 2005, Eq. (14) with chi = 0). In parallel: a residual spring ``kr`` (what carries
load once every element slips) and a dashpot ``c``. Each direction x / y is a joint of its
own (uncoupled).

Memory: the reversal points of each direction are kept on a stack of :data:`DEPTH`
entries (the first one always the tip of the virgin curve); a deeper nest of sub-loops
forgets its innermost loop, the smallest (its two reversals; a branch then runs on from
the newer reversal past where that loop would have closed).

References: W. D. Iwan, "A distributed-element model for hysteresis and its steady-state
dynamic response", J. Appl. Mech. 33, 893-900, 1966; D. J. Segalman, "A four-parameter
Iwan model for lap-type joints", J. Appl. Mech. 72, 752-760, 2005.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from modal_twin._types import FloatArray
from modal_twin.errors import ModelError
from modal_twin.models.devices.base import (
    KIND_IWAN,
    N_STATE,
    Device,
    clear_outputs,
    copy_state,
)

__all__ = ["DEPTH", "IwanJoint", "iwan_backbone", "law_iwan"]

DEPTH = 16  # reversal points kept per direction
_STRIDE = 2 + 2 * DEPTH  # per direction: direction, depth, (u_r, F_r) pairs
if 2 + 2 * _STRIDE > N_STATE:  # pragma: no cover - a layout check at import
    msg = f"iwan: {2 + 2 * _STRIDE} state slots needed, base.N_STATE is {N_STATE}"
    raise ImportError(msg)


@njit(cache=True, inline="always")
def iwan_backbone(a, k, uy):  # pragma: no cover - jitted
    """Return (B(a), B'(a)) of the uniform Iwan density for a drift ``a >= 0``."""
    if a >= uy:
        return 0.5 * k * uy, 0.0
    return k * (a - 0.5 * a * a / uy), k * (1.0 - a / uy)


@njit(cache=True)
def _jenkins_set(x, x0, b, k, uy, s, s_new):  # pragma: no cover - jitted
    """Return (F, dF/dx) of the Jenkins set of one direction at trial drift ``x``.

    ``x0`` the committed drift, ``s[b:]`` the committed memory: direction ``s[b]``, depth
    ``n = s[b + 1]``, reversal ``j`` at ``(s[b + 2 + 2 j], s[b + 3 + 2 j])`` (drift, force);
    the trial memory written to ``s_new[b:]``. Depth 0: on the virgin curve.
    """
    d = s[b]
    n = int(s[b + 1])
    for j in range(2 * DEPTH):
        s_new[b + 2 + j] = s[b + 2 + j]
    dx = x - x0
    nd = 1.0 if dx > 0.0 else (-1.0 if dx < 0.0 else d)
    if d != 0.0 and nd != d:  # a reversal at the committed point: push it
        f0 = _branch_force(x0, d, n, k, uy, s, b)
        if n == DEPTH:  # full: forget the loop nearest to closed
            n = _merged(s_new, b, n)
        s_new[b + 2 + 2 * n] = x0
        s_new[b + 3 + 2 * n] = f0
        n += 1
    if nd != 0.0:
        d = nd
    # Madelung's rule: a branch past the reversal it heads for closes that loop
    while n >= 2 and d * (x - s_new[b + 2 * (n - 1)]) >= 0.0:
        n -= 2
    if n == 1 and d * (x + s_new[b + 2]) >= 0.0:  # past the mirror of the virgin tip
        n = 0
    if n > 0 and d * (x - s_new[b + 2 * n]) >= 2.0 * uy:
        # every element slips: nothing before is remembered; the state is the branch from
        # a virtual tip 2 uy behind, which is the virgin curve's past its mirror
        n = 1
        s_new[b + 2] = x - 2.0 * d * uy
        s_new[b + 3] = -0.5 * d * k * uy
        if d * x >= uy:
            n = 0
    s_new[b] = d
    s_new[b + 1] = float(n)
    return _branch(x, d, n, k, uy, s_new, b)


@njit(cache=True)
def _merged(s, b, n):  # pragma: no cover - jitted
    """Forget two successive reversals ``j, j + 1`` (``1 <= j <= n - 2``); return n - 2.

    The pair whose next reversal ``j + 1`` comes nearest the one before, ``j - 1`` (of the
    same sense): the loop nearest to closed, whose memory matters least (the range-pair
    rule of rainflow counting); the stack keeps alternating maxima and minima.
    """
    best = 1
    gap = np.inf
    for j in range(1, n - 1):
        g = abs(s[b + 2 + 2 * (j + 1)] - s[b + 2 + 2 * (j - 1)])
        if g < gap:
            gap = g
            best = j
    for j in range(best, n - 2):
        s[b + 2 + 2 * j] = s[b + 6 + 2 * j]
        s[b + 3 + 2 * j] = s[b + 7 + 2 * j]
    return n - 2


@njit(cache=True)
def _branch(x, d, n, k, uy, s, b):  # pragma: no cover - jitted
    """Return (F, dF/dx) on the branch of memory ``s[b:]`` (direction d, depth n) at x."""
    if n == 0:
        fb, kb = iwan_backbone(abs(x), k, uy)
        return (fb if x >= 0.0 else -fb), kb
    fb, kb = iwan_backbone(0.5 * abs(x - s[b + 2 * n]), k, uy)
    return s[b + 1 + 2 * n] + 2.0 * d * fb, kb


@njit(cache=True)
def _branch_force(x, d, n, k, uy, s, b):  # pragma: no cover - jitted
    """Return the force of :func:`_branch`."""
    f, _ = _branch(x, d, n, k, uy, s, b)
    return f


@njit(cache=True)
def law_iwan(p, s, u, v, f, Kt, Ct, s_new):  # pragma: no cover - jitted
    """Uniform Iwan set per direction; p = [kx, ky, krx, kry, uy, cx, cy, n_dir].

    State: s[0:2] drift; direction i's memory from ``2 + i * _STRIDE``.
    """
    nd = int(p[7])
    uy = p[4]
    clear_outputs(f, Kt, Ct)
    copy_state(s, s_new)
    for i in range(2):
        if i >= nd:
            continue
        b = 2 + i * _STRIDE
        fj, kj = _jenkins_set(u[i], s[i], b, p[i], uy, s, s_new)
        f[i] = fj + p[2 + i] * u[i] + p[5 + i] * v[i]
        Kt[i, i] = kj + p[2 + i]
        Ct[i, i] = p[5 + i]
    s_new[0] = u[0]
    s_new[1] = u[1]


class IwanJoint(Device):
    """Iwan microslip joint (uniform slip density, Masing memory) with a spring and dashpot.

    Parameters
    ----------
    k : float or sequence of float
        Stuck stiffness of the Jenkins elements per direction, N/m.
    kr : float or sequence of float
        Residual spring in parallel per direction, N/m (what is left at full slip).
    uy : float
        Drift at which every element slips, m (> 0); the slip force ``k uy / 2``.
    c : sequence of float
        Viscous damping per direction, N s/m (its length: the directions, 1 or 2).
    name : str
        Label.
    """

    kind = KIND_IWAN
    n_state = 2 + 2 * _STRIDE

    def __init__(self, k: float | list[float], kr: float | list[float], uy: float,
                 c: list[float], *, name: str = "iwan") -> None:
        c = [float(x) for x in np.atleast_1d(c)]
        nd = len(c)
        kk = np.broadcast_to(np.asarray(k, float), (2,)) if np.ndim(k) == 0 else np.asarray(
            k, float)
        kr_ = np.broadcast_to(np.asarray(kr, float), (2,)) if np.ndim(kr) == 0 else np.asarray(
            kr, float)
        if (nd not in (1, 2) or kk.size < nd or kr_.size < nd or not uy > 0
                or min(c) < 0 or np.any(kk[:nd] < 0) or np.any(kr_[:nd] < 0)):
            msg = (f"k, kr, uy, c: expected k >= 0, kr >= 0 per direction, uy > 0, c >= 0 "
                   f"with 1 or 2 entries, got k={k}, kr={kr}, uy={uy}, c={c}")
            raise ModelError(msg)
        k2 = [float(kk[0]), float(kk[min(1, kk.size - 1)]) if nd == 2 else 0.0]
        kr2 = [float(kr_[0]), float(kr_[min(1, kr_.size - 1)]) if nd == 2 else 0.0]
        cc = c + [0.0] * (2 - nd)
        super().__init__([*k2, *kr2, float(uy), *cc, float(nd)], n_dir=nd, name=name)

    def reference_damping(self) -> FloatArray:
        """Return diag(c)."""
        return np.diag(self.params[5:7])
