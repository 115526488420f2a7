"""Truth of the trailer car: the library's LINEAR coupled vehicle (``assemble_vehicle`` of
``config/vehicles/trailer_car.yaml``: M, C, K in physical coordinates, not its modal
reduction), with the truth's own mount law / damper change and its own RK4 integration.

    M x'' + C x' + K x = -Gamma u - L' f(L x, L x'),   u = [z_1..z_4, z_1'..z_4']

Channels: floor vertical absolute accelerations ``floor_<label>_z = S x''``.
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
    """

    mount: tuple[str, float, float, Law] | None = None
    damper_wear: tuple[int, float] | None = None
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
        """``floor_<label>_z`` in the library plant's order."""
        return tuple(c.name for c in self.vm.channels)

    def simulate(self, u: FloatArray, fs_hz: float) -> FloatArray:
        """Clean floor accelerations (n_ch, nt) for the track inputs ``u`` (8, nt)."""
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
        lam = np.linalg.eigvals(np.linalg.solve(vm.M, K))
        w_max = float(np.sqrt(np.max(np.abs(lam))))
        n_sub = max(2, int(np.ceil(w_max / (0.6 * fs_hz))))  # omega_max h <= 0.6
        res = run_rk4(vm.M, C, K, vm.Gamma, att, u, fs_hz, n_sub)
        return vm.S @ res.xdd
