"""3D rigid-flexible trailer car on a linear wheel-rail contact ([002] Sec. 5.1, Fig. 13).

Bodies and coordinates (x forward, y left, z up; rotations about x, y, z: roll, pitch,
yaw): the carbody through its reduced model (:mod:`modal_twin.models.carbody_interface`:
rigid, six DOFs of ``G``, or the Craig-Bampton shell of :mod:`modal_twin.models.
carbody_shell`), two bogie frames of six DOFs each, four wheelsets with
lateral ``y`` and yaw ``psi`` (their vertical ``z`` and roll ``phi`` follow the track's
vertical profile and cross level, their longitudinal motion is held). The small motion of
a point ``p`` of a rigid body with reference point ``o`` is ``[I, -skew(p - o)] [u;
theta]``.

Every suspension element acts along a unit direction ``e`` between a point on body A and
the same point on body B; its elongation is linear in the coordinates ``q`` and the track
input ``u``: ``d = g' q + h' u``. Springs store ``k d^2 / 2``; dashpots dissipate with
``c d'``; a **Maxwell** element (a dashpot ``c`` in series with a spring ``k``, [002] Sec.
5.1) has the internal state ``e`` (the dashpot's stroke)::

    f = k (d - e),     c e' = k (d - e)

Elements: per axle box a primary spring in x, y, z and a vertical dashpot (wheelset ->
bogie); per air spring x, y, z springs and a vertical Maxwell damper (bogie -> seat); per
bogie a lateral Maxwell damper, two yaw (anti-yaw) Maxwell dampers at ``+-half_spacing``, a
traction rod (x) and an anti-roll bar (the lateral damper and the traction rod act at the
carbody's centre pin ``pivot_<b>`` when it has one, else offset from ``seat_<b>L``), a roll
stiffness on the relative roll measured at the two seats ``(d_zL - d_zR) / (2
half_spacing)``. The wheel-rail forces are the linear contact of
:mod:`modal_twin.models.wheel_rail` on each wheelset's ``(y, psi)`` with the alignment
``y_a`` under it. Gravity's roll (pendulum) terms of the bodies are neglected.

**Equipment** on elastic hangers (the file's ``equipment`` with ``hanger: elastic``,
:mod:`modal_twin.models.vehicle3d_spec`): each box is a rigid body of six DOFs about its
centre of mass ``E`` (``<box>_x .. <box>_yaw``, after the wheelsets), ``M_e = diag(m, m,
m, J_xx, J_yy, J_zz)``, on four hangers at ``x_e +- half_length`` on the side beams
(underframe, ``y = +-W/2`` at the underframe's height) or the roof (``y = +-half_width``),
each a spring-damper ``<box>_hanger<j>_<axis>`` in x, y and z (``k d + c d'``) from the box's
point to the carbody's point there (``ReducedCarbody.hangers``). The rigid carbody's values
are the car in service with its boxes ([002] Sec. 2's 41.03 t), so its own mass matrix
about ``G`` loses each hung box's rigid-body mass::

    M_c = diag(m, m, m, I_xx, I_yy, I_zz) - T_e' M_e T_e,   T_e = [[I, -skew(E - G)], [0, I]]

and the car's total mass and centre of mass stay the file's; the shell leaves out its own
item of the box's name and its hanger nodes are interface nodes of the reduction.

First-order model, state ``s = [q; q'; e]``, input ``w = [u; u']`` with
``u = [z_1..4, phi_1..4, ya_1..4]`` (:func:`modal_twin.models.track3d.track_inputs_3d`)::

    M q'' = -(K + K_c) q - (C + C_c(V)) q' + G_m K_m e + B_u u + B_du u'
    e'    = (K_m / C_m) (G_m' q + H_m u - e)

The ride outputs are the floor points' absolute accelerations (vertical and lateral),
rows of ``s'``. It is linear and time invariant at a given speed: simulated by the exact
zero-order-hold discretisation ``[A_d, B_d] = expm([[A, B], [0, 0]] dt)`` (input held over
each sample), and its eigenvalues over speed give the hunting critical speed, where the
least-damped kinematic mode's damping ratio crosses zero (:mod:`modal_twin.models.hunting`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg as sla
import scipy.signal

from modal_twin._types import ComplexArray, FloatArray
from modal_twin.errors import ModelError, OptionError, ShapeError
from modal_twin.models.carbody3d import Equipment
from modal_twin.models.carbody_interface import (
    ReducedCarbody,
    offset_matrix,
    rigid_carbody,
    skew,
)
from modal_twin.models.carbody_shell import vehicle_shell_carbody
from modal_twin.models.vehicle3d_spec import Vehicle3DSpec
from modal_twin.models.wheel_rail import WheelRailContact, contact_matrices

__all__ = [
    "SimulationResult",
    "SuspensionElement",
    "Vehicle3D",
    "box_centre",
    "box_mass",
    "build_vehicle3d",
    "carbody_full",
    "default_carbody",
    "hanger_points",
    "hanger_stiffness",
    "mass_matrix",
    "n_coordinates",
    "propagate",
    "rigid_mass_about",
    "suspension_elements",
    "zoh",
]

N_AXLES = 4
N_U = 3 * N_AXLES  # z, phi, ya per wheelset
_SIX = ("x", "y", "z", "roll", "pitch", "yaw")


@dataclass(frozen=True, slots=True)
class _Anchor:
    """A body's reference motion ``[u; theta] = Tq q + Tu u`` about the point ``origin``."""

    Tq: FloatArray
    Tu: FloatArray
    origin: FloatArray

    def at(self, p: FloatArray) -> tuple[FloatArray, FloatArray]:
        L = offset_matrix(p - self.origin)
        return L @ self.Tq, L @ self.Tu


