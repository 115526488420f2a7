"""Truth of the 3D trailer car: the library's LINEAR 3D car (``build_vehicle3d`` of
``config/vehicles/trailer_car_3d.yaml``, rigid carbody: its first-order state space
``s' = A s + B w`` with the Maxwell dampers' own states, at the file's speed), with one
damper's coefficient changed in the truth's own copy and the truth's own RK4 integration
(sub-stepped, the input linear between samples), not the library's second-order plant nor
its integrator.

Channels: the floor accelerations ``floor_<label>_z`` / ``_y`` (absolute, the car's output
rows), in the library plant's order; with ``device_channels`` also the stroke ``d = g' q``
and force ``k (d - e)`` of the Maxwell dampers named there (``<damper>_d<axis>``,
``<damper>_f<axis>``: x of a yaw damper, y of a lateral one, z of a vertical one).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from modal_twin.models.vehicle3d import build_vehicle3d
from modal_twin.models.vehicle3d_spec import load_vehicle3d

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

    def __post_init__(self) -> None:
        self.spec = load_vehicle3d(self.vehicle_file)
        vm = build_vehicle3d(self.spec)
        if self.damper_wear is not None:
            name, keep = self.damper_wear
            cm = vm.cm.copy()
            cm[vm.maxwell_names.index(name)] *= keep
            vm = replace(vm, cm=cm)
        self.vm = vm

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
        Bw = B @ w  # the forcing is linear in w: interpolate it
        s = np.zeros(A.shape[0])
        S = np.empty((A.shape[0], w.shape[1]))
        S[:, 0] = s
        for k in range(w.shape[1] - 1):
            f0, f1 = Bw[:, k], Bw[:, k + 1]
            for j in range(n_sub):
                a0, a1 = j / n_sub, (j + 0.5) / n_sub
                fa = f0 + a0 * (f1 - f0)
                fm = f0 + a1 * (f1 - f0)
                fb = f0 + (j + 1) / n_sub * (f1 - f0)
                k1 = A @ s + fa
                k2 = A @ (s + 0.5 * h * k1) + fm
                k3 = A @ (s + 0.5 * h * k2) + fm
                k4 = A @ (s + h * k3) + fb
                s = s + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
            S[:, k + 1] = s
        out = [Cy @ S + Dy @ w]
        n, vm = self.vm.n_dof, self.vm
        j = [vm.maxwell_names.index(d) for d in self.device_channels]
        stroke = vm.Gm[:, j].T @ S[:n]
        out += [stroke, vm.km[j, None] * (stroke - S[2 * n:][j])]
        return np.vstack(out)


def _axis(damper: str) -> str:
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
