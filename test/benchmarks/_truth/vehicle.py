"""Truth of the trailer car: the library's LINEAR coupled vehicle (``assemble_vehicle`` of
``config/vehicles/trailer_car.yaml``: M, C, K in physical coordinates, not its modal
reduction), with the truth's own mount law / damper change and its own RK4 integration.

    M x'' + C x' + K x = -Gamma u - L' f(L x, L x'),   u = [z_1..z_4, z_1'..z_4']

Channels: floor vertical absolute accelerations ``floor_<label>_z = S x''``; with
``device_channels`` also the secondary suspensions' stroke and force
(``secondary_<front|rear>_dz`` = pivot minus bogie, m; ``_fz`` = spring + dashpot + any
friction, N), channels the library's car does not have; with ``primary_channels`` the
primary suspensions' too (``primary_<wheelset 1..4>_dz`` = the bogie's point over the
axle minus the track under it, m; ``_fz`` = spring + dashpot + any law there, N).

Other effects of the truth: friction in a secondary damper (a law on the stroke, in
parallel with the linear spring-dashpot), a law in parallel with one wheelset's primary
spring-dashpot (its stroke holds the track input: the law's drift is ``g' x - z_i``), a
secondary damper behind an elastic bushing (the dashpot leaves the linear part and acts in
series with the bushing), and a higher modal damping of the carbody's first
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
from .laws import Law, SeriesBushingDashpot

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
    primary_law : (wheelset index 0..3, law) or None
        A law on that wheelset's primary stroke added in parallel.
    damper_bushing : (bogie index, bushing stiffness k_b in N/m) or None
        That bogie's secondary damper acts behind a bushing (module docstring).
    primary_channels : bool
        Record the four primary strokes and forces too (after the secondary ones).
    """

    mount: tuple[str, float, float, Law] | None = None
    damper_wear: tuple[int, float] | None = None
    damper_law: tuple[int, Law] | None = None
    bending_zeta_add: float = 0.0
    device_channels: bool = False
    primary_law: tuple[int, Law] | None = None
    damper_bushing: tuple[int, float] | None = None
    primary_channels: bool = False
    vehicle_file: Path = VEHICLE_YAML

    def __post_init__(self) -> None:
        spec = load_vehicle(self.vehicle_file)
        if self.mount is not None:
            spec = equipment_mounted(spec, self.mount[0], self.mount[1], self.mount[2])
        self.spec = spec
        self.vm = assemble_vehicle(spec)

    @property
    def axle_x(self) -> tuple[float, float, float, float]:
        """Wheelset positions 1 (leading) .. 4, m from the carbody centre."""
        return self.spec.axle_x

    def mount_k(self) -> float:
        """Linear stiffness of the truth mount, N/m."""
        assert self.mount is not None
        return self.spec.equipment_named(self.mount[0]).k_mount

    def channel_names(self) -> tuple[str, ...]:
        """``floor_<label>_z`` in the library plant's order (then the device channels)."""
        out = tuple(c.name for c in self.vm.channels)
        if self.device_channels:
            out += tuple(f"secondary_{b}_{q}" for q in ("dz", "fz") for b in BOGIES)
        if self.primary_channels:
            out += tuple(f"primary_{i + 1}_{q}" for q in ("dz", "fz") for i in range(4))
        return out

    def primary_rows(self) -> tuple[FloatArray, FloatArray]:
        """Rows ``g_i`` (4, n) of the bogie point over each axle, and ``e_i`` (4, 8)
        picking the track under it from the inputs: stroke ``g_i x - e_i u``."""
        vm = self.vm
        a = 0.5 * self.spec.wheelbase
        G = np.zeros((4, vm.n_dof))
        E = np.zeros((4, len(INPUTS)))
        for i in range(4):
            b = BOGIES[i // 2]
            G[i, vm.dof_names.index(f"z_bogie_{b}")] = 1.0
            G[i, vm.dof_names.index(f"beta_bogie_{b}")] = a if i % 2 == 0 else -a
            E[i, i] = 1.0
        return G, E

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
        if self.damper_bushing is not None:
            b, k_b = self.damper_bushing
            ds = vm.D_sec[b]
            C -= self.spec.c_secondary * np.outer(ds, ds)  # the dashpot moves behind k_b
            att.append(Attached(f"secondary_{BOGIES[b]}",
                                SeriesBushingDashpot(k_b, self.spec.c_secondary),
                                np.vstack([ds, np.zeros(vm.n_dof)])))
        if self.primary_law is not None:
            i, plaw = self.primary_law
            G, E = self.primary_rows()
            z = np.zeros(len(INPUTS))
            e_u, e_v = -E[i], -np.roll(E[i], 4)  # the track under it, and its rate
            att.append(Attached(f"primary_{i + 1}", plaw, np.vstack([G[i], np.zeros(vm.n_dof)]),
                                np.vstack([e_u, z]), np.vstack([e_v, z])))
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
        out = [vm.S @ res.xdd]
        if self.device_channels:
            stroke, rate = vm.D_sec @ res.x, vm.D_sec @ res.xd
            keep = np.ones(2)  # share of the secondary dashpot in parallel with the spring
            if self.damper_wear is not None:
                keep[self.damper_wear[0]] = self.damper_wear[1]
            if self.damper_bushing is not None:
                keep[self.damper_bushing[0]] = 0.0  # its force is the series law's
            force = self.spec.c_secondary * keep[:, None] * rate  # the spec's values
            force += self.spec.k_secondary * stroke
            for i, a in enumerate(att):
                if a.name.startswith("secondary_"):
                    force[BOGIES.index(a.name.removeprefix("secondary_"))] += res.f[i, 0]
            out += [stroke, force]
        if self.primary_channels:
            G, E = self.primary_rows()
            stroke = G @ res.x - E[:, :4] @ u[:4]
            rate = G @ res.xd - E[:, :4] @ u[4:]
            force = self.spec.k_primary * stroke + self.spec.c_primary * rate
            for i, a in enumerate(att):
                if a.name.startswith("primary_"):
                    force[int(a.name.removeprefix("primary_")) - 1] += res.f[i, 0]
            out += [stroke, force]
        return np.vstack(out)