@dataclass(frozen=True, slots=True)
class SuspensionElement:
    """One suspension element: its elongation ``d = g' q + h' u`` and its law.

    Attributes
    ----------
    name : str
        ``primary_1L_y``, ``air_spring_2R_z``, ``yaw_damper_1L``, ``anti_roll_bar_2`` ...
    kind : {"spring", "damper", "spring_damper", "maxwell"}
        Spring ``k d``, dashpot ``c d'``, both in parallel (an equipment hanger), or Maxwell
        (dashpot ``c`` behind ``k``; module docstring).
    g : (n,) float array
        Elongation per coordinate ``q``.
    h : (12,) float array
        Elongation per track input ``u``.
    k, c : float
    axis : {"x", "y", "z"}
        Direction the element acts along (the anti-roll bar: ``x``, a roll, rad).
    """

    name: str
    kind: str  # spring | damper | spring_damper | maxwell
    g: FloatArray
    h: FloatArray
    k: float = 0.0
    c: float = 0.0
    axis: str = "z"


_Element = SuspensionElement


@dataclass(frozen=True, slots=True)
class Vehicle3D:
    """The assembled 3D vehicle (module docstring).

    Attributes
    ----------
    spec : Vehicle3DSpec
    carbody : ReducedCarbody
    dof_names : tuple of str
        Names of the coordinates ``q``.
    M, K, C : (n, n) float arrays
        Mass, suspension stiffness (without contact, Maxwell springs included) and
        dashpot damping.
    Gm : (n, m) float array
        Maxwell elements' directions ``g``; ``Hm`` (m, 12) their track terms.
    km, cm : (m,) float arrays
        Maxwell series stiffness and damping.
    Bu, Bdu : (n, 12) float arrays
        Generalised forces per unit track input and input rate (suspensions only).
    contact : WheelRailContact
    maxwell_names : tuple of str
    """

    spec: Vehicle3DSpec
    carbody: ReducedCarbody
    dof_names: tuple[str, ...]
    M: FloatArray
    K: FloatArray
    C: FloatArray
    Gm: FloatArray
    Hm: FloatArray
    km: FloatArray
    cm: FloatArray
    Bu: FloatArray
    Bdu: FloatArray
    contact: WheelRailContact
    maxwell_names: tuple[str, ...]
    _wheelset_dofs: tuple[tuple[int, int], ...] = field(default=())

    @property
    def n_dof(self) -> int:
        """Number of mechanical coordinates ``q``."""
        return int(self.M.shape[0])

    @property
    def n_state(self) -> int:
        """``2 n_dof + number of Maxwell elements``."""
        return 2 * self.n_dof + int(self.km.size)

    def dof(self, name: str) -> int:
        """Index of coordinate ``name`` (e.g. ``"ws1_y"``, ``"car_z"``, ``"bogie2_yaw"``)."""
        try:
            return self.dof_names.index(name)
        except ValueError:
            msg = f"dof: expected one of {list(self.dof_names)}, got {name!r}"
            raise OptionError(msg) from None

    def state_space(self, speed: float) -> tuple[FloatArray, FloatArray]:
        """Return ``A (ns, ns)`` and ``B (ns, 24)`` at ``speed`` (m/s; module docstring)."""
        n, m = self.n_dof, int(self.km.size)
        Kt, Ct = self.K.copy(), self.C.copy()
        Bu = self.Bu.copy()
        Cc, Kc, Ba = contact_matrices(self.contact, speed)
        for a, (iy, ipsi) in enumerate(self._wheelset_dofs):
            ix = np.ix_([iy, ipsi], [iy, ipsi])
            Kt[ix] += Kc
            Ct[ix] += Cc
            Bu[[iy, ipsi], 2 * N_AXLES + a] += Ba  # alignment ya of wheelset a
        Minv = np.linalg.inv(self.M)
        A = np.zeros((2 * n + m, 2 * n + m))
        A[:n, n:2 * n] = np.eye(n)
        A[n:2 * n, :n] = -Minv @ Kt
        A[n:2 * n, n:2 * n] = -Minv @ Ct
        A[n:2 * n, 2 * n:] = Minv @ (self.Gm * self.km)
        rate = self.km / self.cm
        A[2 * n:, :n] = rate[:, None] * self.Gm.T
        A[2 * n:, 2 * n:] = -np.diag(rate)
        B = np.zeros((2 * n + m, 2 * N_U))
        B[n:2 * n, :N_U] = Minv @ Bu
        B[n:2 * n, N_U:] = Minv @ self.Bdu
        B[2 * n:, :N_U] = rate[:, None] * self.Hm
        return A, B

    def floor_outputs(self, A: FloatArray, B: FloatArray) -> tuple[FloatArray, FloatArray,
                                                                    list[str]]:
        """Output matrices of the floor accelerations: ``y = Cy s + Dy w``.

        Returns
        -------
        Cy, Dy : (2 n_points, ns), (2 n_points, 24) float arrays
            Rows ``<label>_z`` then ``<label>_y`` per floor point (absolute, m/s^2).
        names : list of str
        """
        n = self.n_dof
        rows, names = [], []
        for label, (_, P) in self.carbody.points.items():
            Pq = np.zeros((3, n))
            Pq[:, : self.carbody.n] = P
            for axis, tag in ((2, "z"), (1, "y")):
                rows.append(Pq[axis])
                names.append(f"floor_{label}_{tag}")
        S = np.array(rows)
        return S @ A[n:2 * n], S @ B[n:2 * n], names

    def is_stable(self, speed: float) -> bool:
        """Tell whether every eigenvalue at ``speed`` has a negative real part."""
        return bool(np.max(self.eigenvalues(speed).real) < 0.0)

    def eigenvalues(self, speed: float) -> ComplexArray:
        """Eigenvalues of ``A`` at ``speed``, rad/s (complex)."""
        A, _ = self.state_space(speed)
        return np.asarray(np.linalg.eigvals(A), dtype=np.complex128)

    def kinematic_modes(self, speed: float, *, f_min_hz: float = 0.1,
                        kinematic_share: float = 0.25) -> ComplexArray:
        """Eigenvalues (rad/s, Im > 0) of the kinematic modes at ``speed``.

        Kinematic modes: oscillatory eigenvalues (above ``f_min_hz``) whose eigenvector
        puts at least ``kinematic_share`` of ``|q|^2`` in the wheelsets' lateral and yaw
        coordinates (0 takes every oscillatory mode); a carbody with a ``motion`` matrix
        (modal coordinates) enters ``|q|^2`` by those physical motions.
        """
        A, _ = self.state_space(speed)
        lam, X = np.linalg.eig(A)
        ws = [i for pair in self._wheelset_dofs for i in pair]
        Q = np.abs(X[: self.n_dof]) ** 2
        motion = self.carbody.motion
        if motion is not None:  # a modal carbody counts by its physical motion (m, rad)
            nc = self.carbody.n
            Q = np.vstack([np.abs(motion @ X[:nc]) ** 2, Q[nc:]])
            ws = [i - nc + motion.shape[0] for i in ws]
        share = Q[ws].sum(axis=0) / Q.sum(axis=0)
        osc = (lam.imag > 2.0 * math.pi * f_min_hz) & (share >= kinematic_share)
        return np.asarray(lam[osc], dtype=np.complex128)

    def least_damped(self, speed: float, *, f_min_hz: float = 0.1,
                     kinematic_share: float = 0.25) -> tuple[float, float]:
        """Damping ratio and frequency (Hz) of the least-damped kinematic mode.

        ``(inf, nan)`` when there is none (at a crawl the creep forces damp every wheelset
        motion critically; see :meth:`kinematic_modes`).
        """
        lam = self.kinematic_modes(speed, f_min_hz=f_min_hz, kinematic_share=kinematic_share)
        if lam.size == 0:
            return math.inf, math.nan
        zeta = -lam.real / np.abs(lam)
        i = int(np.argmin(zeta))
        return float(zeta[i]), float(lam[i].imag / (2.0 * math.pi))

    def simulate(self, w: FloatArray, fs_hz: float, speed: float, *,
                 s0: FloatArray | None = None, dofs: tuple[str, ...] = ()) -> SimulationResult:
        """Run the model on the track input ``w`` (24, nt) at ``speed`` (zero-order hold).

        Parameters
        ----------
        w : (24, nt) float array
            ``[u; u']`` (:func:`modal_twin.models.track3d.track_inputs_3d`).
        fs_hz : float
        speed : float
            m/s.
        s0 : (ns,) float array, optional
            Initial state (default rest).
        dofs : tuple of str
            Coordinates ``q`` to return besides the floor accelerations (``"ws1_y"`` ...).

        Raises
        ------
        ShapeError
            ``w`` not (24, nt) or ``s0`` of the wrong length.
        OptionError
            Bad rate or speed, unknown DOF name.
        """
        w = np.asarray(w, dtype=float)
        if w.ndim != 2 or w.shape[0] != 2 * N_U:
            msg = f"w: expected shape ({2 * N_U}, nt), got {w.shape}"
            raise ShapeError(msg)
        if not (math.isfinite(fs_hz) and fs_hz > 0):
            msg = f"fs_hz: expected a positive finite rate, got {fs_hz!r}"
            raise OptionError(msg)
        A, B = self.state_space(speed)
        Ad, Bd = zoh(A, B, 1.0 / fs_hz)
        Cy, Dy, names = self.floor_outputs(A, B)
        ns = A.shape[0]
        s = np.zeros(ns) if s0 is None else np.asarray(s0, dtype=float).copy()
        if s.shape != (ns,):
            msg = f"s0: expected shape ({ns},), got {s.shape}"
            raise ShapeError(msg)
        Sq = np.zeros((len(dofs), ns))
        for r, d in enumerate(dofs):
            Sq[r, self.dof(d)] = 1.0
        Y = propagate(Ad, Bd, w, s, np.vstack([Cy, Sq]))
        return SimulationResult(t=np.arange(w.shape[1]) / fs_hz, dofs=Y[len(names):],
                                dof_names=tuple(dofs), floor=Y[: len(names)] + Dy @ w,
                                floor_names=tuple(names), speed=speed)


