"""The carbody as a reduced model with six-DOF interface points: rigid or flexible.

The 3D vehicle (:mod:`modal_twin.models.vehicle3d`) sees its carbody only through a
:class:`ReducedCarbody`: mass, stiffness and damping matrices over the carbody's own
coordinates ``q_c`` (n of them), and for each **seat** (the four secondary-suspension seats,
names ``seat_1L, seat_1R, seat_2L, seat_2R``; bogie 1 leading, L = +y) a matrix ``T`` (6 x
n) giving the seat's small motion ``[u_x, u_y, u_z, theta_x, theta_y, theta_z] = T q_c`` (a
shell carbody adds its centre pins ``pivot_1, pivot_2``); for each floor **point** a matrix
``P`` (3 x n) giving its displacement. A suspension element attached at ``p`` near seat
``s`` moves with the seat as a rigid offset (the bolster is rigidly bolted to the
underframe, [002] Sec. 5.1)::

    u(p) = [I, -skew(p - p_s)] T_s q_c

A Craig-Bampton carbody (:mod:`modal_twin.models.carbody_shell`) enters with
``q_c = [u_b; eta]`` or its free-free modes: ``T_s`` is the seat node's motion and ``P``
the floor node's translations from the reduced basis. The rigid carbody of :func:`rigid_carbody`
has ``q_c`` = the six motions of its centre of gravity ``G``::

    M = diag(m, m, m, I_xx, I_yy, I_zz),  K = C = 0,  T_s = [[I, -skew(p_s - G)], [0, I]]

A light stand-in for the shell: :func:`with_bending_mode` adds one flexible coordinate
``eta`` to a carbody: the first free-free vertical bending of a uniform beam of length
``L`` and the carbody's mass ``m`` (Blevins, *Formulas for Natural Frequency and Mode
Shape*, 1979, Table 8-1, free-free: ``beta L = 4.73004``)::

    phi(s) = cosh(beta s) + cos(beta s) - sigma (sinh(beta s) + sin(beta s)),
    sigma = 0.982502,  s = x + L / 2,  int_0^L phi^2 ds = L

mass-normalised as ``phi / sqrt(m)`` (uniform line mass ``m / L``), so ``M_eta = 1``,
``K_eta = omega^2``, ``C_eta = 2 zeta omega``; it is orthogonal to the rigid translation
and (being symmetric) to the rigid pitch. A seat at ``x`` moves ``u_z = phi(x) eta`` and
pitches ``theta_y = -phi'(x) eta``; a floor point moves ``u_z = phi(x) eta``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.errors import ModelError, ShapeError

__all__ = [
    "RIGID_COORDINATES",
    "SEAT_NAMES",
    "ReducedCarbody",
    "offset_matrix",
    "rigid_carbody",
    "skew",
    "with_bending_mode",
]

RIGID_COORDINATES: tuple[str, ...] = ("x", "y", "z", "roll", "pitch", "yaw")
"""Coordinates of the rigid carbody (motions of ``G``)."""

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
    coordinates : tuple of str
        Names of the n coordinates (default ``q0 .. q<n-1>``).
    motion : (k, n) float array, optional
        Physical motions (m, rad) that stand for the carbody in a vehicle mode's shares,
        for carbodies whose coordinates are not physical (modal ones); None: ``q_c``.
    source : object, optional
        What the carbody was reduced from (a shell carbody:
        :class:`modal_twin.models.carbody_shell.ShellCarbody`), for naming its modes.
    hangers : mapping str -> ((3,) position, (3, n) P)
        Attachment points of the equipment boxes the vehicle hangs (``<box>_h1 ..
        <box>_h4``) and their displacement matrices; empty without such boxes.
    """

    name: str
    M: FloatArray
    K: FloatArray
    C: FloatArray
    seats: Mapping[str, tuple[FloatArray, FloatArray]]
    points: Mapping[str, tuple[FloatArray, FloatArray]]
    coordinates: tuple[str, ...] = ()
    motion: FloatArray | None = None
    source: object = field(default=None, compare=False, repr=False)
    hangers: Mapping[str, tuple[FloatArray, FloatArray]] = field(default_factory=dict)

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
        for what, pts in (("points", self.points), ("hangers", self.hangers)):
            for name, (_, P) in pts.items():
                if P.shape != (3, n):
                    msg = f"{what}[{name!r}]: expected P of shape (3, {n}), got {P.shape}"
                    raise ShapeError(msg)
        if self.coordinates and len(self.coordinates) != n:
            msg = f"coordinates: expected {n} names, got {len(self.coordinates)}"
            raise ShapeError(msg)

    @property
    def coordinate_names(self) -> tuple[str, ...]:
        """The coordinates' names (``q0 ..`` when none were given)."""
        return self.coordinates or tuple(f"q{k}" for k in range(self.n))

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
    return ReducedCarbody(name=name, M=M, K=z, C=z.copy(), seats=seat_map, points=pt_map,
                          coordinates=RIGID_COORDINATES)


