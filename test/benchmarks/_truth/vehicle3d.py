"""Truth of the 3D trailer car: the library's LINEAR 3D car (``build_vehicle3d`` of
``config/vehicles/trailer_car_3d.yaml``, rigid carbody: its first-order state space
``s' = A s + B w`` with the Maxwell dampers' own states, at the file's speed), with one
damper's coefficient changed in the truth's own copy and the truth's own RK4 integration
(sub-stepped, the input linear between samples), not the library's second-order plant nor
its integrator.

Channels: the floor accelerations ``floor_<label>_z`` / ``_y`` (absolute, the car's output
rows), in the library plant's order; with ``device_channels`` also the stroke ``d = g' q``
and force ``k (d - e)`` of the Maxwell dampers named there (``<damper>_d<axis>``,
``<damper>_f<axis>``: x of a yaw damper, y of a lateral one, z of a vertical one), or of
equipment hangers (``<box>_hanger<j>_<axis>``: ``k d + c d'``, or the law's force).

Only the hanger case uses this module now; it is NOT independent of the library's linear
3D car (the worn yaw damper cases moved to :mod:`.vehicle3d_own`, written from the physics).

Equipment (added in session 8): ``hung`` boxes of the file are put on their elastic
hangers (the library's linear car with them, as above); ``hanger_law`` replaces one
hanger's spring by a law of :mod:`.laws` (written here, not the library's), its force
``f(d, d')`` on the stroke ``d = g' q`` of that hanger (``g`` the library's linear
geometry of the element), added to the truth's RK4 as ``q'' += -M^-1 g f`` while the
hanger's dashpot stays in the linear part.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from modal_twin.models.vehicle3d import build_vehicle3d, suspension_elements
from modal_twin.models.vehicle3d_spec import load_vehicle3d

from .laws import Law

FloatArray = np.ndarray
ROOT = Path(__file__).resolve().parents[3]
VEHICLE3D_YAML = ROOT / "config" / "vehicles" / "trailer_car_3d.yaml"
INPUTS = tuple([f"{c}{a}" for c in ("zt", "phit", "yat") for a in range(1, 5)]
               + [f"d{c}{a}" for c in ("zt", "phit", "yat") for a in range(1, 5)])


@dataclass
class Vehicle3DTruth:
    """The 3D car, optionally with a worn Maxwell damper.

    Parameters
    ----------
    damper_wear : (damper name, remaining fraction of its c) or None
        A Maxwell damper of the car (``yaw_damper_1L``, ``lateral_damper_2`` ...).
    """

    damper_wear: tuple[str, float] | None = None
    device_channels: tuple[str, ...] = ()
    vehicle_file: Path = VEHICLE3D_YAML
    hung: tuple[str, ...] = ()
    hanger_law: tuple[str, Law] | None = None

    def __post_init__(self) -> None:
        spec = load_vehicle3d(self.vehicle_file)
        for box in self.hung:
            spec = spec.with_equipment(box, hanger="elastic")
        self.spec = spec
        vm = build_vehicle3d(self.spec)
        if self.damper_wear is not None:
            name, keep = self.damper_wear
            cm = vm.cm.copy()
            cm[vm.maxwell_names.index(name)] *= keep
            vm = replace(vm, cm=cm)
        self.vm = vm
        self.elements = {e.name: e for e in suspension_elements(self.spec, vm.carbody)}
        if self.hanger_law is not None:
            assert self.hanger_law[1].n_ode == 0, "laws with ODE states are not handled"

    @property
    def axle_x(self) -> tuple[float, ...]:
        """Axle positions from the carbody centre, m (front first)."""
        return tuple(self.spec.axle_x)

    @property
    def speed_kmh(self) -> float:
        """The file's speed, km/h (the contact is built at it)."""
        return float(self.spec.speed_kmh)

    def element_k(self, name: str) -> float:
        """Linear stiffness of a suspension element of the truth's car, N/m."""
        return float(self.elements[name].k)

    def channel_names(self) -> tuple[str, ...]:
        """Floor accelerations, vertical then lateral per point (the library's order)."""
        floor = tuple(f"floor_{p.label}_{a}" for p in self.spec.floor_points for a in "zy")
        return floor + tuple(f"{d}_{q}{_axis(d)}" for q in "df" for d in self.device_channels)

    def simulate(self, w: FloatArray, fs_hz: float) -> FloatArray:
        """Clean channels (n_ch, nt) for the track inputs ``w`` (24, nt), RK4."""
        A, B = self.vm.state_space(self.spec.speed)
        Cy, Dy, names = self.vm.floor_outputs(A, B)
        assert tuple(names) == self.channel_names()[: len(names)]
        lam_max = float(np.abs(np.linalg.eigvals(A)).max())
        n_sub = max(2, int(np.ceil(lam_max / (0.6 * fs_hz))))  # |lambda| h <= 0.6
        h = 1.0 / (fs_hz * n_sub)
        n, vm = self.vm.n_dof, self.vm
        law_force, A = self._law(A)
        Bw = B @ w  # the forcing is linear in w: interpolate it
        s = np.zeros(A.shape[0])
        S = np.empty((A.shape[0], w.shape[1]))
        S[:, 0] = s

        def rate(s: FloatArray, f: FloatArray) -> FloatArray:
            return A @ s + f + law_force(s)

        for k in range(w.shape[1] - 1):
            f0, f1 = Bw[:, k], Bw[:, k + 1]
            for j in range(n_sub):
                a0, a1 = j / n_sub, (j + 0.5) / n_sub
                fa = f0 + a0 * (f1 - f0)
                fm = f0 + a1 * (f1 - f0)
                fb = f0 + (j + 1) / n_sub * (f1 - f0)
                k1 = rate(s, fa)
                k2 = rate(s + 0.5 * h * k1, fm)
                k3 = rate(s + 0.5 * h * k2, fm)
                k4 = rate(s + h * k3, fb)
                s = s + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
            S[:, k + 1] = s
        out = [Cy @ S + Dy @ w]
        strokes, forces = [], []
        for d in self.device_channels:
            if d in vm.maxwell_names:
                j = vm.maxwell_names.index(d)
                stroke = vm.Gm[:, j] @ S[:n]
                strokes.append(stroke)
                forces.append(vm.km[j] * (stroke - S[2 * n + j]))
                continue
            el = self.elements[d]
            stroke, rate_d = el.g @ S[:n], el.g @ S[n:2 * n]
            strokes.append(stroke)
            if self.hanger_law is not None and d == self.hanger_law[0]:
                forces.append(self._law_force(stroke, rate_d) + el.c * rate_d)
            else:
                forces.append(el.k * stroke + el.c * rate_d)
        if self.device_channels:
            out += [np.array(strokes), np.array(forces)]
        return np.vstack(out)

    def _law_force(self, d: FloatArray, v: FloatArray) -> FloatArray:
        """The hanger law's force on stroke ``d`` and rate ``v`` (arrays of equal shape)."""
        assert self.hanger_law is not None
        law = self.hanger_law[1]
        u = np.stack([np.atleast_1d(d), np.zeros_like(np.atleast_1d(d))])
        r = np.stack([np.atleast_1d(v), np.zeros_like(np.atleast_1d(v))])
        return law.force(u, r, np.zeros(0))[0][0]

    def _law(self, A: FloatArray):
        """The hanger law's generalised force on the state rate and ``A`` without its spring."""
        n = self.vm.n_dof
        if self.hanger_law is None:
            return (lambda s: 0.0), A
        el = self.elements[self.hanger_law[0]]
        Minv = np.linalg.inv(self.vm.M)
        mg = Minv @ el.g
        A = A.copy()
        A[n:2 * n, :n] += el.k * np.outer(mg, el.g)  # the law replaces the linear spring
        g = el.g

        def force(s: FloatArray) -> FloatArray:
            out = np.zeros_like(s)
            out[n:2 * n] = -mg * float(self._law_force(g @ s[:n], g @ s[n:2 * n])[0])
            return out

        return force, A


def _axis(damper: str) -> str:
    if "_hanger" in damper:
        return damper[-1]
    return {"yaw": "x", "lateral": "y", "vertical": "z"}[damper.split("_")[0]]


def track_inputs_3d(axle_x: tuple[float, ...], speed_kmh: float, seconds: float,
                    fs_hz: float, rms_m: float, seed: int) -> FloatArray:
    """Inputs (24, nt): vertical profile, cross level (rad) and alignment under the four
    wheelsets, then their rates; three independent band-limited profiles (the generator
    of :func:`.records.track_inputs`), cross level ``rms_m / 0.75 m`` rad, alignment 0.7
    ``rms_m``."""
    from .records import track_inputs

    parts = [track_inputs(axle_x, speed_kmh, seconds, fs_hz, rms_m * g, seed + 7919 * i)
             for i, g in enumerate((1.0, 1.0 / 0.75 * 0.5, 0.7))]
    return np.vstack([p[:4] for p in parts] + [p[4:] for p in parts])
