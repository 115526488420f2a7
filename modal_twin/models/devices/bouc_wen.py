"""Bidirectional Bouc-Wen devices of [004]: elastic sliding bearing (ESB) and steel damper (SDP).

Hysteretic variable (Park et al. 1986), Eqs. (10a)-(10b) of [004]::

    Zx' = A ux' - b|ux' Zx|Zx - g ux' Zx^2 - b|uy' Zy|Zx - g uy' Zx Zy
    Zy' = A uy' - b|uy' Zy|Zy - g uy' Zy^2 - b|ux' Zx|Zy - g ux' Zx Zy

Forces, Eq. (11a) (ESB) and Eq. (11b) (SDP) of [004]::

    f_ESB = mu(t) W Z + diag(c) u'
    f_SDP = K_SDP [alpha u + (1 - alpha) Z] + diag(c) u'
    mu = mu0 [W / S (mm^2/N)]^mu1 [V (s/mm)]^mu2,   V = ||u'||

The ODE is rate independent, so over a time step it is integrated along the straight
displacement path ``u_prev -> u`` (classical RK4 in the path parameter, sub-stepped so that
each sub-step changes Z by at most ~5 % of its bound ``sqrt(A / (b + g))``). The tangent
returned is the instantaneous dZ/du at the end of the step (a quasi-Newton tangent).
The ESB friction coefficient is evaluated with the trial velocity; its velocity derivative
in ``Ct`` is regularised below 1 um/s (the law itself is not: mu -> 0 as V -> 0).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from modal_twin._types import FloatArray
from modal_twin.errors import ModelError, OptionError
from modal_twin.models.devices.base import KIND_BW_ESB, KIND_BW_SDP, Device, carry_state

__all__ = [
    "BW_UNCOUPLED",
    "BoucWenESB",
    "BoucWenSDP",
    "bouc_wen_history",
    "bw_advance_many",
    "bw_esb_force",
    "bw_rate",
    "bw_rate_uniaxial",
    "bw_sdp_force",
    "esb_pressure_factor",
    "law_bw_esb",
    "law_bw_sdp",
    "table10_esb",
    "table10_sdp",
]

#: Parameter slot of both Bouc-Wen kinds that uncouples the directions (1: each its own
#: uniaxial variable; 0, the default of every parameter vector: Eq. (10) of [004]). The
#: ESB's vector ends at slot 9 (W), so its slot stays 0.
BW_UNCOUPLED = 10


@njit(cache=True)
def bw_rate(A, beta, gamma, zx, zy, dx, dy, kappa=1.0):  # pragma: no cover - jitted
    """Return (dZx, dZy) for a displacement increment (dx, dy), Eqs. (10a)-(10b) of [004].

    ``kappa`` scales the terms that couple the directions: 1 is Eq. (10) of [004] (one
    circular yield surface), 0 two independent uniaxial variables (two orthogonal
    dampers). With ``kappa = 1`` the numbers are bitwise those of Eq. (10) (``1.0 * x``
    is ``x`` exactly).
    """
    rx = (
        A * dx
        - beta * abs(dx * zx) * zx
        - gamma * dx * zx * zx
        - kappa * beta * abs(dy * zy) * zx
        - kappa * gamma * dy * zx * zy
    )  # Eq. (10a) of [004]
    ry = (
        A * dy
        - beta * abs(dy * zy) * zy
        - gamma * dy * zy * zy
        - kappa * beta * abs(dx * zx) * zy
        - kappa * gamma * dx * zx * zy
    )  # Eq. (10b) of [004]
    return rx, ry


@njit(cache=True)
def _bw_nsub(A, beta, gamma, dx, dy):  # pragma: no cover - jitted
    """Return the RK4 sub-steps of an increment (each changes Z by <= ~5 % of its bound)."""
    bg = beta + gamma
    zult = math.sqrt(A / bg) if bg > 0.0 else 1.0
    dmax = max(abs(dx), abs(dy))
    nsub = 1 + int(A * dmax / (0.05 * zult))
    return min(nsub, 10000)


@njit(cache=True)
def _bw_rk4(A, beta, gamma, zx, zy, hx, hy, kappa):  # pragma: no cover - jitted
    """One classical RK4 step of Eqs. (10a)-(10b) of [004] along the increment (hx, hy)."""
    k1x, k1y = bw_rate(A, beta, gamma, zx, zy, hx, hy, kappa)
    k2x, k2y = bw_rate(A, beta, gamma, zx + 0.5 * k1x, zy + 0.5 * k1y, hx, hy, kappa)
    k3x, k3y = bw_rate(A, beta, gamma, zx + 0.5 * k2x, zy + 0.5 * k2y, hx, hy, kappa)
    k4x, k4y = bw_rate(A, beta, gamma, zx + k3x, zy + k3y, hx, hy, kappa)
    zx += (k1x + 2.0 * k2x + 2.0 * k3x + k4x) / 6.0
    zy += (k1y + 2.0 * k2y + 2.0 * k3y + k4y) / 6.0
    return zx, zy


@njit(cache=True)
def bw_rate_uniaxial(A, beta, gamma, nu, z, du):  # pragma: no cover - jitted
    """Return dz of the uniaxial hysteretic variable for a drift increment ``du``.

    ``dz = A du - beta |du| |z|^(nu - 1) z - gamma du |z|^nu``: Eq. (10a) of [004] with
    ``uy = Zy = 0`` and its exponent 2 generalised to ``nu`` (nu = 2 is Eq. (10a) itself;
    nu = 1 the Bouc-Wen benchmark of Noel and Schoukens). Homogeneous of degree one in
    ``du``, so ``dz/dt`` is the same expression with ``du = u'``.
    """
    if nu == 1.0:  # pow-free branch; |z|^0 z and |z|^1 are exact, so the same numbers
        return A * du - beta * abs(du) * z - gamma * du * abs(z)  # Eq. (10a) of [004]
    az = abs(z)
    return A * du - beta * abs(du) * az ** (nu - 1.0) * z - gamma * du * az**nu  # Eq. (10a)


@njit(cache=True)
def _bw_path(u, A, beta, gamma, nu, nsub):  # pragma: no cover - jitted
    """RK4 of :func:`bw_rate_uniaxial` along the path ``u`` (z_0 = 0); nsub <= 0: adaptive."""
    z = np.empty_like(u)
    z[0] = 0.0
    s = 0.0
    for i in range(1, u.size):
        du = u[i] - u[i - 1]
        n = nsub if nsub > 0 else _bw_nsub(A, beta, gamma, du, 0.0)
        h = du / n
        for _ in range(n):
            k1 = bw_rate_uniaxial(A, beta, gamma, nu, s, h)
            k2 = bw_rate_uniaxial(A, beta, gamma, nu, s + 0.5 * k1, h)
            k3 = bw_rate_uniaxial(A, beta, gamma, nu, s + 0.5 * k2, h)
            k4 = bw_rate_uniaxial(A, beta, gamma, nu, s + k3, h)
            s += (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
        z[i] = s
    return z


def bouc_wen_history(
    u: FloatArray,
    *,
    beta: float,
    gamma: float,
    A: float = 1.0,
    nu: float = 2.0,
    n_sub: int | None = None,
) -> FloatArray:
    """Return the Bouc-Wen hysteretic variable driven along a drift history (z_0 = 0).

    The one integrator of the uniaxial Bouc-Wen variable (the device laws, the diagnosis'
    restoring-force regressors and its single-DOF model share its rate
    :func:`bw_rate_uniaxial`)::

        z' = A u' - beta |u'| |z|^(nu - 1) z - gamma u' |z|^nu      Eq. (10a) of [004]

    Rate independent, so it is integrated along the displacement path: classical RK4 in
    the path parameter, ``n_sub`` sub-steps per sample. For nu = 2 and ``n_sub=None`` it
    is the scheme of the bidirectional device laws (:class:`BoucWenSDP`, Eq. (10) of [004])
    restricted to one direction. ``z`` is bounded by ``(A / (beta + gamma))^(1 / nu)``
    and starts with slope ``A``; on monotonic loading from rest with nu = 2 it is
    ``z = sqrt(A / (beta + gamma)) tanh(sqrt(A (beta + gamma)) u)``.

    Parameters
    ----------
    u : FloatArray
        Drift, shape (nt,), m.
    beta, gamma : float
        Shape parameters (units such that ``beta |z|^nu`` is 1/m).
    A : float
        Initial slope dz/du.
    nu : float
        Exponent, >= 1 (2 in [004]).
    n_sub : int, optional
        RK4 sub-steps per sample; None: as many as keep each sub-step's change of ``z``
        below ~5 % of its nu = 2 bound (the device laws' rule).

    Returns
    -------
    FloatArray
        z, shape (nt,), in the units of ``A u``.

    Raises
    ------
    OptionError
        For nu < 1 or n_sub < 1.

    Examples
    --------
    >>> z = bouc_wen_history(np.linspace(0.0, 10.0, 1001), beta=0.5, gamma=0.5)
    >>> round(float(z[-1]), 6)  # tanh(10): saturated at sqrt(A / (beta + gamma)) = 1
    1.0
    """
    if not nu >= 1.0:
        msg = f"nu: expected nu >= 1, got {nu!r}"
        raise OptionError(msg)
    if n_sub is not None and not n_sub >= 1:
        msg = f"n_sub: expected an int >= 1 or None, got {n_sub!r}"
        raise OptionError(msg)
    y = np.ascontiguousarray(u, dtype=float)
    return _bw_path(y, float(A), float(beta), float(gamma), float(nu),
                    0 if n_sub is None else int(n_sub))


@njit(cache=True)
def _bw_tangent(A, beta, gamma, dx, dy, zx, zy, kappa):  # pragma: no cover - jitted
    """Instantaneous tangent d(Z')/d(u') at the end state, Eqs. (10a)-(10b) differentiated.

    ``kappa``: the coupling of :func:`bw_rate` (it scales the cross terms d01, d10).
    """
    sx = 1.0 if dx > 0.0 else (-1.0 if dx < 0.0 else 0.0)
    sy = 1.0 if dy > 0.0 else (-1.0 if dy < 0.0 else 0.0)
    d00 = A - beta * sx * abs(zx) * zx - gamma * zx * zx
    d01 = kappa * (-beta * sy * abs(zy) * zx - gamma * zx * zy)
    d11 = A - beta * sy * abs(zy) * zy - gamma * zy * zy
    d10 = kappa * (-beta * sx * abs(zx) * zy - gamma * zx * zy)
    return d00, d01, d10, d11


@njit(cache=True)
def _bw_advance(p, s, u, s_new):  # pragma: no cover - jitted
    """Integrate Z along u_prev -> u (RK4), store Z in s_new[2:4]; return dZ/du entries."""
    A = p[0]
    beta = p[1]
    gamma = p[2]
    dx = u[0] - s[0]
    dy = u[1] - s[1]
    zx = s[2]
    zy = s[3]
    nsub = _bw_nsub(A, beta, gamma, dx, dy)
    if nsub == 1:  # x / 1 == x exactly (IEEE 754): skips two divisions on the common path
        hx = dx
        hy = dy
    else:
        hx = dx / nsub
        hy = dy / nsub
    kappa = 1.0 - p[BW_UNCOUPLED]  # ESB: the slot is never set (0), so Eq. (10) itself
    for _ in range(nsub):
        zx, zy = _bw_rk4(A, beta, gamma, zx, zy, hx, hy, kappa)
    carry_state(s, u, s_new)
    s_new[2] = zx
    s_new[3] = zy
    return _bw_tangent(A, beta, gamma, dx, dy, zx, zy, kappa)


@njit(cache=True)
def bw_advance_many(idx, params, states, uv, s_new, tan, work, nsub):  # pragma: no cover  # noqa: C901
    """:func:`_bw_advance` of several Bouc-Wen devices at once, bitwise the same numbers.

    The RK4 stages of the devices are interleaved (stage 1 of every device, then stage 2
    ...), so that their independent dependency chains overlap in the processor instead of
    running one after the other; each device sees exactly the operations of
    :func:`_bw_advance` in the same order.

    Parameters
    ----------
    idx : (m,) int64
        Rows of ``params`` / ``states`` / ``s_new`` / ``tan`` to advance.
    params, states : (n_dev, N_PARAM), (n_dev, N_STATE)
        Law parameters and committed states.
    uv : (>= 2 n_dev,)
        Trial displacements, ``uv[2 d + a]`` of device d in direction a.
    s_new : (n_dev, N_STATE)
        Trial states (rows ``idx`` written).
    tan : (n_dev, 4)
        dZ/du entries d00, d01, d10, d11 (rows ``idx`` written).
    work : (11, m), nsub : (m,) int64
        Scratch.
    """
    m = idx.shape[0]
    nmax = 0
    for j in range(m):
        d = idx[j]
        A = params[d, 0]
        beta = params[d, 1]
        gamma = params[d, 2]
        dx = uv[2 * d] - states[d, 0]
        dy = uv[2 * d + 1] - states[d, 1]
        ns_j = _bw_nsub(A, beta, gamma, dx, dy)
        if ns_j == 1:
            work[0, j] = dx
            work[1, j] = dy
        else:
            work[0, j] = dx / ns_j
            work[1, j] = dy / ns_j
        work[2, j] = states[d, 2]
        work[3, j] = states[d, 3]
        nsub[j] = ns_j
        nmax = max(nmax, ns_j)
    for it in range(nmax):  # _bw_rk4 written stage by stage over the devices
        for j in range(m):
            if it < nsub[j]:
                d = idx[j]
                k1x, k1y = bw_rate(params[d, 0], params[d, 1], params[d, 2], work[2, j],
                                   work[3, j], work[0, j], work[1, j],
                                   1.0 - params[d, BW_UNCOUPLED])
                work[4, j] = k1x
                work[5, j] = k1y
        for r in (4, 6):  # k2 at z + k1 / 2 into rows 6-7, k3 at z + k2 / 2 into rows 8-9
            for j in range(m):
                if it < nsub[j]:
                    d = idx[j]
                    kx, ky = bw_rate(params[d, 0], params[d, 1], params[d, 2],
                                     work[2, j] + 0.5 * work[r, j],
                                     work[3, j] + 0.5 * work[r + 1, j], work[0, j], work[1, j],
                                     1.0 - params[d, BW_UNCOUPLED])
                    work[r + 2, j] = kx
                    work[r + 3, j] = ky
        for j in range(m):
            if it < nsub[j]:
                d = idx[j]
                k3x = work[8, j]
                k3y = work[9, j]
                k4x, k4y = bw_rate(params[d, 0], params[d, 1], params[d, 2], work[2, j] + k3x,
                                   work[3, j] + k3y, work[0, j], work[1, j],
                                   1.0 - params[d, BW_UNCOUPLED])
                work[2, j] += (work[4, j] + 2.0 * work[6, j] + 2.0 * k3x + k4x) / 6.0
                work[3, j] += (work[5, j] + 2.0 * work[7, j] + 2.0 * k3y + k4y) / 6.0
    for j in range(m):
        d = idx[j]
        zx = work[2, j]
        zy = work[3, j]
        for ic in range(states.shape[1]):
            s_new[d, ic] = states[d, ic]
        s_new[d, 0] = uv[2 * d]
        s_new[d, 1] = uv[2 * d + 1]
        s_new[d, 2] = zx
        s_new[d, 3] = zy
        d00, d01, d10, d11 = _bw_tangent(params[d, 0], params[d, 1], params[d, 2],
                                         uv[2 * d] - states[d, 0], uv[2 * d + 1] - states[d, 1],
                                         zx, zy, 1.0 - params[d, BW_UNCOUPLED])
        tan[d, 0] = d00
        tan[d, 1] = d01
        tan[d, 2] = d10
        tan[d, 3] = d11


@njit(cache=True)
def esb_pressure_factor(p):  # pragma: no cover - jitted
    """Return mu0 [W / S (N/mm^2)]^mu1, the constant factor of the ESB friction law.

    ``p`` as in :func:`law_bw_esb`. The law evaluates ``mu0 * (W / S * 1e-6) ** mu1 * V ...``
    left to right, so ``esb_pressure_factor(p) * (V * 1e3) ** mu2`` is the same number to
    the last bit; the twin caches it per bearing (one ``pow`` less per evaluation).
    """
    return p[5] * (p[9] / p[8] * 1e-6) ** p[6]


@njit(cache=True)
def law_bw_esb(p, s, u, v, f, Kt, Ct, s_new):  # pragma: no cover - jitted
    """ESB, Eq. (11a) of [004]; p = [A, beta, gamma, cx, cy, mu0, mu1, mu2, S, W]."""
    d00, d01, d10, d11 = _bw_advance(p, s, u, s_new)
    bw_esb_force(p, v, f, Kt, Ct, s_new, d00, d01, d10, d11, esb_pressure_factor(p))


@njit(cache=True)
def bw_esb_force(p, v, f, Kt, Ct, s_new, d00, d01, d10, d11, c_press):  # pragma: no cover
    """Force and tangents of the ESB, Eq. (11a) of [004], once Z is in ``s_new[2:4]``.

    ``d00 .. d11`` are dZ/du (from :func:`_bw_advance`), ``c_press`` is
    :func:`esb_pressure_factor` of ``p`` (the twin caches it per bearing).
    """
    mu2 = p[7]
    W = p[9]
    V = math.sqrt(v[0] * v[0] + v[1] * v[1])
    # friction coefficient: pressure in N/mm^2, velocity in mm/s (text below Eq. (11) of [004]),
    # mu = mu0 (W / S)^mu1 V^mu2 with the pressure factor c_press = mu0 (W / S)^mu1 cached
    mu = c_press * (V * 1e3) ** mu2 if V > 0.0 else 0.0
    Vr = max(V, 1e-6)
    dmu = mu * mu2 / (Vr * Vr)  # d mu / d v_j = dmu * v_j
    for i in range(2):
        f[i] = mu * W * s_new[2 + i] + p[3 + i] * v[i]  # Eq. (11a) of [004]
        for j in range(2):
            Ct[i, j] = W * s_new[2 + i] * dmu * v[j]
        Ct[i, i] += p[3 + i]
    Kt[0, 0] = mu * W * d00
    Kt[0, 1] = mu * W * d01
    Kt[1, 0] = mu * W * d10
    Kt[1, 1] = mu * W * d11


@njit(cache=True)
def law_bw_sdp(p, s, u, v, f, Kt, Ct, s_new):  # pragma: no cover - jitted
    """SDP, Eq. (11b) of [004]; p = [A, beta, gamma, cx, cy, alpha, kxx, kxy, kyy, 0, unc]."""
    d00, d01, d10, d11 = _bw_advance(p, s, u, s_new)
    bw_sdp_force(p, u, v, f, Kt, Ct, s_new, d00, d01, d10, d11)


@njit(cache=True)
def bw_sdp_force(p, u, v, f, Kt, Ct, s_new, d00, d01, d10, d11):  # pragma: no cover
    """Force and tangents of the SDP, Eq. (11b) of [004], once Z is in ``s_new[2:4]``."""
    a = p[5]
    Kxx = p[6]
    Kxy = p[7]
    Kyy = p[8]
    wx = a * u[0] + (1.0 - a) * s_new[2]
    wy = a * u[1] + (1.0 - a) * s_new[3]
    f[0] = Kxx * wx + Kxy * wy + p[3] * v[0]  # Eq. (11b) of [004]
    f[1] = Kxy * wx + Kyy * wy + p[4] * v[1]  # Eq. (11b) of [004]
    g00 = a + (1.0 - a) * d00
    g01 = (1.0 - a) * d01
    g10 = (1.0 - a) * d10
    g11 = a + (1.0 - a) * d11
    Kt[0, 0] = Kxx * g00 + Kxy * g10
    Kt[0, 1] = Kxx * g01 + Kxy * g11
    Kt[1, 0] = Kxy * g00 + Kyy * g10
    Kt[1, 1] = Kxy * g01 + Kyy * g11
    Ct[0, 1] = 0.0
    Ct[1, 0] = 0.0
    Ct[0, 0] = p[3]
    Ct[1, 1] = p[4]


def _check_bw(A: float, beta: float, gamma: float, c: list[float]) -> None:
    if not (A > 0 and beta + gamma > 0 and beta >= -abs(gamma)) or min(c) < 0:
        msg = (
            f"A, beta, gamma, c: expected A > 0, beta + gamma > 0, c >= 0, "
            f"got A={A}, beta={beta}, gamma={gamma}, c={c}"
        )
        raise ModelError(msg)


class BoucWenESB(Device):
    """Elastic sliding bearing: bidirectional Bouc-Wen with friction, Eqs. (10)-(11a) of [004].

    Parameters
    ----------
    A, beta, gamma : float
        Bouc-Wen shape parameters, 1/m (Z is dimensionless, bounded by sqrt(A/(b+g))).
    c : sequence of float
        Viscous damping (cxx, cyy), N s/m.
    W : float
        Vertical load carried, N (not tabulated in [004]; the caller must supply it).
    mu0, mu1, mu2 : float
        Friction-law coefficients; defaults 0.0606, -0.5883, 0.1148 (text of [004]).
    S : float
        Slider effective area, m^2; default 0.1018 (text of [004]).
    name : str
        Label.
    """

    kind = KIND_BW_ESB

    def __init__(
        self,
        A: float,
        beta: float,
        gamma: float,
        c: list[float],
        *,
        W: float,
        mu0: float = 0.0606,
        mu1: float = -0.5883,
        mu2: float = 0.1148,
        S: float = 0.1018,
        name: str = "ESB",
    ) -> None:
        c = [float(x) for x in c]
        _check_bw(A, beta, gamma, c)
        if not (W > 0 and S > 0 and mu0 >= 0 and mu2 >= 0):
            msg = f"W, S, mu0, mu2: expected positive, got W={W}, S={S}, mu0={mu0}, mu2={mu2}"
            raise ModelError(msg)
        super().__init__(
            [A, beta, gamma, c[0], c[1], mu0, mu1, mu2, S, W], n_dir=2, name=name
        )

    def reference_stiffness(self) -> FloatArray:
        """Return zeros: the friction force vanishes at rest (mu(V = 0) = 0)."""
        return np.zeros((2, 2))

    def reference_damping(self) -> FloatArray:
        """Return diag(c)."""
        return np.diag(self.params[3:5])


class BoucWenSDP(Device):
    """U-shaped steel damper pair: bidirectional Bouc-Wen, Eqs. (10)-(11b) of [004].

    Parameters
    ----------
    A, beta, gamma : float
        Bouc-Wen parameters (A dimensionless, beta and gamma in 1/m^2; Z in m).
    K : FloatArray
        Symmetric (2, 2) stiffness K_SDP, N/m.
    alpha : float
        Post- to pre-yield stiffness ratio.
    c : sequence of float
        Viscous damping (cxx, cyy), N s/m.
    name : str
        Label.
    uncoupled : bool
        False (default): Eq. (10) of [004], one variable pair with a circular yield
        surface. True: each direction its own uniaxial variable (Eq. (10a) without the
        terms in the other direction): two orthogonal dampers, each yielding at its own
        drift, as a pair of uniaxial devices (the terms scaled by ``kappa`` in
        :func:`bw_rate`).
    """

    kind = KIND_BW_SDP

    def __init__(
        self,
        A: float,
        beta: float,
        gamma: float,
        K: FloatArray,
        alpha: float,
        c: list[float],
        *,
        name: str = "SDP",
        uncoupled: bool = False,
    ) -> None:
        c = [float(x) for x in c]
        _check_bw(A, beta, gamma, c)
        K = np.asarray(K, dtype=float)
        if K.shape != (2, 2) or abs(K[0, 1] - K[1, 0]) > 1e-12 * np.abs(K).max():
            msg = f"K: expected a symmetric (2, 2) matrix, got {K.tolist()}"
            raise ModelError(msg)
        if not 0.0 <= alpha <= 1.0:
            msg = f"alpha: expected 0 <= alpha <= 1, got {alpha}"
            raise ModelError(msg)
        super().__init__(
            [A, beta, gamma, c[0], c[1], alpha, K[0, 0], K[0, 1], K[1, 1], 0.0,
             1.0 if uncoupled else 0.0], n_dir=2, name=name
        )

    def reference_damping(self) -> FloatArray:
        """Return diag(c)."""
        return np.diag(self.params[3:5])


# Table 10 of [004]: A (1/m), beta (1/m), gamma (1/m), cxx, cyy (Mg/s).
_TABLE10_ESB = {
    "ESB1": (47.13, 10.41, 36.72, 3.79e3, 50.04e3),
    "ESB2": (54.10, 25.41, 28.69, 30.00e3, 20.00e3),
}


def table10_esb(device: str, *, W: float) -> BoucWenESB:
    """Return ESB1 or ESB2 as calibrated in Table 10 of [004].

    Parameters
    ----------
    device : {"ESB1", "ESB2"}
    W : float
        Vertical load on the bearing, N ([004] does not tabulate it).

    Raises
    ------
    ModelError
        For an unknown label.
    """
    if device not in _TABLE10_ESB:
        msg = f"device: expected one of {sorted(_TABLE10_ESB)}, got {device!r}"
        raise ModelError(msg)
    A, b, g, cx, cy = _TABLE10_ESB[device]
    return BoucWenESB(A, b, g, [cx, cy], W=W, name=device)


def table10_sdp(name: str = "SDP") -> BoucWenSDP:
    """Return the SDP model of Table 10 of [004] (both SDPs share it).

    kxx = 3.975 MN/m, kyy = 3.779 MN/m, kxy = 0, alpha = 0.1225, A = 1,
    beta = 635 1/m^2, gamma = 1102 1/m^2, cxx = cyy = 90 Mg/s.
    """
    K = np.array([[3.975e6, 0.0], [0.0, 3.779e6]])
    return BoucWenSDP(1.0, 635.0, 1102.0, K, 0.1225, [90.0e3, 90.0e3], name=name)