def propagate(Ad: FloatArray, Bd: FloatArray, w: FloatArray, s0: FloatArray,
              C_out: FloatArray) -> FloatArray:
    """Return the outputs ``C_out s_k`` (n_out, nt) of ``s_{k+1} = Ad s_k + Bd w_k``, ``s_0 = s0``.

    In the eigenvector basis of ``Ad`` (``Ad = V diag(mu) V^-1``) every mode is a
    first-order recursion ``z_k = mu z_{k-1} + c_{k-1}``, run by ``scipy.signal.lfilter``;
    of a complex-conjugate pair only one is run (its output counted twice, real part). A
    step-by-step loop is used when ``V`` is ill conditioned (cond > 1e8).
    """
    mu, V = np.linalg.eig(Ad)
    nt = w.shape[1]
    if np.linalg.cond(V) < 1e8:
        Vinv = np.linalg.inv(V)
        keep = np.flatnonzero(mu.imag >= 0.0)
        c = (Vinv[keep] @ Bd) @ w
        z0 = Vinv[keep] @ s0
        Z = np.empty((keep.size, nt), dtype=np.complex128)
        for j, i in enumerate(keep):
            Z[j] = scipy.signal.lfilter([0.0, 1.0], [1.0, -mu[i]], c[j], zi=[z0[j]])[0]
        weight = np.where(mu[keep].imag > 0.0, 2.0, 1.0)
        return np.asarray(((C_out @ V[:, keep]) * weight) @ Z, dtype=np.complex128).real
    X = np.empty((nt, Ad.shape[0]))
    s, AdT, BwT = s0.copy(), Ad.T, (Bd @ w).T
    for k in range(nt):
        X[k] = s
        s = s @ AdT + BwT[k]
    return np.asarray(C_out @ X.T, dtype=np.float64)


