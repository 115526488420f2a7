"""The carbody as a reduced model with six-DOF interface points: rigid now, flexible later.

The 3D vehicle (:mod:`modal_twin.models.vehicle3d`) sees its carbody only through a
:class:`ReducedCarbody`: mass, stiffness and damping matrices over the carbody's own
coordinates ``q_c`` (n of them), and for each **seat** (the four secondary-suspension
seats, names ``seat_1L, seat_1R, seat_2L, seat_2R``; bogie 1 leading, L = +y) a matrix
``T`` (6 x n) giving the seat's small motion ``[u_x, u_y, u_z, theta_x, theta_y,
theta_z] = T q_c``; for each floor **point** a matrix ``P`` (3 x n) giving its
displacement. A suspension element attached at ``p`` near seat ``s`` moves with the seat
as a rigid offset (the bolster is rigidly bolted to the underframe, [002] Sec. 5.1)::

    u(p) = [I, -skew(p - p_s)] T_s q_c

A Craig-Bampton carbody (:mod:`modal_twin.models.craig_bampton`) enters with
``q_c = [u_b; eta]``: ``T_s`` selects the seat node's six boundary DOFs and ``P`` the floor
node's translations from the reduced basis. The rigid carbody of :func:`rigid_carbody`
has ``q_c`` = the six motions of its centre of gravity ``G``::

    M = diag(m, m, m, I_xx, I_yy, I_zz),  K = C = 0,  T_s = [[I, -skew(p_s - G)], [0, I]]
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.errors import ModelError, ShapeError

__all__ = [
    "SEAT_NAMES",
    "ReducedCarbody",
    "offset_matrix",
    "rigid_carbody",
    "skew",
]

SEAT_NAMES: tuple[str, ...] = ("seat_1L", "seat_1R", "seat_2L", "seat_2R")
"""Interface names: secondary-suspension seats of bogie 1 (leading) and 2, left and right."""


def skew(r: Sequence[float] | FloatArray) -> FloatArray:
    """Cross-product matrix: ``skew(r) @ v = r x v``."""
    x, y, z = (float(v) for v in r)
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def offset_matrix(r: Sequence[float] | FloatArray) -> FloatArray:
    """``[I, -skew(r)]`` (3 x 6): displacement of a point at offset ``r`` of a rigid motion."""
    return np.hstack([np.eye(3), -skew(r)])


@dataclass(frozen=True, slots=True)
class ReducedCarbody:
    """A carbody over its own coordinates with six-DOF seats (module docstring).

    Attributes
    ----------
    name : str
    M, K, C : (n, n) float arrays
        Mass (kg, kg m^2), stiffness, damping in the carbody's coordinates.
    seats : mapping str -> ((3,) position, (6, n) T)
        Seat positions (m, from the carbody centre at rail level) and motion matrices.
    points : mapping str -> ((3,) position, (3, n) P)
        Floor points and their displacement matrices.
    """

    name: str
    M: FloatArray
    K: FloatArray
    C: FloatArray
    seats: Mapping[str, tuple[FloatArray, FloatArray]]
    points: Mapping[str, tuple[FloatArray, FloatArray]]

    def __post_init__(self) -> None:
        n = self.M.shape[0]
        for what, A in (("M", self.M), ("K", self.K), ("C", self.C)):
            if A.shape != (n, n):
                msg = f"{what}: expected shape ({n}, {n}), got {A.shape}"
                raise ShapeError(msg)
        missing = [s for s in SEAT_NAMES if s not in self.seats]
        if missing:
            msg = f"seats: expected {list(SEAT_NAMES)}, missing {missing}"
            raise ModelError(msg)
        for name, (_, T) in self.seats.items():
            if T.shape != (6, n):
                msg = f"seats[{name!r}]: expected T of shape (6, {n}), got {T.shape}"
                raise ShapeError(msg)
        for name, (_, P) in self.points.items():
            if P.shape != (3, n):
                msg = f"points[{name!r}]: expected P of shape (3, {n}), got {P.shape}"
                raise ShapeError(msg)

    @property
    def n(self) -> int:
        """Number of carbody coordinates."""
        return int(self.M.shape[0])

    def at_seat(self, seat: str, p: Sequence[float] | FloatArray) -> FloatArray:
        """Displacement matrix (3 x n) of a point ``p`` rigidly offset from ``seat``."""
        pos, T = self.seats[seat]
        return offset_matrix(np.asarray(p, dtype=float) - pos) @ T


def rigid_carbody(mass: float, inertia: Sequence[float], cg: Sequence[float],
                  seats: Mapping[str, Sequence[float]],
                  points: Mapping[str, Sequence[float]], *, name: str = "rigid") -> ReducedCarbody:
    """Build a rigid carbody of six DOFs at its centre of gravity (module docstring).

    Parameters
    ----------
    mass : float
        kg.
    inertia : (I_xx, I_yy, I_zz)
        Roll, pitch and yaw inertia about ``G``, kg m^2.
    cg : (3,) float
        Position of ``G``, m.
    seats, points : mapping name -> (3,) position
        Seat and floor-point positions, m.

    Raises
    ------
    ModelError
        A mass or inertia that is not positive.
    """
    I3 = [float(v) for v in inertia]
    if not (mass > 0.0 and len(I3) == 3 and all(v > 0.0 for v in I3)):
        msg = f"mass, inertia: expected positive values, got {mass!r}, {inertia!r}"
        raise ModelError(msg)
    G = np.asarray(cg, dtype=float)
    M = np.diag([mass, mass, mass, *I3])
    seat_map = {}
    for s, p in seats.items():
        r = np.asarray(p, dtype=float)
        T = np.eye(6)
        T[:3, 3:] = -skew(r - G)
        seat_map[s] = (r, T)
    pt_map = {k: (np.asarray(p, dtype=float), offset_matrix(np.asarray(p, dtype=float) - G))
              for k, p in points.items()}
    z = np.zeros((6, 6))
    return ReducedCarbody(name=name, M=M, K=z, C=z.copy(), seats=seat_map, points=pt_map)