_BETA_L = 4.730040745
_SIGMA = 0.982502215


def _beam_mode(x: float, length: float) -> tuple[float, float]:
    """Return the first free-free bending shape and slope at ``x`` (``int phi^2 = L``)."""
    b = _BETA_L / length
    s = x + 0.5 * length
    phi = np.cosh(b * s) + np.cos(b * s) - _SIGMA * (np.sinh(b * s) + np.sin(b * s))
    dphi = b * (np.sinh(b * s) - np.sin(b * s) - _SIGMA * (np.cosh(b * s) + np.cos(b * s)))
    return float(phi), float(dphi)


def with_bending_mode(carbody: ReducedCarbody, *, length: float, f_hz: float, zeta: float,
                      mass: float) -> ReducedCarbody:
    """Add the first free-free vertical bending of a uniform beam (module docstring).

    Parameters
    ----------
    carbody : ReducedCarbody
        Whose seats and points lie within ``+-length / 2`` in x.
    length : float
        Beam length, m.
    f_hz, zeta : float
        Frequency (Hz) and damping ratio of the mode.
    mass : float
        Carbody mass spread uniformly over the length, kg.

    Raises
    ------
    ModelError
        Non-positive length, frequency or mass, negative damping, a seat or point off the beam.
    """
    if not (length > 0.0 and f_hz > 0.0 and mass > 0.0 and zeta >= 0.0):
        msg = (f"length, f_hz, mass, zeta: expected positive values (zeta >= 0), got "
               f"{length!r}, {f_hz!r}, {mass!r}, {zeta!r}")
        raise ModelError(msg)
    n = carbody.n + 1
    w = 2.0 * np.pi * f_hz
    scale = 1.0 / np.sqrt(mass)

    def grow(A: FloatArray, extra: float) -> FloatArray:
        out = np.zeros((n, n))
        out[:-1, :-1] = A
        out[-1, -1] = extra
        return out

    seats, points = {}, {}
    for name, (p, T) in carbody.seats.items():
        if abs(p[0]) > 0.5 * length:
            msg = f"seats[{name!r}]: x = {p[0]} is off the beam of length {length}"
            raise ModelError(msg)
        phi, dphi = _beam_mode(float(p[0]), length)
        T2 = np.hstack([T, np.zeros((6, 1))])
        T2[2, -1], T2[4, -1] = phi * scale, -dphi * scale
        seats[name] = (p, T2)
    for name, (p, P) in carbody.points.items():
        if abs(p[0]) > 0.5 * length:
            msg = f"points[{name!r}]: x = {p[0]} is off the beam of length {length}"
            raise ModelError(msg)
        P2 = np.hstack([P, np.zeros((3, 1))])
        P2[2, -1] = _beam_mode(float(p[0]), length)[0] * scale
        points[name] = (p, P2)
    return ReducedCarbody(name=f"{carbody.name} + bending {f_hz:g} Hz", M=grow(carbody.M, 1.0),
                          K=grow(carbody.K, w * w), C=grow(carbody.C, 2.0 * zeta * w),
                          seats=seats, points=points,
                          coordinates=(*carbody.coordinate_names, "bending1"))