def zoh(A: FloatArray, B: FloatArray, dt: float) -> tuple[FloatArray, FloatArray]:
    """Exact zero-order-hold discretisation ``expm([[A, B], [0, 0]] dt)``."""
    ns, ni = A.shape[0], B.shape[1]
    E = np.zeros((ns + ni, ns + ni))
    E[:ns, :ns], E[:ns, ns:] = A, B
    Ed = sla.expm(E * dt)
    return Ed[:ns, :ns], Ed[:ns, ns:]


@dataclass(frozen=True, slots=True)
class SimulationResult:
    """A run of :meth:`Vehicle3D.simulate`.

    Attributes
    ----------
    t : (nt,) float array
        s.
    dofs : (n_dofs, nt) float array
        The coordinates asked for, m or rad.
    dof_names : tuple of str
    floor : (2 n_points, nt) float array
        Floor accelerations, m/s^2, rows named by ``floor_names``.
    floor_names : tuple of str
    speed : float
        m/s.
    """

    t: FloatArray
    dofs: FloatArray
    dof_names: tuple[str, ...]
    floor: FloatArray
    floor_names: tuple[str, ...]
    speed: float

    def channel(self, name: str) -> FloatArray:
        """One floor channel by name (``floor_mid_z`` ...)."""
        if name not in self.floor_names:
            msg = f"channel: expected one of {list(self.floor_names)}, got {name!r}"
            raise OptionError(msg)
        return np.asarray(self.floor[self.floor_names.index(name)])


