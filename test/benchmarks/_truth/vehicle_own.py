"""Independent truth of the vertical-plane trailer car, written from the physics.

Nothing here comes from the library: the parameters are read from
``config/vehicles/trailer_car.yaml`` with ``yaml.safe_load``; the carbody is a free-free
uniform Euler-Bernoulli beam described by its CLOSED-FORM modes (not a finite-element
mesh reduced by Craig-Bampton, as the library's car); the suspensions are point springs
and dashpots between attachment points; the integrator is the truths' sub-stepped RK4
(:mod:`.integrate`). What is modelled is the library's car (``modal_twin.models.vehicle``),
so that a hidden effect is the main difference between the two; the form is not, and the
difference of the nominal forms (measured in ``test/models/test_vehicle_own_truth.py``) is
a model-form gap the diagnosis must live with.

Carbody (length ``L``, line mass ``m = shell + fittings``, bending stiffness ``EI``; ``x``
from the centre, ``s = x + L / 2``): the vertical displacement is
``w(x, t) = a_0 + x a_1 + sum_n phi_n(s) eta_n`` with the free-free modes (Blevins,
*Formulas for Natural Frequency and Mode Shape*, Table 8-1, free-free beam)::

    phi_n(s) = cosh(b s) + cos(b s) - sigma_n (sinh(b s) + sin(b s)),
    sigma_n = (cosh(b L) - cos(b L)) / (sinh(b L) - sin(b L)),   b = beta_n,
    cos(beta_n L) cosh(beta_n L) = 1   (beta_n L = 4.7300, 7.8532, 10.9956, ...),
    omega_n = beta_n^2 sqrt(EI / m),   int_0^L phi_n^2 ds = L,

so the bare beam's generalised mass is ``diag(m L, m L^3 / 12, m L, m L, ...)`` and its
stiffness ``diag(0, 0, m L omega_n^2, ...)``. The first ``n_flex`` modes are kept (default
8, to 290 Hz; the response is below 30 Hz). ``phi_n`` is evaluated in an overflow-free form
(:func:`free_free_mode`).

Rigid (bolted) equipment: a point mass ``m_e`` at ``x_e`` on the beam, adding
``m_e psi(x_e) psi(x_e)'`` to the carbody's generalised mass (``psi`` the row of the
shapes ``[1, x, phi_1 .. phi_N]``; a Rayleigh-Ritz coupling). Elastic equipment: a body
``z_e`` on a spring ``k_e = m_e (2 pi f)^2`` and dashpot ``c_e = 2 zeta m_e 2 pi f`` to
the floor point below it (stroke ``z_e - w(x_e)``).

Carbody damping, the file's ``zeta`` on each flexible mode of "the carbody in service"
(``damping_modes="carbody"``, default: the free-free modes of the beam with its rigid
items, solved here in the beam's modal basis, ``v_k' M_c v_k = 1``;
``C_c = M_c V diag(2 zeta omega_k) V' M_c``), or on the bare beam's modes
(``"beam"``: ``diag(0, 0, 2 zeta m L omega_n, ...)``, another reading of the file; it
moves the nominal floor accelerations by about 2 % NRMSE, the test's figures).

Bogies front / rear at ``x_b = +- pivot_spacing / 2``: bounce ``z_b``, pitch ``beta_b``
(front up positive; a point ``x`` of the frame moves ``z_b + (x - x_b) beta_b``).
Secondary suspension per bogie: a spring and a dashpot on the stroke ``w(x_b) - z_b``.
Primary suspension per wheelset ``i`` (1 leads; ``x_i = x_b +- wheelbase / 2``): a spring
and a dashpot on the stroke ``z_b + (x_i - x_b) beta_b - z_t,i`` with ``z_t,i`` the track
under it (the wheelsets follow the track). The inputs ``u = [z_t,1..4, z_t,1..4']`` carry
the delays between wheelsets (:func:`.records.track_inputs`).

Coordinates in this order (not the library's): ``a_0, a_1, eta_1 .. eta_N``, ``z_front,
beta_front, z_rear, beta_rear``, then each elastic item's ``z_e``. Every element with
stroke row ``r`` (and track share ``e``) adds ``k r r'`` to K and ``c r r'`` to C; the
track forcing ``-G u`` of the integrator is ``G[:, i] = -k_p r_i``, ``G[:, 4 + i] = -c_p
r_i``.

Channels (those of :mod:`.vehicle`): ``floor_<label>_z`` = ``w''(x_sensor)`` (absolute
vertical acceleration, in the file's sensor order); with ``device_channels`` the secondary
strokes then forces ``secondary_<front|rear>_dz`` / ``_fz`` (spring + dashpot + any law
there, N); with ``primary_channels`` the primary ones ``primary_<1..4>_dz`` / ``_fz``.

Hidden effects (the laws of :mod:`.laws`): a law in parallel with a secondary suspension
(friction in the damper), an elastic item whose mount spring a law replaces, a law in
parallel with one wheelset's primary spring-dashpot, a secondary damper behind a bushing
(its dashpot leaves the linear part and acts in series with the bushing), a worn secondary
damper, and extra modal damping ``dzeta`` of the carbody's first bending mode (of the
modes ``damping_modes`` names: ``C_c += M_c v_1 (2 dzeta omega_1) v_1' M_c``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import yaml
from scipy.linalg import eigh
from scipy.optimize import brentq

from .integrate import Attached, run_rk4
from .laws import Law, SeriesBushingDashpot

FloatArray = np.ndarray
ROOT = Path(__file__).resolve().parents[3]
VEHICLE_YAML = ROOT / "config" / "vehicles" / "trailer_car.yaml"
BOGIES = ("front", "rear")
INPUTS = ("zt1", "zt2", "zt3", "zt4", "vt1", "vt2", "vt3", "vt4")


def free_free_root(n: int) -> float:
    """``beta_n L`` of the n-th (1-based) flexible free-free mode: the root of ``cos t -
    1 / cosh t`` next to ``(2 n + 1) pi / 2``."""
    t0 = (2 * n + 1) * math.pi / 2.0
    return float(brentq(lambda t: math.cos(t) - 1.0 / math.cosh(t), t0 - 0.4, t0 + 0.4,
                        xtol=1e-14))


def free_free_mode(bl: float, s_over_l: FloatArray) -> FloatArray:
    """``phi_n`` (module docstring) at ``s / L`` for ``beta_n L = bl``, without overflow.

    ``cosh(b s) - sigma sinh(b s) = e^{b s} (1 - sigma) / 2 + e^{-b s} (1 + sigma) / 2`` with
    ``(1 - sigma) e^{b L} / 2 = (cos bL - sin bL - e^{-bL}) / (1 - e^{-2 bL} - 2 sin bL
    e^{-bL})``.
    """
    t = bl * np.asarray(s_over_l, dtype=float)
    e = math.exp(-bl)
    c_up = (math.cos(bl) - math.sin(bl) - e) / (1.0 - e * e - 2.0 * math.sin(bl) * e)
    one_minus_sigma = 2.0 * c_up * e
    sigma = 1.0 - one_minus_sigma
    return (c_up * np.exp(t - bl) + 0.5 * (1.0 + sigma) * np.exp(-t)
            + np.cos(t) - sigma * np.sin(t))


@dataclass
class VehicleOwn:
    """The trailer car in the vertical plane, from the file's values (module docstring).

    Parameters
    ----------
    mount : (item, f_hz, zeta, law) or None
        The item hangs on a mount of linear frequency ``f_hz`` and damping ratio ``zeta``
        whose spring the law replaces (the law gets the stroke ``z_e - w(x_e)``; its
        stiffness parameter should be :meth:`mount_k`).
    damper_wear : (bogie 0 front / 1 rear, remaining fraction of c) or None
    damper_law : (bogie, law) or None
        A law on the secondary stroke, in parallel.
    bending_zeta_add : float
        Modal damping added to the beam's first bending mode.
    device_channels : bool
        Record the secondary strokes and forces.
    primary_law : (wheelset 0..3, law) or None
        A law on that wheelset's primary stroke, in parallel.
    damper_bushing : (bogie, bushing stiffness k_b in N/m) or None
        That bogie's secondary dashpot acts behind a bushing.
    primary_channels : bool
        Record the four primary strokes and forces (after the secondary ones).
    n_flex : int
        Flexible free-free modes kept.
    damping_modes : {"carbody", "beam"}
        The modes the file's ``zeta`` damps (module docstring).
    vehicle_file : Path
    """

    mount: tuple[str, float, float, Law] | None = None
    damper_wear: tuple[int, float] | None = None
    damper_law: tuple[int, Law] | None = None
    bending_zeta_add: float = 0.0
    device_channels: bool = False
    primary_law: tuple[int, Law] | None = None
    damper_bushing: tuple[int, float] | None = None
    primary_channels: bool = False
    n_flex: int = 8
    damping_modes: str = "carbody"
    vehicle_file: Path = VEHICLE_YAML
    values: dict = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if self.damping_modes not in ("carbody", "beam"):
            msg = f"damping_modes: expected 'carbody' or 'beam', got {self.damping_modes!r}"
            raise ValueError(msg)
        with open(self.vehicle_file, encoding="utf-8") as fh:
            self.values = yaml.safe_load(fh)
        v = self.values
        cb = v["carbody"]
        self.length = float(cb["length"])
        self.line_mass = float(cb["shell_line_mass"]) + float(cb["fittings_line_mass"])
        self.EI = float(cb["EI"])
        self.zeta = float(cb["zeta"])
        half_p, half_w = 0.5 * float(cb["pivot_spacing"]), 0.5 * float(v["bogie"]["wheelbase"])
        self.bogie_x = (half_p, -half_p)
        self.axle_x = (half_p + half_w, half_p - half_w, -half_p + half_w, -half_p - half_w)
        self.speed_kmh = float(v.get("speed_kmh", 300.0))
        self.beta_l = np.array([free_free_root(n) for n in range(1, self.n_flex + 1)])
        self.omega_beam = (self.beta_l / self.length) ** 2 * math.sqrt(self.EI / self.line_mass)
        self.items = [dict(e) for e in v.get("equipment", [])]
        if self.mount is not None:
            item = self.item(self.mount[0])
            item.update(mount="elastic", f_mount_hz=self.mount[1], zeta_mount=self.mount[2])
        self.elastic = [e for e in self.items if e["mount"] == "elastic"]
        self.n_cb = 2 + self.n_flex
        self.n = self.n_cb + 4 + len(self.elastic)

    # ------------------------------------------------------------------ geometry
    def item(self, name: str) -> dict:
        """The equipment item called ``name`` (its file entry, as read)."""
        for e in self.items:
            if e["name"] == name:
                return e
        raise KeyError(name)

    def shapes(self, x: float) -> FloatArray:
        """Row ``psi(x)`` (n,) giving the carbody's vertical displacement at ``x``."""
        row = np.zeros(self.n)
        row[0], row[1] = 1.0, x
        s = (x + 0.5 * self.length) / self.length
        row[2:self.n_cb] = [float(free_free_mode(bl, s)) for bl in self.beta_l]
        return row

    def _bogie_point(self, b: int, x: float) -> FloatArray:
        row = np.zeros(self.n)
        row[self.n_cb + 2 * b] = 1.0
        row[self.n_cb + 2 * b + 1] = x - self.bogie_x[b]
        return row

    def secondary_rows(self) -> FloatArray:
        """Strokes ``w(x_b) - z_b`` (2, n), front then rear."""
        return np.array([self.shapes(xb) - self._bogie_point(b, xb)
                         for b, xb in enumerate(self.bogie_x)])

    def primary_rows(self) -> FloatArray:
        """Bogie points over the axles (4, n); the stroke is this row's ``x`` less the
        track under wheelset ``i``."""
        return np.array([self._bogie_point(i // 2, xa) for i, xa in enumerate(self.axle_x)])

    def mount_rows(self) -> FloatArray:
        """Strokes ``z_e - w(x_e)`` (n_elastic, n) of the elastic items."""
        rows = []
        for j, e in enumerate(self.elastic):
            r = -self.shapes(float(e["x"]))
            r[self.n_cb + 4 + j] = 1.0
            rows.append(r)
        return np.array(rows).reshape(len(self.elastic), self.n)

    def mount_k(self) -> float:
        """Linear stiffness ``m (2 pi f)^2`` of the ``mount`` item's hanger, N/m."""
        assert self.mount is not None
        e = self.item(self.mount[0])
        return float(e["mass"]) * (2.0 * math.pi * float(e["f_mount_hz"])) ** 2

    def sensor_rows(self) -> FloatArray:
        """``w`` at each floor sensor (n_sensors, n)."""
        return np.array([self.shapes(float(s["x"])) for s in self.values["sensors"]])

    # ------------------------------------------------------------------ equations
    def linear_matrices(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """``M, C, K`` (n, n) and ``G`` (n, 8) of the nominal car (module docstring)."""
        v, n, nc = self.values, self.n, self.n_cb
        mL = self.line_mass * self.length
        M, K, C = np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))
        M[0, 0], M[1, 1] = mL, mL * self.length**2 / 12.0
        for j, w in enumerate(self.omega_beam):
            M[2 + j, 2 + j] = mL
            K[2 + j, 2 + j] = mL * w * w
        for e in self.items:
            if e["mount"] == "rigid":
                psi = self.shapes(float(e["x"]))
                M += float(e["mass"]) * np.outer(psi, psi)
        omega, Mv = self.damped_carbody_modes(M)
        C[:nc, :nc] = Mv @ np.diag(2.0 * self.zeta * omega) @ Mv.T
        for b in range(2):
            M[nc + 2 * b, nc + 2 * b] = float(v["bogie"]["mass"])
            M[nc + 2 * b + 1, nc + 2 * b + 1] = float(v["bogie"]["pitch_inertia"])
        ks, cs = float(v["secondary"]["k"]), float(v["secondary"]["c"])
        for r in self.secondary_rows():
            K += ks * np.outer(r, r)
            C += cs * np.outer(r, r)
        kp, cp = float(v["primary"]["k"]), float(v["primary"]["c"])
        G = np.zeros((n, len(INPUTS)))
        for i, r in enumerate(self.primary_rows()):
            K += kp * np.outer(r, r)
            C += cp * np.outer(r, r)
            G[:, i], G[:, 4 + i] = -kp * r, -cp * r
        for j, (e, r) in enumerate(zip(self.elastic, self.mount_rows(), strict=True)):
            me, f, z = float(e["mass"]), float(e["f_mount_hz"]), float(e["zeta_mount"])
            M[nc + 4 + j, nc + 4 + j] = me
            K += me * (2.0 * math.pi * f) ** 2 * np.outer(r, r)
            C += 2.0 * z * me * 2.0 * math.pi * f * np.outer(r, r)
        return M, C, K, G

    def matrices(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray,
                                list[Attached]]:
        """``M, C, K, G`` of the truth's linear part (the nominal car less what the laws
        replace, with any wear and added bending damping) and its laws."""
        M, C, K, G = self.linear_matrices()
        cs = float(self.values["secondary"]["c"])
        D = self.secondary_rows()
        att: list[Attached] = []
        zero = np.zeros(self.n)
        if self.mount is not None:
            j = [e["name"] for e in self.elastic].index(self.mount[0])
            r = self.mount_rows()[j]
            K -= self.mount_k() * np.outer(r, r)  # the law replaces the mount's spring
            att.append(Attached(self.mount[0], self.mount[3], np.vstack([r, zero])))
        if self.damper_wear is not None:
            b, keep = self.damper_wear
            C -= (1.0 - keep) * cs * np.outer(D[b], D[b])
        if self.damper_law is not None:
            b, law = self.damper_law
            att.append(Attached(f"secondary_{BOGIES[b]}", law, np.vstack([D[b], zero])))
        if self.damper_bushing is not None:
            b, k_b = self.damper_bushing
            C -= cs * np.outer(D[b], D[b])  # the dashpot moves behind the bushing
            att.append(Attached(f"secondary_{BOGIES[b]}", SeriesBushingDashpot(k_b, cs),
                                np.vstack([D[b], zero])))
        if self.primary_law is not None:
            i, law = self.primary_law
            e_u, e_v, z8 = np.zeros(len(INPUTS)), np.zeros(len(INPUTS)), np.zeros(len(INPUTS))
            e_u[i], e_v[4 + i] = -1.0, -1.0  # the track under it, and its rate
            att.append(Attached(f"primary_{i + 1}", law,
                                np.vstack([self.primary_rows()[i], zero]),
                                np.vstack([e_u, z8]), np.vstack([e_v, z8])))
        if self.bending_zeta_add:
            omega, Mv = self.damped_carbody_modes(M)
            C[:self.n_cb, :self.n_cb] += (2.0 * self.bending_zeta_add * omega[0]
                                          * np.outer(Mv[:, 0], Mv[:, 0]))
        return M, C, K, G, att

    def damped_carbody_modes(self, M: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Circular frequencies (n_flex,) and ``M_c v_k`` (n_cb, n_flex) of the flexible
        modes the file's ``zeta`` damps (``damping_modes``), ``v_k' M_c v_k = 1``."""
        nc = self.n_cb
        mL = self.line_mass * self.length
        if self.damping_modes == "beam":
            Mv = np.zeros((nc, self.n_flex))
            Mv[2:, :] = np.eye(self.n_flex) * math.sqrt(mL)  # M_c v with v = e_k / sqrt(mL)
            return self.omega_beam.copy(), Mv
        Mc = M[:nc, :nc]
        Kc = np.zeros((nc, nc))
        Kc[2:, 2:] = np.diag(mL * self.omega_beam**2)
        lam, V = eigh(Kc, Mc)  # ascending: the two rigid-body zeros first
        return np.sqrt(np.clip(lam[2:], 0.0, None)), Mc @ V[:, 2:]

    def natural_frequencies_hz(self) -> FloatArray:
        """Undamped natural frequencies of the nominal coupled car, Hz (ascending)."""
        M, _, K, _ = self.linear_matrices()
        lam = np.linalg.eigvals(np.linalg.solve(M, K)).real
        return np.sqrt(np.sort(np.clip(lam, 0.0, None))) / (2.0 * math.pi)

    def carbody_frequencies_hz(self) -> FloatArray:
        """Free-free frequencies of the carbody alone (the beam with its rigid items, no
        suspension), Hz: two rigid zeros, then the bending modes."""
        omega, _ = self.damped_carbody_modes(self.linear_matrices()[0])
        if self.damping_modes == "beam":  # those are the bare beam's: solve with the items
            omega, _ = replace(self, damping_modes="carbody").damped_carbody_modes(
                self.linear_matrices()[0])
        return np.concatenate([[0.0, 0.0], omega]) / (2.0 * math.pi)

    # ------------------------------------------------------------------ channels
    def channel_names(self) -> tuple[str, ...]:
        """Floor accelerations in the file's sensor order, then device channels."""
        out = tuple(f"floor_{s['label']}_z" for s in self.values["sensors"])
        if self.device_channels:
            out += tuple(f"secondary_{b}_{q}" for q in ("dz", "fz") for b in BOGIES)
        if self.primary_channels:
            out += tuple(f"primary_{i + 1}_{q}" for q in ("dz", "fz") for i in range(4))
        return out

    def simulate(self, u: FloatArray, fs_hz: float, n_sub: int | None = None) -> FloatArray:
        """Clean channels (n_ch, nt) for the track inputs ``u`` (8, nt), from rest; RK4
        with ``n_sub`` steps per sample (default ``omega_max h <= 0.6``)."""
        M, C, K, G, att = self.matrices()
        if n_sub is None:
            w_max = float(np.sqrt(np.max(np.abs(np.linalg.eigvals(np.linalg.solve(M, K))))))
            n_sub = max(2, int(np.ceil(w_max / (0.6 * fs_hz))))
        res = run_rk4(M, C, K, G, att, u, fs_hz, n_sub)
        out = [self.sensor_rows() @ res.xdd]
        v = self.values
        if self.device_channels:
            D = self.secondary_rows()
            stroke, rate = D @ res.x, D @ res.xd
            keep = np.ones(2)  # share of the dashpot in parallel with the spring
            if self.damper_wear is not None:
                keep[self.damper_wear[0]] = self.damper_wear[1]
            if self.damper_bushing is not None:
                keep[self.damper_bushing[0]] = 0.0  # its force is the series law's
            force = (float(v["secondary"]["k"]) * stroke
                     + float(v["secondary"]["c"]) * keep[:, None] * rate)
            for i, a in enumerate(att):
                if a.name.startswith("secondary_"):
                    force[BOGIES.index(a.name.removeprefix("secondary_"))] += res.f[i, 0]
            out += [stroke, force]
        if self.primary_channels:
            P = self.primary_rows()
            stroke, rate = P @ res.x - u[:4], P @ res.xd - u[4:]
            force = float(v["primary"]["k"]) * stroke + float(v["primary"]["c"]) * rate
            for i, a in enumerate(att):
                if a.name.startswith("primary_"):
                    force[int(a.name.removeprefix("primary_")) - 1] += res.f[i, 0]
            out += [stroke, force]
        return np.vstack(out)
