"""Restoring-force laws of the independent truth (own forms, none from the library).

Each law acts on one device's horizontal drift ``u = (u_x, u_y)`` (m) and drift velocity
``v`` (m/s) and returns the force the device exerts (N, same sign as ``u``: it resists).
Laws with a smooth internal state carry it as ODE states (``n_ode`` per device, advanced by
the integrator together with the structure); rate-independent memory (the sliders of the
Iwan model) is frozen during a step and committed after it by a return map, which is exact
for an elastic-perfectly-plastic element under motion that is monotonic within the step.

Forms chosen to differ from :mod:`modal_twin.models.devices` (Coulomb / stick-slip,
Bouc-Wen ``n = 2`` style, bilinear, cubic, piecewise-linear gap, linear k-c):

* :class:`BoucWenN1` -- uncoupled Bouc-Wen with exponent ``n = 1`` and ``beta = gamma``
  (a soft knee, linear unloading), plus a viscous part;
* :class:`IwanJoint` -- parallel Jenkins elements with a uniform slip-displacement
  distribution (distributed microslip, smooth softening, Masing hysteresis);
* :class:`StribeckFriction` -- bidirectional friction whose coefficient falls from
  ``mu_s`` to ``mu_k`` with sliding speed (Gaussian Stribeck curve), regularised;
* :class:`TanhSoftening`, :class:`QuinticHardening`, :class:`SinhHardening` -- smooth
  elastic non-linearities;
* :class:`HertzGap` -- contact of power 1.5 beyond a clearance;
* :class:`LinearKC` -- a spring-dashpot with changed values (damping change);
* :class:`ArctanFriction` -- friction alone (a damper's seals), arctangent-regularised;
* :class:`SeriesBushingDashpot` -- a dashpot behind an elastic bushing (its force an ODE
  state).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

FloatArray = np.ndarray


@dataclass
class Law:
    """Base: a law with ``n_ode`` smooth states and optional rate-independent memory."""

    n_ode: int = field(default=0, init=False)

    def force(self, u: FloatArray, v: FloatArray, z: FloatArray) -> tuple[FloatArray,
                                                                            FloatArray]:
        """Return the force (2,) and the state derivative (n_ode,)."""
        raise NotImplementedError

    def commit(self, u: FloatArray) -> None:
        """Update rate-independent memory at the end of a step (default: none)."""

    def reset(self) -> None:
        """Forget the memory (start at rest)."""


@dataclass
class LinearKC(Law):
    """``f = k u + c v`` per direction (k, c as (2,) arrays or scalars)."""

    k: FloatArray | float
    c: FloatArray | float

    def force(self, u, v, z):
        return np.asarray(self.k) * u + np.asarray(self.c) * v, z[:0]


@dataclass
class BoucWenN1(Law):
    """Bouc-Wen with ``n = 1``, ``A = 1``, ``beta = gamma = 1 / (2 u_y)``, per direction.

    ``z' = v - beta |v| z - gamma v |z|``; ``f = alpha k u + (1 - alpha) k z + c v``.
    With ``beta = gamma`` the loading branch is ``dz/du = 1 - 2 beta z`` for ``z > 0``
    (exponential approach to ``z_s = u_y``) and unloading is linear (``dz/du = 1``).
    """

    k: float
    alpha: float
    uy: float
    c: float

    def __post_init__(self) -> None:
        self.n_ode = 2

    def force(self, u, v, z):
        b = 0.5 / self.uy
        zd = v - b * np.abs(v) * z - b * v * np.abs(z)
        f = self.alpha * self.k * u + (1.0 - self.alpha) * self.k * z + self.c * v
        return f, zd


def boucwen_n1_loop_energy(k: float, alpha: float, uy: float, a: float) -> float:
    """Closed-form energy (J) dissipated per steady cycle of :class:`BoucWenN1` at drift
    amplitude ``a`` (rate-independent part; the dashpot adds ``pi c omega a^2``).

    With ``b = 1 / (2 u_y)`` the steady loop's turning value ``z_1`` solves
    ``z_1 = (1 - exp(-2 b (2 a - z_1))) / (2 b)`` and the loop area in ``(u, z)`` is
    ``2 (a - z_1) / b - z_1^2`` (derivation in the module tests).
    """
    from scipy.optimize import brentq

    b = 0.5 / uy
    z1 = brentq(lambda z: z - (1.0 - np.exp(-2.0 * b * (2.0 * a - z))) / (2.0 * b),
                0.0, min(uy, 2.0 * a))
    return (1.0 - alpha) * k * (2.0 * (a - z1) / b - z1**2)


@dataclass
class IwanJoint(Law):
    """Iwan model: ``n_el`` Jenkins elements (stiffness ``k / n_el`` each) whose slip
    displacements are uniform on ``(0, phi_max]``, in parallel with ``k_res`` and ``c``.

    Backbone (closed form of the uniform distribution): ``f = k (u - u^2 / (2 phi_max))``
    for ``0 <= u <= phi_max`` and ``k phi_max / 2`` beyond, plus ``k_res u``.
    """

    k: float
    phi_max: float
    k_res: float
    c: float
    n_el: int = 60
    s: FloatArray = field(init=False)

    def __post_init__(self) -> None:
        self.phi = self.phi_max * (np.arange(self.n_el) + 0.5) / self.n_el
        self.ki = self.k / self.n_el
        self.reset()

    def reset(self) -> None:
        self.s = np.zeros((2, self.n_el))  # slider positions, per direction

    def force(self, u, v, z):
        e = np.clip(u[:, None] - self.s, -self.phi, self.phi)
        return self.ki * e.sum(axis=1) + self.k_res * u + self.c * v, z[:0]

    def commit(self, u):
        e = u[:, None] - self.s
        self.s = u[:, None] - np.clip(e, -self.phi, self.phi)


def iwan_backbone(k: float, phi_max: float, u: FloatArray) -> FloatArray:
    """Closed-form virgin-loading force of the Jenkins elements of :class:`IwanJoint`."""
    u = np.asarray(u, dtype=float)
    return np.where(u <= phi_max, k * (u - u**2 / (2.0 * phi_max)), 0.5 * k * phi_max)


def iwan_loop_energy(k: float, phi_max: float, a: float) -> float:
    """Closed-form energy per cycle at amplitude ``a <= phi_max``: the integral of
    ``4 k_phi phi (a - phi)`` over the slip density ``k / phi_max``, ``2 k a^3 /
    (3 phi_max)``."""
    return 2.0 * k * a**3 / (3.0 * phi_max)


@dataclass
class StribeckFriction(Law):
    """Bidirectional friction with a speed-dependent coefficient, regularised.

    ``mu(s) = mu_k + (mu_s - mu_k) exp(-(s / v_s)^2)``, ``s = |v|``;
    ``f = k u + c v + mu(s) W v / sqrt(s^2 + eps^2)``.
    """

    W: float
    mu_s: float
    mu_k: float
    v_s: float
    k: float
    c: float
    eps: float = 2e-3

    def mu(self, s: FloatArray) -> FloatArray:
        """Friction coefficient at sliding speed ``s`` (m/s)."""
        return self.mu_k + (self.mu_s - self.mu_k) * np.exp(-(np.asarray(s) / self.v_s) ** 2)

    def force(self, u, v, z):
        s = float(np.hypot(v[0], v[1]))
        f = self.k * u + self.c * v + self.mu(s) * self.W * v / np.sqrt(s * s + self.eps**2)
        return f, z[:0]


@dataclass
class TanhSoftening(Law):
    """``f = k_r u + (k - k_r) u_0 tanh(u / u_0) + c v`` per direction (tangent ``k`` at
    zero, ``k_r`` at large drift)."""

    k: float
    k_r: float
    u0: float
    c: float

    def force(self, u, v, z):
        return (self.k_r * u + (self.k - self.k_r) * self.u0 * np.tanh(u / self.u0)
                + self.c * v), z[:0]


@dataclass
class QuinticHardening(Law):
    """``f = k u (1 + (u / u_5)^4) + c v`` per direction."""

    k: float
    u5: float
    c: float

    def force(self, u, v, z):
        return self.k * u * (1.0 + (u / self.u5) ** 4) + self.c * v, z[:0]


@dataclass
class SinhHardening(Law):
    """``f = k u_0 sinh(u / u_0) + c v`` (tangent ``k cosh(u / u_0)``), per direction."""

    k: float
    u0: float
    c: float

    def force(self, u, v, z):
        return self.k * self.u0 * np.sinh(u / self.u0) + self.c * v, z[:0]


@dataclass
class HertzGap(Law):
    """Linear ``k``, ``c`` plus a Hertz contact beyond a clearance ``g``, per direction:
    ``f_c = k_h max(|u| - g, 0)^1.5 sign(u)``; with ``one_sided`` only ``u > g`` touches
    (a stopper on one side: ``f_c = k_h max(u - g, 0)^1.5``)."""

    k: float
    c: float
    k_h: float
    g: float
    one_sided: bool = False

    def force(self, u, v, z):
        if self.one_sided:
            fc = self.k_h * np.maximum(u - self.g, 0.0) ** 1.5
        else:
            fc = self.k_h * np.maximum(np.abs(u) - self.g, 0.0) ** 1.5 * np.sign(u)
        return self.k * u + self.c * v + fc, z[:0]


@dataclass
class ArctanFriction(Law):
    """Dry friction alone, regularised by an arctangent, per direction:
    ``f = F (2 / pi) arctan(v / v_eps)`` (``F`` the sliding force, N; 90 % of it is
    reached at ``|v| = 6.3 v_eps``). Meant in parallel with a linear spring-dashpot (the
    friction of a hydraulic damper's seals)."""

    F: float
    v_eps: float

    def force(self, u, v, z):
        return self.F * (2.0 / np.pi) * np.arctan(v / self.v_eps), z[:0]


@dataclass
class SeriesBushingDashpot(Law):
    """A dashpot ``c`` behind an elastic bushing ``k_b`` (in series), per direction: the
    force ``f`` they carry is an ODE state, ``f' = k_b (v - f / c)`` (the bushing stretches
    by ``f / k_b``, the dashpot moves at ``f / c``). Slow strokes see the dashpot, fast ones
    the bushing (relaxation time ``c / k_b``)."""

    k_b: float
    c: float

    def __post_init__(self) -> None:
        self.n_ode = 2

    def force(self, u, v, z):
        return z.copy(), self.k_b * (v - z / self.c)