# ---------------------------------------------------------------------------- assembly
def _body_anchor(n: int, col: int, origin: FloatArray) -> _Anchor:
    Tq = np.zeros((6, n))
    Tq[:, col:col + 6] = np.eye(6)
    return _Anchor(Tq, np.zeros((6, N_U)), origin)


def _wheelset_anchor(n: int, iy: int, a: int, origin: FloatArray) -> _Anchor:
    Tq, Tu = np.zeros((6, n)), np.zeros((6, N_U))
    Tq[1, iy], Tq[5, iy + 1] = 1.0, 1.0  # lateral y and yaw psi
    Tu[2, a], Tu[3, N_AXLES + a] = 1.0, 1.0  # vertical z and roll phi follow the track
    return _Anchor(Tq, Tu, origin)


def _carbody_at(cb: ReducedCarbody, n: int, seat: str, p: FloatArray
                ) -> tuple[FloatArray, FloatArray]:
    Pq = np.zeros((3, n))
    Pq[:, : cb.n] = cb.at_seat(seat, p)
    return Pq, np.zeros((3, N_U))


def _element(name: str, kind: str, A: tuple[FloatArray, FloatArray],
             Bp: tuple[FloatArray, FloatArray], e: FloatArray, k: float = 0.0,
             c: float = 0.0) -> _Element:
    """Element along ``e`` from a point of body A to the same point of body B."""
    return _Element(name, kind, e @ (Bp[0] - A[0]), e @ (Bp[1] - A[1]), k, c,
                    "xyz"[int(np.argmax(np.abs(e)))])


def _primary(spec: Vehicle3DSpec, n: int, b: int, bog: _Anchor,
             ws: list[tuple[int, int]]) -> list[_Element]:
    """Axle-box springs (x, y, z) and vertical dashpots of bogie ``b``."""
    v, r0 = spec.v, spec.v("contact", "r0")
    out = []
    for a in (2 * b, 2 * b + 1):
        xa = spec.axle_x[a]
        wa = _wheelset_anchor(n, ws[a][0], a, np.array([xa, 0.0, r0]))
        for side, sgn in (("L", 1.0), ("R", -1.0)):
            p = np.array([xa, sgn * v("primary", "half_spacing"), r0])
            for axis, kk in enumerate(("kx", "ky", "kz")):
                out.append(_element(f"primary_{a + 1}{side}_{kk[1]}", "spring", wa.at(p),
                                    bog.at(p), np.eye(3)[axis], k=v("primary", kk)))
            out.append(_element(f"primary_{a + 1}{side}_cz", "damper", wa.at(p), bog.at(p),
                                np.eye(3)[2], c=v("primary", "cz")))
    return out


