"""Independent truth of the 3D trailer car (rigid carbody), written from the physics.

Nothing here comes from the library: the parameters are read from
``config/vehicles/trailer_car_3d.yaml`` with ``yaml.safe_load``; the car is a set of bodies
with point-to-point suspension elements whose forces are computed from the bodies' motions;
the equations of motion are the bodies' Newton-Euler balances; the integrator is a
sub-stepped RK4. What is modelled is the library's 3D car (``modal_twin.models.vehicle3d``),
so that a hidden effect is the only difference between the two; the form is not.

Bodies (x forward, y left, z up; small rotations ``theta = (roll, pitch, yaw)``; the motion
of a point ``P`` of a rigid body with reference point ``O`` is ``u_P = u_O + theta x (P -
O)``, its force ``F`` at ``P`` acts on the body as ``F`` and the moment ``(P - O) x F``):

- wheelsets 1-4 (1 leading), reference point the axle centre ``(x_a, 0, r0)``, free in
  lateral ``y`` and yaw ``psi``; the vertical motion ``z`` and roll ``phi`` are those of the
  track under it (profile and cross level), the longitudinal motion is held, so the
  constraint takes every other force component;
- bogie frames 1, 2, six DOFs about their centres of gravity ``(+-L_p / 2, 0, h_b)``;
- the carbody, six DOFs about its centre of gravity ``(0, 0, h_c)``.

Coordinates in this order (not the library's): ``w1_y, w1_psi, .., w4_y, w4_psi``, then
bogie 1 ``(ux, uy, uz, rx, ry, rz)``, bogie 2, the carbody; then the Maxwell dampers'
series-spring states; the state is ``[q, q', e]``.

Elements (each a spring, dashpot or Maxwell element along one global axis between the
same point of two bodies, elongation ``d = axis . (u_P(upper body) - u_P(lower body))``):

- per axle box ``(x_a, +-primary.half_spacing, r0)``: springs in x, y, z and a vertical
  dashpot, wheelset -> bogie;
- per air spring ``(x_b, +-secondary.half_spacing, seat_height)``: springs x, y, z;
- per side a vertical and a yaw Maxwell damper at ``+-half_spacing`` (along z and x), a
  lateral Maxwell damper and a traction rod (x) on the centre line, bogie -> carbody;
- per bogie an anti-roll bar: a torsion spring ``k_roll`` on the carbody's roll relative
  to the bogie as seen at the air-spring seats, ``alpha = (d_zL - d_zR) / (2 s)``, acting as
  the vertical force pair ``+-k_roll alpha / (2 s)`` at the seats.

A Maxwell element (dashpot ``c`` in series with a spring ``k``; its own state is the
spring's extension ``x_s``) carries the force ``f = k x_s`` and its spring stretches by
what the dashpot does not take: ``x_s' = d' - f / c``. (The library writes the same element
with the dashpot's stroke ``e = d - x_s``.) The channels' stroke and force of a damper are
``d`` and ``f``.

Wheel-rail contact, linear (Kalker's linear creep theory without spin; Wickens,
*Fundamentals of Rail Vehicle Dynamics*, 2003, Ch. 2; Garg & Dukkipati, *Dynamics of
Railway Vehicle Systems*, 1984, Ch. 5-6): per wheel the creep forces ``F_x = -f11 xi_x``,
``F_y = -f22 xi_y`` with, for the wheelset's lateral position relative to the rail
``y_r = y - y_a`` (alignment ``y_a``) and rolling radii ``r0 +- lambda y_r``, the
creepages at the left (+b) / right (-b) wheel (rolling at ``Omega = V / r0``)::

    xi_x = (V -+ b psi' - Omega (r0 +- lambda y_r)) / V = -+(b psi' / V + lambda y_r / r0)
    xi_y = y' / V - psi

summed over the two wheels (forces at ``(0, +-b, 0)`` from the axle centre); the coned
wheels' gravitational stiffness (Wickens Sec. 2.5): a lateral force ``-W lambda / b y_r``
and a yaw moment ``+W lambda b psi`` (destabilising), ``W`` the axle load
(static: a quarter of carbody and bogies plus the wheelset, g = 9.81 m/s^2). With the
yaw ``psi`` absolute, the creepages need no term of the track's heading or curvature (the
track's heading cancels in ``xi_y``, and ``xi_x`` holds the wheelset's own yaw rate: on a
curve that is what gives the outward shift ``r0 b / (lambda R)``). As in the library: the
gravitational yaw moment on the absolute ``psi``, not on the yaw relative to the rail
``psi - y_a' / V`` (that term changes the benchmark track's lateral floor accelerations by
NRMSE 1-2e-3), no gravity (pendulum) terms of body roll, no spin creep.

Inputs ``w`` (24, nt): ``z_1..4, phi_1..4, ya_1..4`` then their rates, per wheelset (the
delays between wheelsets are in the track generator :func:`track_inputs_3d`). The system is
linear, so its matrices are the responses of the force balance to unit states and inputs
(:meth:`Vehicle3DOwn.matrices`); the hunting speed is the speed where the first
oscillatory eigenvalue of them crosses into the right half-plane (own bisection).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

FloatArray = np.ndarray
ROOT = Path(__file__).resolve().parents[3]
VEHICLE3D_YAML = ROOT / "config" / "vehicles" / "trailer_car_3d.yaml"
INPUTS = tuple([f"{c}{a}" for c in ("zt", "phit", "yat") for a in range(1, 5)]
               + [f"d{c}{a}" for c in ("zt", "phit", "yat") for a in range(1, 5)])
GRAVITY = 9.81
N_WS = 4
N_Q = 2 * N_WS + 6 + 6 + 6  # wheelsets (y, psi), bogie 1, bogie 2, carbody


@dataclass(frozen=True)
class _Body:
    name: str
    origin: FloatArray
    first: int  # index of its first coordinate
    wheelset: int = -1  # wheelset number 0..3, or -1 for a six-DOF body


@dataclass
class _Element:
    name: str
    kind: str  # spring | dashpot | maxwell
    lower: _Body
    upper: _Body
    point: FloatArray
    axis: int  # 0, 1, 2
    k: float = 0.0
    c: float = 0.0


@dataclass
class Vehicle3DOwn:
    """The 3D car with a rigid carbody, from the vehicle file's values (module docstring).

    Parameters
    ----------
    damper_wear : (damper name, remaining fraction of its c) or None
        A Maxwell damper (``yaw_damper_1L``, ``lateral_damper_2`` ...).
    device_channels : tuple of str
        Maxwell dampers whose stroke ``d`` and force ``f`` are channels after the floor.
    vehicle_file : Path
    hold : {"linear", "zero"}
        The input between samples: linear, or held (a zero-order hold).
    """

    damper_wear: tuple[str, float] | None = None
    device_channels: tuple[str, ...] = ()
    vehicle_file: Path = VEHICLE3D_YAML
    hold: str = "linear"
    values: dict = field(init=False, repr=False)
    _suspension_ab: tuple[FloatArray, FloatArray] | None = field(default=None, init=False,
                                                                 repr=False)

    def __post_init__(self) -> None:
        if self.hold not in ("linear", "zero"):
            msg = f"hold: expected 'linear' or 'zero', got {self.hold!r}"
            raise ValueError(msg)
        with open(self.vehicle_file, encoding="utf-8") as fh:
            self.values = yaml.safe_load(fh)
        v = self.values
        self.speed_kmh = float(v.get("speed_kmh", 300.0))
        self.speed = self.speed_kmh / 3.6
        half_p = 0.5 * float(v["carbody"]["pivot_spacing"])
        half_w = 0.5 * float(v["bogie"]["wheelbase"])
        self.bogie_x = (half_p, -half_p)
        self.axle_x = (half_p + half_w, half_p - half_w, -half_p + half_w, -half_p - half_w)
        r0 = float(v["contact"]["r0"])
        self.wheelsets = [_Body(f"w{a + 1}", np.array([x, 0.0, r0]), 2 * a, a)
                          for a, x in enumerate(self.axle_x)]
        hb = float(v["bogie"]["cg_height"])
        self.bogies = [_Body(f"bogie{b + 1}", np.array([x, 0.0, hb]), 2 * N_WS + 6 * b)
                       for b, x in enumerate(self.bogie_x)]
        self.car = _Body("car", np.array([0.0, 0.0, float(v["carbody"]["cg_height"])]),
                         2 * N_WS + 12)
        self.elements = self._elements()
        if self.damper_wear is not None:
            name, keep = self.damper_wear
            self.element(name).c *= keep
        self.maxwell = [e for e in self.elements if e.kind == "maxwell"]
        m_car, m_bog = float(v["carbody"]["mass"]), float(v["bogie"]["mass"])
        self.axle_load = GRAVITY * ((m_car + 2.0 * m_bog) / 4.0 + float(v["wheelset"]["mass"]))
        self.mass = self._mass()

    # ------------------------------------------------------------------ the car's parts
    def element(self, name: str) -> _Element:
        """The element called ``name``."""
        for e in self.elements:
            if e.name == name:
                return e
        raise KeyError(name)

    def _mass(self) -> FloatArray:
        v = self.values
        m = np.zeros(N_Q)
        for a in range(N_WS):
            m[2 * a], m[2 * a + 1] = v["wheelset"]["mass"], v["wheelset"]["Izz"]
        for body, sec in ((self.bogies[0], "bogie"), (self.bogies[1], "bogie"),
                          (self.car, "carbody")):
            s = v[sec]
            m[body.first:body.first + 6] = [s["mass"]] * 3 + [s["Ixx"], s["Iyy"], s["Izz"]]
        return m.astype(float)

    def _elements(self) -> list[_Element]:
        v = self.values
        r0 = float(v["contact"]["r0"])
        pri, sec = v["primary"], v["secondary"]
        hs = float(sec["seat_height"])
        out: list[_Element] = []
        for a, ws in enumerate(self.wheelsets):
            bog = self.bogies[a // 2]
            for side, sgn in (("L", 1.0), ("R", -1.0)):
                p = np.array([self.axle_x[a], sgn * float(pri["half_spacing"]), r0])
                for axis, key in enumerate(("kx", "ky", "kz")):
                    out.append(_Element(f"primary_{a + 1}{side}_{key[1]}", "spring", ws, bog,
                                        p, axis, k=float(pri[key])))
                out.append(_Element(f"primary_{a + 1}{side}_cz", "dashpot", ws, bog, p, 2,
                                    c=float(pri["cz"])))
        for b, bog in enumerate(self.bogies):
            xb = self.bogie_x[b]
            for side, sgn in (("L", 1.0), ("R", -1.0)):
                p = np.array([xb, sgn * float(sec["half_spacing"]), hs])
                for axis, key in enumerate(("kx", "ky", "kz")):
                    out.append(_Element(f"air_spring_{b + 1}{side}_{key[1]}", "spring", bog,
                                        self.car, p, axis, k=float(sec[key])))
                for dev, axis in (("vertical_damper", 2), ("yaw_damper", 0)):
                    d = v[dev]
                    pd = np.array([xb, sgn * float(d["half_spacing"]), hs])
                    out.append(_Element(f"{dev}_{b + 1}{side}", "maxwell", bog, self.car, pd,
                                        axis, k=float(d["k_series"]), c=float(d["c"])))
            pc = np.array([xb, 0.0, hs])
            d = v["lateral_damper"]
            out.append(_Element(f"lateral_damper_{b + 1}", "maxwell", bog, self.car, pc, 1,
                                k=float(d["k_series"]), c=float(d["c"])))
            out.append(_Element(f"traction_rod_{b + 1}", "spring", bog, self.car, pc, 0,
                                k=float(v["traction_rod"]["kx"])))
        return out

    # ------------------------------------------------------------------ kinematics
    def _motion(self, body: _Body, q: FloatArray, u: FloatArray) -> tuple[FloatArray,
                                                                          FloatArray]:
        """Translation and rotation of ``body`` for coordinates ``q`` and track ``u``
        (also rates: the map is linear)."""
        if body.wheelset >= 0:
            a = body.wheelset
            y, psi = q[2 * a], q[2 * a + 1]
            return (np.array([0.0, y, u[a]]), np.array([u[N_WS + a], 0.0, psi]))
        i = body.first
        return q[i:i + 3], q[i + 3:i + 6]

    def _point(self, body: _Body, q: FloatArray, u: FloatArray, p: FloatArray) -> FloatArray:
        t, r = self._motion(body, q, u)
        return t + np.cross(r, p - body.origin)

    def _elongation(self, e: _Element, q: FloatArray, u: FloatArray) -> float:
        return float(self._point(e.upper, q, u, e.point)[e.axis]
                     - self._point(e.lower, q, u, e.point)[e.axis])

    @staticmethod
    def _push(Q: FloatArray, body: _Body, p: FloatArray, force: FloatArray) -> None:
        """Add the force ``force`` at point ``p`` of ``body`` to the generalised forces."""
        moment = np.cross(p - body.origin, force)
        if body.wheelset >= 0:  # the track takes x, z, roll and pitch
            Q[body.first] += force[1]
            Q[body.first + 1] += moment[2]
            return
        Q[body.first:body.first + 3] += force
        Q[body.first + 3:body.first + 6] += moment

    def _pair(self, Q: FloatArray, e: _Element, f: float, p: FloatArray | None = None,
              axis: int | None = None) -> None:
        """Tension ``f`` of an element: pulls the upper body back, the lower one along."""
        vec = np.zeros(3)
        vec[e.axis if axis is None else axis] = f
        pt = e.point if p is None else p
        self._push(Q, e.upper, pt, -vec)
        self._push(Q, e.lower, pt, vec)

    # ------------------------------------------------------------------ equations
    def derivative(self, s: FloatArray, u: FloatArray, du: FloatArray,
                   speed: float | None = None, *, contact: bool = True) -> FloatArray:
        """``s'`` of the state ``[q, q', x_s]`` for the track ``u`` and its rate ``du``
        (``contact=False``: without the wheel-rail forces)."""
        V = self.speed if speed is None else speed
        q, qd, xs = s[:N_Q], s[N_Q:2 * N_Q], s[2 * N_Q:]
        Q = np.zeros(N_Q)
        xs_dot = np.zeros(len(self.maxwell))
        j = 0
        for e in self.elements:
            if e.kind == "spring":
                self._pair(Q, e, e.k * self._elongation(e, q, u))
            elif e.kind == "dashpot":
                self._pair(Q, e, e.c * self._elongation(e, qd, du))
            else:
                f = e.k * xs[j]
                self._pair(Q, e, f)
                xs_dot[j] = self._elongation(e, qd, du) - f / e.c
                j += 1
        self._anti_roll_bars(Q, q, u)
        if contact:
            self._contact(Q, q, qd, u, V)
        qdd = Q / self.mass
        return np.concatenate([qd, qdd, xs_dot])

    def _anti_roll_bars(self, Q: FloatArray, q: FloatArray, u: FloatArray) -> None:
        sec = self.values["secondary"]
        s = float(sec["half_spacing"])
        k = float(self.values["anti_roll_bar"]["k_roll"])
        for b, bog in enumerate(self.bogies):
            pts = [np.array([self.bogie_x[b], sg * s, float(sec["seat_height"])])
                   for sg in (1.0, -1.0)]
            dz = [self._point(self.car, q, u, p)[2] - self._point(bog, q, u, p)[2]
                  for p in pts]
            torque = k * (dz[0] - dz[1]) / (2.0 * s)
            bar = _Element("bar", "spring", bog, self.car, pts[0], 2)
            self._pair(Q, bar, torque / (2.0 * s), pts[0])
            self._pair(Q, bar, -torque / (2.0 * s), pts[1])

    def _contact(self, Q: FloatArray, q: FloatArray, qd: FloatArray, u: FloatArray,
                 V: float) -> None:
        c = self.values["contact"]
        lam, r0, b = float(c["conicity"]), float(c["r0"]), float(c["b"])
        f11, f22 = float(c["f11"]), float(c["f22"])
        W = self.axle_load
        for a in range(N_WS):
            y, psi = q[2 * a], q[2 * a + 1]
            yd, psid = qd[2 * a], qd[2 * a + 1]
            y_r = y - u[2 * N_WS + a]
            fy, mz = 0.0, 0.0
            for sgn in (1.0, -1.0):  # left wheel at +b, right at -b
                rolling = r0 + sgn * lam * y_r
                xi_x = (V - sgn * b * psid - V / r0 * rolling) / V
                xi_y = yd / V - psi
                Fx, Fy = -f11 * xi_x, -f22 * xi_y
                fy += Fy
                mz += -(sgn * b) * Fx  # (r x F)_z with r = (0, sgn b, 0)
            fy += -W * lam / b * y_r
            mz += W * lam * b * psi
            Q[2 * a] += fy
            Q[2 * a + 1] += mz

    # ------------------------------------------------------------------ linear form
    def matrices(self, speed: float | None = None) -> tuple[FloatArray, FloatArray]:
        """``A`` (ns, ns) and ``B`` (ns, 24) of ``s' = A s + B w``: the responses of
        :meth:`derivative` to unit states and inputs (exact: it is linear); the
        suspension's part once, the contact's at each speed."""
        if self._suspension_ab is None:
            self._suspension_ab = self._probe(lambda s, u, du: self.derivative(
                s, u, du, contact=False))
        V = self.speed if speed is None else speed

        def contact_only(s: FloatArray, u: FloatArray, du: FloatArray) -> FloatArray:
            Q = np.zeros(N_Q)
            self._contact(Q, s[:N_Q], s[N_Q:2 * N_Q], u, V)
            out = np.zeros_like(s)
            out[N_Q:2 * N_Q] = Q / self.mass
            return out

        Ac, Bc = self._probe(contact_only)
        return self._suspension_ab[0] + Ac, self._suspension_ab[1] + Bc

    def _probe(self, fun: Callable[[FloatArray, FloatArray, FloatArray], FloatArray]
               ) -> tuple[FloatArray, FloatArray]:
        ns = 2 * N_Q + len(self.maxwell)
        zero_u = np.zeros(3 * N_WS)
        A = np.empty((ns, ns))
        for i in range(ns):
            s = np.zeros(ns)
            s[i] = 1.0
            A[:, i] = fun(s, zero_u, zero_u)
        B = np.empty((ns, 6 * N_WS))
        for i in range(6 * N_WS):
            w = np.zeros(6 * N_WS)
            w[i] = 1.0
            B[:, i] = fun(np.zeros(ns), w[:3 * N_WS], w[3 * N_WS:])
        return A, B

    def floor_rows(self) -> FloatArray:
        """Rows (2 n_points, N_Q) taking ``q''`` to the floor accelerations, z then y."""
        h = float(self.values["carbody"]["floor_height"])
        rows = []
        for p in self.values["floor_points"]:
            P = np.array([float(p["x"]), float(p.get("y", 0.0)), h])
            for axis in (2, 1):
                row = np.zeros(N_Q)
                for i in range(6):
                    unit = np.zeros(N_Q)
                    unit[self.car.first + i] = 1.0
                    row[self.car.first + i] = self._point(self.car, unit, np.zeros(12), P)[axis]
                rows.append(row)
        return np.array(rows)

    def channel_names(self) -> tuple[str, ...]:
        """Floor accelerations (z then y per point), then strokes, then forces."""
        floor = tuple(f"floor_{p['label']}_{a}" for p in self.values["floor_points"]
                      for a in "zy")
        return floor + tuple(f"{d}_{k}{'xyz'[self.element(d).axis]}" for k in "df"
                             for d in self.device_channels)

    def critical_speed(self, lo: float = 20.0, hi: float = 300.0, f_min_hz: float = 0.1,
                       tol: float = 1e-3) -> tuple[float, float]:
        """Hunting speed (m/s) and frequency (Hz): the lowest speed on a 5 m/s grid of
        ``[lo, hi]`` with an oscillatory eigenvalue in the right half-plane, bisected."""
        def growth(V: float) -> tuple[float, float]:
            lam = np.linalg.eigvals(self.matrices(V)[0])
            lam = lam[lam.imag > 2.0 * np.pi * f_min_hz]
            i = int(np.argmax(lam.real))
            return float(lam[i].real), float(lam[i].imag / (2.0 * np.pi))

        grid = np.arange(lo, hi + 1e-9, 5.0)
        prev = grid[0]
        for V in grid:
            if growth(float(V))[0] > 0.0:
                a, b = float(prev), float(V)
                while b - a > tol:
                    m = 0.5 * (a + b)
                    a, b = (a, m) if growth(m)[0] > 0.0 else (m, b)
                vc = 0.5 * (a + b)
                return vc, growth(vc)[1]
            prev = V
        return float("inf"), float("nan")

    # ------------------------------------------------------------------ simulation
    def simulate(self, w: FloatArray, fs_hz: float, n_sub: int | None = None) -> FloatArray:
        """Clean channels (n_ch, nt) for the track inputs ``w`` (24, nt): RK4, ``n_sub``
        steps per sample (default ``|lambda|_max h <= 0.6``), the input linear between
        samples or held (``hold``), the car at rest at the start."""
        A, B = self.matrices()
        if n_sub is None:
            lam_max = float(np.abs(np.linalg.eigvals(A)).max())
            n_sub = max(2, int(np.ceil(lam_max / (0.6 * fs_hz))))
        h = 1.0 / (fs_hz * n_sub)
        F = B @ w
        ns, nt = A.shape[0], w.shape[1]
        S = np.zeros((ns, nt))
        s = np.zeros(ns)
        for k in range(nt - 1):
            f0 = F[:, k]
            df = (F[:, k + 1] - f0) if self.hold == "linear" else np.zeros(ns)
            for j in range(n_sub):
                fa = f0 + (j / n_sub) * df
                fm = f0 + ((j + 0.5) / n_sub) * df
                fb = f0 + ((j + 1) / n_sub) * df
                k1 = A @ s + fa
                k2 = A @ (s + 0.5 * h * k1) + fm
                k3 = A @ (s + 0.5 * h * k2) + fm
                k4 = A @ (s + h * k3) + fb
                s = s + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            S[:, k + 1] = s
        qdd = (A @ S + F)[N_Q:2 * N_Q]
        out = [self.floor_rows() @ qdd]
        if self.device_channels:
            d, f = self._damper_channels(S, w)
            out += [d, f]
        return np.vstack(out)

    def _damper_channels(self, S: FloatArray, w: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Stroke ``d`` and force ``k x_s`` of the ``device_channels`` dampers."""
        d, f = [], []
        for name in self.device_channels:
            e = self.element(name)
            j = self.maxwell.index(e)
            row = np.zeros(N_Q)
            for i in range(N_Q):
                unit = np.zeros(N_Q)
                unit[i] = 1.0
                row[i] = self._elongation(e, unit, np.zeros(3 * N_WS))
            d.append(row @ S[:N_Q])  # bogie-carbody dampers hold no track input
            f.append(e.k * S[2 * N_Q + j])
        return np.array(d), np.array(f)


def track_inputs_3d(axle_x: tuple[float, ...], speed_kmh: float, seconds: float,
                    fs_hz: float, rms_m: float, seed: int) -> FloatArray:
    """Inputs (24, nt): vertical profile, cross level (rad) and alignment under the four
    wheelsets, then their rates; three independent band-limited profiles (the generator
    of :func:`.records.track_inputs`, each wheelset delayed by its distance behind the
    leading one / V), cross level ``rms_m / 0.75 m`` rad, alignment 0.7 ``rms_m``."""
    from .records import track_inputs

    parts = [track_inputs(axle_x, speed_kmh, seconds, fs_hz, rms_m * g, seed + 7919 * i)
             for i, g in enumerate((1.0, 1.0 / 0.75 * 0.5, 0.7))]
    return np.vstack([p[:4] for p in parts] + [p[4:] for p in parts])
