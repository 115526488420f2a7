"""Linear wheel-rail contact of a coned wheelset: creep forces and gravitational stiffness.

The classical linear model of a wheelset running at speed ``V`` on straight track
(Wickens, *Fundamentals of Rail Vehicle Dynamics*, Swets & Zeitlinger 2003, Ch. 2-4;
Garg & Dukkipati, *Dynamics of Railway Vehicle Systems*, Academic Press 1984, Ch. 5-6,
their Eqs. (6.1)-(6.2) without spin). The wheelset's lateral displacement ``y`` and yaw
``psi`` are taken relative to the track centre line, whose lateral alignment is ``y_a``;
``r0`` is the rolling radius, ``b`` half the distance between the contact points,
``lambda`` the equivalent conicity, ``f11`` / ``f22`` Kalker's linear longitudinal /
lateral creep coefficients of one wheel (N), ``W`` the axle load (N).

Creepages (longitudinal at the left / right wheel, lateral)::

    xi_x = +-(b psi' / V + lambda (y - y_a) / r0),    xi_y = y' / V - psi

Forces on the wheelset (two wheels; Kalker's linear theory, spin creep neglected)::

    F_y = -2 f22 (y' / V - psi) - k_gy (y - y_a)                 (lateral force)
    M_z = -2 f11 b (b psi' / V + lambda (y - y_a) / r0) - k_gpsi psi   (yaw moment)

with the gravitational stiffnesses of a coned wheelset (Wickens Sec. 2.5; Garg &
Dukkipati Eq. (5.70))::

    k_gy = W lambda / b       (restoring),      k_gpsi = -W lambda b   (destabilising)

In matrix form on ``(y, psi)``: ``F = -C_c(V) [y'; psi'] - K_c [y; psi] + B_a y_a``::

    C_c = diag(2 f22 / V, 2 f11 b^2 / V)
    K_c = [[k_gy, -2 f22], [2 f11 b lambda / r0, k_gpsi]]      (not symmetric)
    B_a = [k_gy, 2 f11 b lambda / r0]

The non-symmetric creep stiffness feeds energy into the kinematic (hunting) mode; its
damping ``C_c ~ 1 / V`` falls with speed, hence a critical speed. A free wheelset of
negligible inertia follows Klingel's kinematic oscillation ``y'' = -(V^2 lambda /
(b r0)) y`` of wavelength ``L_w = 2 pi sqrt(r0 b / lambda)``; a rigid bogie of wheelbase
``2 l`` has ``L_b = L_w sqrt(1 + (l / b)^2)`` (Wickens Sec. 4.2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.errors import ModelError, OptionError

__all__ = [
    "WheelRailContact",
    "bogie_kinematic_wavelength",
    "contact_matrices",
    "klingel_wavelength",
]


@dataclass(frozen=True, slots=True)
class WheelRailContact:
    """Linear contact parameters of one wheelset (module docstring).

    Attributes
    ----------
    conicity : float
        Equivalent conicity ``lambda``.
    r0 : float
        Rolling radius, m.
    b : float
        Half the distance between the contact points, m.
    f11, f22 : float
        Kalker's longitudinal and lateral creep coefficients of one wheel, N.
    axle_load : float
        Vertical load ``W`` on the wheelset (both wheels), N; 0 drops the gravitational
        stiffness.
    """

    conicity: float
    r0: float
    b: float
    f11: float
    f22: float
    axle_load: float = 0.0

    def __post_init__(self) -> None:
        for name in ("conicity", "r0", "b", "f11", "f22"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                msg = f"{name}: expected a finite value > 0, got {v!r}"
                raise ModelError(msg)
        if not (math.isfinite(self.axle_load) and self.axle_load >= 0.0):
            msg = f"axle_load: expected a finite value >= 0, got {self.axle_load!r}"
            raise ModelError(msg)

    @property
    def k_gy(self) -> float:
        """Lateral gravitational stiffness ``W lambda / b``, N/m."""
        return self.axle_load * self.conicity / self.b

    @property
    def k_gpsi(self) -> float:
        """Yaw gravitational stiffness ``-W lambda b``, N m/rad (destabilising)."""
        return -self.axle_load * self.conicity * self.b


def contact_matrices(contact: WheelRailContact, speed: float
                     ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Return ``C_c(V)``, ``K_c`` and ``B_a`` of one wheelset on ``(y, psi)``.

    Parameters
    ----------
    contact : WheelRailContact
    speed : float
        Running speed ``V``, m/s.

    Returns
    -------
    C_c : (2, 2) float array
        Creep damping, ``diag(2 f22 / V, 2 f11 b^2 / V)``.
    K_c : (2, 2) float array
        Creep and gravitational stiffness (not symmetric).
    B_a : (2,) float array
        Force and moment per metre of track alignment ``y_a``.

    Raises
    ------
    OptionError
        ``speed`` not positive and finite.

    Examples
    --------
    >>> c = WheelRailContact(0.2, 0.45, 0.75, 1e7, 1e7)
    >>> C, K, B = contact_matrices(c, 50.0)
    >>> print(C[0, 0], K[0, 1], round(K[1, 0]))
    400000.0 -20000000.0 6666667
    """
    if not (math.isfinite(speed) and speed > 0.0):
        msg = f"speed: expected a finite value > 0 m/s, got {speed!r}"
        raise OptionError(msg)
    c = contact
    k_yaw_y = 2.0 * c.f11 * c.b * c.conicity / c.r0
    C = np.diag([2.0 * c.f22 / speed, 2.0 * c.f11 * c.b**2 / speed])
    K = np.array([[c.k_gy, -2.0 * c.f22], [k_yaw_y, c.k_gpsi]])
    return C, K, np.array([c.k_gy, k_yaw_y])


def klingel_wavelength(contact: WheelRailContact) -> float:
    """Klingel's kinematic wavelength of a free wheelset ``2 pi sqrt(r0 b / lambda)``, m."""
    return 2.0 * math.pi * math.sqrt(contact.r0 * contact.b / contact.conicity)


def bogie_kinematic_wavelength(contact: WheelRailContact, wheelbase: float) -> float:
    """Kinematic wavelength of a rigid two-axle bogie ``L_w sqrt(1 + (l / b)^2)``, m.

    ``l`` is half the ``wheelbase`` (Wickens Sec. 4.2, rigid-frame bogie).
    """
    half = 0.5 * wheelbase
    return klingel_wavelength(contact) * math.sqrt(1.0 + (half / contact.b) ** 2)