def _secondary(spec: Vehicle3DSpec, carbody: ReducedCarbody, n: int, b: int,
               bog: _Anchor) -> list[_Element]:
    """Air springs, Maxwell dampers, traction rod and anti-roll bar of bogie ``b``."""
    v = spec.v
    xb = spec.pivot_x[b]
    ds, hs = v("secondary", "half_spacing"), v("secondary", "seat_height")
    ex, ey, ez = np.eye(3)
    out: list[_Element] = []
    seat_dz = []
    for side, sgn in (("L", 1.0), ("R", -1.0)):
        seat = f"seat_{b + 1}{side}"
        p = np.array([xb, sgn * ds, hs])
        for e, kk in ((ex, "kx"), (ey, "ky"), (ez, "kz")):
            out.append(_element(f"air_spring_{b + 1}{side}_{kk[1]}", "spring", bog.at(p),
                                _carbody_at(carbody, n, seat, p), e, k=v("secondary", kk)))
        for dev, e in (("vertical_damper", ez), ("yaw_damper", ex)):
            pd = np.array([xb, sgn * v(dev, "half_spacing"), hs])
            out.append(_element(f"{dev}_{b + 1}{side}", "maxwell", bog.at(pd),
                                _carbody_at(carbody, n, seat, pd), e, k=v(dev, "k_series"),
                                c=v(dev, "c")))
        seat_dz.append(ez @ (_carbody_at(carbody, n, seat, p)[0] - bog.at(p)[0]))
    pc = np.array([xb, 0.0, hs])
    pin = f"pivot_{b + 1}" if f"pivot_{b + 1}" in carbody.seats else f"seat_{b + 1}L"
    car_c = _carbody_at(carbody, n, pin, pc)  # a flexible carbody's centre pin
    out.append(_element(f"lateral_damper_{b + 1}", "maxwell", bog.at(pc), car_c, ey,
                        k=v("lateral_damper", "k_series"), c=v("lateral_damper", "c")))
    out.append(_element(f"traction_rod_{b + 1}", "spring", bog.at(pc), car_c, ex,
                        k=v("traction_rod", "kx")))
    out.append(_Element(f"anti_roll_bar_{b + 1}", "spring", (seat_dz[0] - seat_dz[1]) / (2.0 * ds),
                        np.zeros(N_U), k=v("anti_roll_bar", "k_roll"), axis="x"))
    return out


def _mass(spec: Vehicle3DSpec, carbody: ReducedCarbody, n: int) -> FloatArray:
    v, nc = spec.v, carbody.n
    M = np.zeros((n, n))
    M[:nc, :nc] = carbody.M
    for b in range(2):
        c0 = nc + 6 * b
        M[c0:c0 + 6, c0:c0 + 6] = np.diag([v("bogie", "mass")] * 3 + [
            v("bogie", "Ixx"), v("bogie", "Iyy"), v("bogie", "Izz")])
    for a in range(N_AXLES):
        iy = nc + 12 + 2 * a
        M[iy, iy], M[iy + 1, iy + 1] = v("wheelset", "mass"), v("wheelset", "Izz")
    for i, box in enumerate(spec.hung_equipment):
        c0 = nc + 20 + 6 * i
        M[c0:c0 + 6, c0:c0 + 6] = box_mass(box)
    return M


def box_mass(box: Equipment) -> FloatArray:
    """``diag(m, m, m, J_xx, J_yy, J_zz)`` of a box about its centre of mass."""
    return np.diag([box.mass] * 3 + [float(j) for j in box.inertia])


def rigid_mass_about(M_e: FloatArray, r: FloatArray) -> FloatArray:
    """Return a body's 6x6 mass matrix (about its point ``o``) seen from ``o - r``.

    ``T' M_e T`` with ``T = [[I, -skew(r)], [0, I]]`` (the body's motion at ``o`` of a
    rigid motion of the reference point; module docstring).
    """
    T = np.eye(6)
    T[:3, 3:] = -skew(r)
    return np.asarray(T.T @ M_e @ T)


