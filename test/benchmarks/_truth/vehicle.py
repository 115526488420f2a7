"""Truth of the trailer car: the library's LINEAR coupled vehicle (``assemble_vehicle`` of
``config/vehicles/trailer_car.yaml``: M, C, K in physical coordinates, not its modal
reduction), with the truth's own mount law / damper change and its own RK4 integration.

    M x'' + C x' + K x = -Gamma u - L' f(L x, L x'),   u = [z_1..z_4, z_1'..z_4']

Channels: floor vertical absolute accelerations ``floor_<label>_z = S x''``; with
``device_channels`` also the secondary suspensions' stroke and force
(``secondary_<front|rear>_dz`` = pivot minus bogie, m; ``_fz`` = spring + dashpot + any
friction, N), channels the library's car does not have.

Other effects of the truth: friction in a secondary damper (a law on the stroke, in
parallel with the linear spring-dashpot), and a higher modal damping of the carbody's first
bending mode: ``C += M phi (2 dzeta omega) phi' M`` for the coupled undamped mode ``phi``
(mass-normalised) nearest the free-free first bending frequency of the carbody beam.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from modal_twin.models.vehicle import assemble_vehicle
from modal_twin.models.vehicle_spec import equipment_mounted, load_vehicle

from .integrate import Attached, run_rk4
from .laws import Law

FloatArray = np.ndarray
ROOT = Path(__file__).resolve().parents[3]
VEHICLE_YAML = ROOT / "config" / "vehicles" / "trailer_car.yaml"
BOGIES = ("front", "rear")
INPUTS = ("zt1", "zt2", "zt3", "zt4", "vt1", "vt2", "vt3", "vt4")


@dataclass
class VehicleTruth:
    """The car, optionally with an equipment item on a nonlinear mount and a worn
    secondary damper.

    Parameters
    ----------
    mount : (item, f_hz, zeta, law) or None
        The item hangs on a mount of linear frequency ``f_hz`` whose spring the law
        replaces (the law gets the mount stretch ``z_item - z_floor`` as its x drift; its
        stiffness parameter should be the mount's ``k``).
    damper_wear : (bogie index 0 front / 1 rear, remaining fraction of c) or None
    damper_law : (bogie index, law) or None
        A law on the secondary stroke added in parallel (e.g. friction in the damper).
    bending_zeta_add : float
        Modal damping added to the carbody's first bending mode (module docstring).
    device_channels : bool
        Record the secondary strokes and forces too.
    """

    mount: tuple[str, float, float, Law] | None = None
    damper_wear: tuple[int, float] | None = None
    damper_law: tuple[int, Law] | None = None
    bending_zeta_add: float = 0.0
    device_channels: bool = False
    vehicle_file: Path = VEHICLE_YAML

    def __post_init__(self) -> None:
        spec = load_vehicle(self.vehicle_file)
        if self.mount is not None:
            spec = equipment_mounted(spec, self.mount[0], self.mount[1], self.mount[2])
        self.spec = spec
        self.vm = assemble_vehicle(spec)

    def mount_k(self) -> float:
        """Linear stiffness of the truth mount, N/m."""
        assert self.mount is not None
        return self.spec.equipment_named(self.mount[0]).k_mount

    def channel_names(self) -> tuple[str, ...]:
        """``floor_<label>_z`` in the library plant's order (then the device channels)."""
        out = tuple(c.name for c in self.vm.channels)
        if self.device_channels:
            out += tuple(f"secondary_{b}_{q}" for q in ("dz", "fz") for b in BOGIES)
        return out

    def bending_mode(self) -> tuple[FloatArray, float]:
        """Mass-normalised coupled mode nearest the carbody's first free-free bending
        frequency, and its circular frequency."""
        vm = self.vm
        Li = np.linalg.inv(np.linalg.cholesky(vm.M))  # M = L L'
        lam, v = np.linalg.eigh(Li @ vm.K @ Li.T)
        modes = Li.T @ v  # M-orthonormal
        f_bend = float(vm.carbody.f_free_hz[2])  # after the two rigid-body zeros
        w = np.sqrt(np.clip(lam, 0.0, None))
        j = int(np.argmin(np.abs(w / (2 * np.pi) - f_bend)))
        return modes[:, j], float(w[j])

    def matrices(self) -> tuple[FloatArray, FloatArray, list[Attached]]:
        """Stiffness and damping of the truth's linear part (the model's, less the springs
        the laws replace, with any damper wear and added bending damping) and its laws."""
        vm = self.vm
        K, C = vm.K.copy(), vm.C.copy()
        att = []
        if self.mount is not None:
            name, law = self.mount[0], self.mount[3]
            e = self.spec.equipment_named(name)
            d = np.zeros(vm.n_dof)
            d[vm.dof_names.index(f"z_{name}")] = 1.0
            d[vm.carbody.cb_index(e.x)] = -1.0
            K -= e.k_mount * np.outer(d, d)  # the law replaces the linear mount spring
            att.append(Attached(name, law, np.vstack([d, np.zeros_like(d)])))
        if self.damper_wear is not None:
            b, keep = self.damper_wear
            ds = vm.D_sec[b]
            C -= (1.0 - keep) * self.spec.c_secondary * np.outer(ds, ds)
        if self.damper_law is not None:
            b, dlaw = self.damper_law
            att.append(Attached(f"secondary_{BOGIES[b]}", dlaw,
                                np.vstack([vm.D_sec[b], np.zeros(vm.n_dof)])))
        if self.bending_zeta_add:
            phi, w = self.bending_mode()
            Mp = vm.M @ phi
            C += 2.0 * self.bending_zeta_add * w * np.outer(Mp, Mp)
        return K, C, att

    def simulate(self, u: FloatArray, fs_hz: float) -> FloatArray:
        """Clean channels (n_ch, nt) for the track inputs ``u`` (8, nt)."""
        vm = self.vm
        K, C, att = self.matrices()
        lam = np.linalg.eigvals(np.linalg.solve(vm.M, K))
        w_max = float(np.sqrt(np.max(np.abs(lam))))
        n_sub = max(2, int(np.ceil(w_max / (0.6 * fs_hz))))  # omega_max h <= 0.6
        res = run_rk4(vm.M, C, K, vm.Gamma, att, u, fs_hz, n_sub)
        acc = vm.S @ res.xdd
        if not self.device_channels:
            return acc
        stroke, rate = vm.D_sec @ res.x, vm.D_sec @ res.xd
        force = self.spec.c_secondary * rate  # per-bogie values: the spec's (no theta)
        force *= 1.0 if self.damper_wear is None else np.where(
            np.arange(2) == self.damper_wear[0], self.damper_wear[1], 1.0)[:, None]
        force += self.spec.k_secondary * stroke
        for i, a in enumerate(att):
            if a.name.startswith("secondary_"):
                force[BOGIES.index(a.name.removeprefix("secondary_"))] += res.f[i, 0]
        return np.vstack([acc, stroke, force])