def default_carbody(spec: Vehicle3DSpec) -> ReducedCarbody:
    """Return the spec's carbody: rigid (its mass and inertia) or the shell (``carbody_model``).

    The rigid carbody loses the hung boxes' mass and has their hanger points (module
    docstring).

    Raises
    ------
    ModelError
        The boxes outweigh the carbody (its mass matrix without them is not positive).
    """
    if spec.carbody_model == "shell":
        return vehicle_shell_carbody(spec)
    v = spec.v
    ds, hs = v("secondary", "half_spacing"), v("secondary", "seat_height")
    seats = {f"seat_{i + 1}{side}": (x, sgn * ds, hs) for i, x in enumerate(spec.pivot_x)
             for side, sgn in (("L", 1.0), ("R", -1.0))}
    pts = {p.label: (p.x, p.y, v("carbody", "floor_height")) for p in spec.floor_points}
    G = np.array([0.0, 0.0, v("carbody", "cg_height")])
    cb = rigid_carbody(v("carbody", "mass"), (v("carbody", "Ixx"), v("carbody", "Iyy"),
                       v("carbody", "Izz")), tuple(G), seats, pts)
    if not spec.hung_equipment:
        return cb
    M = cb.M.copy()
    hangers = {}
    for box in spec.hung_equipment:
        M -= rigid_mass_about(box_mass(box), box_centre(spec, box) - G)
        hangers.update({k: (p, offset_matrix(p - G)) for k, p in hanger_points(spec, box).items()})
    if np.linalg.eigvalsh(0.5 * (M + M.T)).min() <= 0.0:
        msg = (f"{spec.source}: equipment: the hung boxes outweigh the carbody's mass or "
               f"inertia ({[e.name for e in spec.hung_equipment]})")
        raise ModelError(msg)
    return replace(cb, M=0.5 * (M + M.T), hangers=hangers)


def build_vehicle3d(spec: Vehicle3DSpec, carbody: ReducedCarbody | None = None) -> Vehicle3D:
    """Assemble the 3D vehicle of ``spec`` (module docstring).

    Parameters
    ----------
    spec : Vehicle3DSpec
    carbody : ReducedCarbody, optional
        A flexible carbody with the four seats and the spec's floor points; default: the
        spec's ``carbody_model``: the rigid carbody of the spec's mass and inertia, or the
        Craig-Bampton shell carbody (:func:`modal_twin.models.carbody_shell.
        vehicle_shell_carbody`; some seconds to build and reduce, kept in memory).
    """
    v = spec.v
    cb = carbody if carbody is not None else default_carbody(spec)
    nc = cb.n
    n = n_coordinates(spec, cb)
    names = [f"car_{k}" for k in cb.coordinate_names]
    for b in (1, 2):
        names += [f"bogie{b}_{d}" for d in _SIX]
    for a in range(1, N_AXLES + 1):
        names += [f"ws{a}_y", f"ws{a}_yaw"]
    for e in spec.hung_equipment:
        names += [f"{e.name}_{d}" for d in _SIX]
    ws = [(nc + 12 + 2 * a, nc + 13 + 2 * a) for a in range(N_AXLES)]
    els = suspension_elements(spec, cb)
    K, C = carbody_full(cb, n)
    Bu, Bdu = np.zeros((n, N_U)), np.zeros((n, N_U))
    mx = [el for el in els if el.kind == "maxwell" and el.c > 0.0]
    for el in els:
        if el.kind in ("spring", "spring_damper") or (el.kind == "maxwell" and el.c > 0.0):
            K += el.k * np.outer(el.g, el.g)
            Bu -= el.k * np.outer(el.g, el.h)
        if el.kind in ("damper", "spring_damper"):
            C += el.c * np.outer(el.g, el.g)
            Bdu -= el.c * np.outer(el.g, el.h)
    contact = WheelRailContact(v("contact", "conicity"), v("contact", "r0"), v("contact", "b"),
                               v("contact", "f11"), v("contact", "f22"),
                               axle_load=spec.axle_load)
    return Vehicle3D(
        spec=spec, carbody=cb, dof_names=tuple(names), M=_mass(spec, cb, n), K=K, C=C,
        Gm=np.array([el.g for el in mx]).T.reshape(n, len(mx)),
        Hm=np.array([el.h for el in mx]).reshape(len(mx), N_U),
        km=np.array([el.k for el in mx]), cm=np.array([el.c for el in mx]),
        Bu=Bu, Bdu=Bdu, contact=contact, maxwell_names=tuple(el.name for el in mx),
        _wheelset_dofs=tuple(ws))


def suspension_elements(spec: Vehicle3DSpec, carbody: ReducedCarbody
                        ) -> list[SuspensionElement]:
    """Every suspension element of the car on the coordinates of :func:`build_vehicle3d`.

    Bogie 1's primary (axle boxes of wheelsets 1, 2) and secondary elements, then bogie
    2's (module docstring); ``g`` has ``carbody.n + 20`` entries.
    """
    nc = carbody.n
    n = n_coordinates(spec, carbody)
    ws = [(nc + 12 + 2 * a, nc + 13 + 2 * a) for a in range(N_AXLES)]
    els: list[SuspensionElement] = []
    for b in range(2):
        bog = _body_anchor(n, nc + 6 * b, np.array([spec.pivot_x[b], 0.0,
                                                    spec.v("bogie", "cg_height")]))
        els += _primary(spec, n, b, bog, ws) + _secondary(spec, carbody, n, b, bog)
    return els + _hangers(spec, carbody, n)


def n_coordinates(spec: Vehicle3DSpec, carbody: ReducedCarbody) -> int:
    """Return the number of coordinates ``q``: carbody, bogies, wheelsets, hung boxes."""
    return carbody.n + 2 * 6 + 2 * N_AXLES + 6 * len(spec.hung_equipment)


def mass_matrix(spec: Vehicle3DSpec, carbody: ReducedCarbody) -> FloatArray:
    """Mass matrix of the car's coordinates ``q`` (carbody, bogies, wheelsets, boxes)."""
    return _mass(spec, carbody, n_coordinates(spec, carbody))


def box_centre(spec: Vehicle3DSpec, box: Equipment) -> FloatArray:
    """Centre of mass of an equipment box in the car's frame (from rail), m.

    Below the underframe (at the seat height, the shell's ``z = 0``) by ``depth``, or
    above the roof (``height`` of the shell's parameters higher) by ``depth``.
    """
    z0 = spec.v("secondary", "seat_height")
    z = (z0 + spec.shell.params.height + box.depth if box.mount == "roof"
         else z0 - box.depth)
    return np.array([box.x, 0.0, z])


def hanger_points(spec: Vehicle3DSpec, box: Equipment) -> dict[str, FloatArray]:
    """Return the four hanger points ``<box>_h1 .. _h4`` of a box on a rigid carbody, m.

    At ``x +- half_length`` (h1, h2 behind, h3, h4 ahead; right then left) on the side
    beams ``y = +-W/2`` at the underframe or on the roof at ``y = +-half_width`` (the
    shell's nodes there: :func:`modal_twin.models.carbody3d.build_carbody`).
    """
    p = spec.shell.params
    z0 = spec.v("secondary", "seat_height")
    roof = box.mount == "roof"
    hy, z = (box.half_width, z0 + p.height) if roof else (0.5 * p.width, z0)
    pts = [(box.x + sx * box.half_length, sy * hy, z) for sx in (-1.0, 1.0)
           for sy in (-1.0, 1.0)]
    return {f"{box.name}_h{j + 1}": np.array(q) for j, q in enumerate(pts)}


def hanger_stiffness(box: Equipment) -> tuple[FloatArray, FloatArray]:
    """Per hanger ``k`` and ``c`` in x, y, z (:mod:`modal_twin.models.vehicle3d_spec`)."""
    kz = box.mass * (2.0 * math.pi * box.f_mount_hz) ** 2 / 4.0
    cz = 2.0 * box.zeta * math.sqrt(kz * box.mass / 4.0)
    r = box.lateral_ratio
    return np.array([r * kz, r * kz, kz]), np.array([r * cz, r * cz, cz])


def _hangers(spec: Vehicle3DSpec, carbody: ReducedCarbody, n: int) -> list[_Element]:
    """Hanger spring-dampers of every hung box (module docstring)."""
    out: list[_Element] = []
    col = carbody.n + 2 * 6 + 2 * N_AXLES
    for i, box in enumerate(spec.hung_equipment):
        anchor = _body_anchor(n, col + 6 * i, box_centre(spec, box))
        k, c = hanger_stiffness(box)
        for j in range(4):
            key = f"{box.name}_h{j + 1}"
            if key not in carbody.hangers:
                msg = f"carbody {carbody.name!r}: no hanger point {key!r}"
                raise ModelError(msg)
            p, P = carbody.hangers[key]
            Pq = np.zeros((3, n))
            Pq[:, : carbody.n] = P
            for axis in range(3):
                out.append(_element(f"{box.name}_hanger{j + 1}_{'xyz'[axis]}",
                                    "spring_damper", anchor.at(p), (Pq, np.zeros((3, N_U))),
                                    np.eye(3)[axis], k=float(k[axis]), c=float(c[axis])))
    return out


def carbody_full(carbody: ReducedCarbody, n: int) -> tuple[FloatArray, FloatArray]:
    """Return the carbody's own K and C placed in the vehicle's (n, n) matrices."""
    K, C = np.zeros((n, n)), np.zeros((n, n))
    K[: carbody.n, : carbody.n] = carbody.K
    C[: carbody.n, : carbody.n] = carbody.C
    return K, C
