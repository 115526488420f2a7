"""Rigid-flexible high-speed trailer car in the vertical plane (Sec. 5.1 of [002]).

[002] couples a Craig-Bampton flexible carbody with rigid bogies, suspensions, underframe
equipment and wheelsets (Fig. 13 of [002]). Here, in the vertical plane:

* carbody: free-free Euler-Bernoulli beam (FE frames of :mod:`modal_twin.models.fe`, only
  ``uz`` and ``ry`` free), uniform line mass ``shell + fittings``, bending stiffness
  ``EI``; rigidly bolted equipment is a lumped mass on its node. Craig-Bampton reduction
  (:func:`~modal_twin.models.craig_bampton.craig_bampton`) with the two pivot ``uz`` and
  every equipment attachment ``uz`` as boundary DOFs and the fixed-interface modes below
  ``cutoff_hz``; coordinates ``[u_b; eta]``;
* bogie b (front, rear): bounce ``z_b`` and pitch ``beta_b``; a point at ``x`` on it moves
  ``z_b + (x - x_b) beta_b``;
* secondary suspension (per bogie): spring-dashpot ``(k_s, c_s)`` on the drift
  ``d_s = u_pivot - z_b``; primary (per wheelset i): ``(k_p, c_p)`` on
  ``z_b + a_i beta_b - z_i`` with ``a_i = +-wheelbase / 2`` and ``z_i`` the track
  irregularity under wheelset i (the wheelsets follow the track);
* elastic equipment e: own DOF ``z_e`` on ``k_e = m_e (2 pi f_e)^2``,
  ``c_e = 2 zeta_e m_e 2 pi f_e`` to its attachment node.

Equation of motion in the coupled coordinates ``x`` (absolute displacements)::

    M x'' + C x' + K x = sum_i g_i (k_p z_i + c_p z_i') = -Gamma u,
    u = [z_1..z_4, z_1'..z_4'],  Gamma = -[k_p g_1 .. k_p g_4, c_p g_1 .. c_p g_4]

(``g_i`` puts a unit force at wheel point i of its bogie), the sign convention of
:mod:`modal_twin.twin.simulator` (``M q'' + C q' + K q = -Gamma u - sum B' f``). A
constant lift ``z`` of all wheelsets lifts the whole vehicle by ``z`` (``K x_rigid =
sum k_p g_i``). Carbody damping: modal damping ``zeta_k`` on the k-th flexible free-free
mode of the full beam (``zeta_carbody``, or ``zeta_cb_<k>`` for the first few),
``C_full = M Phi_e diag(2 zeta omega) Phi_e' M``, projected on the CB
basis (``T' C_full T``); suspensions and mounts add their dashpots (non-classical).

Reduction: the real undamped modes of the coupled model, ``x = Phi q`` with
``Phi' M Phi = I``, give ``M_r = I``, ``K_r = diag(omega^2)``, ``C_r = Phi' C Phi`` (full),
``Gamma_r = Phi' Gamma``. Outputs: floor vertical absolute accelerations
``y = S Phi q''`` (no feed-through: ``x`` is absolute); on request the stroke ``D x`` and
force (``k d + c d'``, or the device's) of each device site: the secondary suspensions, the
elastic equipment hangers and the primary suspensions, where a device law of the registry
may replace the element's spring and dashpot (:meth:`VehicleModel.sites`). A primary
stroke ``g_i' x - z_i`` holds the track input: the device there sees ``B q + E u`` (and its
rate ``B q' + Ed u``), its linear element's share of ``Gamma`` leaves with it, and its
stroke and force channels have a feed-through of the input.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as sla

from modal_twin._types import ComplexArray, FloatArray
from modal_twin.channels import ChannelSpec
from modal_twin.errors import ModelError, OptionError
from modal_twin.models.craig_bampton import CBReduction, craig_bampton
from modal_twin.models.devices import (
    BilinearElastic,
    CubicSpring,
    Device,
    LinearDevice,
    SmoothBilinearSpring,
)
from modal_twin.models.fe import FEAssembly, FEModel
from modal_twin.models.plant import Plant, Source
from modal_twin.models.reduced import DeviceAttachment, ReducedSystem
from modal_twin.models.vehicle_spec import (
    DEFAULT_VEHICLE_YAML,
    EquipmentSpec,
    SensorSpec,
    VehicleSpec,
    apply_theta,
    equipment_mounted,
    load_vehicle,
    theta_names,
)

__all__ = [
    "DEFAULT_VEHICLE_YAML",
    "INPUT_NAMES",
    "PRIMARY_SITES",
    "SUSPENSION_SITES",
    "Carbody",
    "EquipmentSpec",
    "SensorSpec",
    "VehicleModel",
    "VehicleSpec",
    "assemble_vehicle",
    "build_carbody",
    "build_vehicle",
    "equipment_mounted",
    "load_vehicle",
    "rigid_mode_count",
    "theta_names",
    "vehicle_info",
]

SUSPENSION_SITES: tuple[str, ...] = ("secondary_front", "secondary_rear")
"""Device sites of the car: the secondary suspension of each bogie (stroke ``u_pivot - z_b``)."""

PRIMARY_SITES: tuple[str, ...] = ("primary_1", "primary_2", "primary_3", "primary_4")
"""Device sites of the primary suspension of each wheelset (1 leads: front bogie, front
axle), stroke ``z_b + a_i beta_b - z_i`` (the track under it: an input)."""

INPUT_NAMES: tuple[str, ...] = ("zt1", "zt2", "zt3", "zt4", "vt1", "vt2", "vt3", "vt4")
"""Track irregularity under wheelsets 1 (leading) .. 4 (m) and its rate (m/s)."""

_E_ALU = 70e9  # Pa, aluminium: only E * Iz = EI matters in the vertical plane
_FIXED = ("ux", "uy", "rx", "rz")  # out-of-plane and axial DOFs are not modelled


@dataclass(frozen=True, slots=True)
class Carbody:
    """The FE carbody beam and its Craig-Bampton reduction.

    Attributes
    ----------
    assembly : FEAssembly
        Free DOFs ``uz``, ``ry`` of every node (rigid equipment lumped on its node).
    node_x : (n_nodes,) float array
        Node positions, m (node ids ``0 .. n_nodes - 1``).
    cb : CBReduction
        Boundary DOFs: front pivot, rear pivot, then each equipment node (unique).
    boundary_nodes : tuple of int
        Node of each boundary DOF.
    C_cb : (n_cb, n_cb) float array
        Carbody damping in CB coordinates (module docstring).
    f_free_hz : (n,) float array
        All free-free frequencies of the full beam (two rigid-body zeros first).
    """

    assembly: FEAssembly
    node_x: FloatArray
    cb: CBReduction
    boundary_nodes: tuple[int, ...]
    C_cb: FloatArray
    f_free_hz: FloatArray

    def node_at(self, x: float) -> int:
        """Node id at position ``x`` (nodes are placed at every named point)."""
        return int(np.argmin(np.abs(self.node_x - x)))

    def cb_index(self, x: float) -> int:
        """CB coordinate of the boundary ``uz`` at ``x`` (a pivot or an equipment point)."""
        return self.boundary_nodes.index(self.node_at(x))

    def uz_row(self, x: float) -> FloatArray:
        """Row of ``cb.T`` giving ``uz`` at node ``x`` from the CB coordinates."""
        return np.asarray(self.cb.T[self.assembly.dof_index(self.node_at(x), "uz")])


def _node_positions(spec: VehicleSpec) -> FloatArray:
    """Uniform grid, with the nearest free interior node moved onto each named point."""
    half = 0.5 * spec.length
    grid = np.linspace(-half, half, spec.n_elements + 1)
    h = spec.length / spec.n_elements
    named = sorted({*spec.pivot_x, *(e.x for e in spec.equipment),
                    *(s.x for s in spec.sensors)})
    claimed: set[int] = set()
    extra: list[float] = []
    for x in named:
        j = int(np.argmin(np.abs(grid - x)))
        if abs(grid[j] - x) <= 1e-9 * spec.length:
            claimed.add(j)
        elif 0 < j < grid.size - 1 and j not in claimed and abs(grid[j] - x) < 0.5 * h:
            grid[j] = x
            claimed.add(j)
        else:
            extra.append(x)
    return np.unique(np.concatenate([grid, extra]))


def rigid_mode_count(asm: FEAssembly) -> int:
    """Return the number of rigid-body modes of an assembled structure (its constraints).

    The rigid-body motions (:meth:`FEAssembly.rigid_body_modes`) the supports and ties
    leave free are the combinations of the six that vanish on every fixed DOF
    (``T R_free = R_full``) and that K does not load (its null space; a grounded spring
    softer than 1e-9 of K's largest term would pass); their count is the rank of their
    rigid-body mass ``R' M R``. A mesh refinement leaves it unchanged (the free-free
    carbody: 2, bounce and pitch), where a threshold relative to the largest eigenvalue
    moves with the shortest element.

    Parameters
    ----------
    asm : FEAssembly

    Returns
    -------
    int
    """
    R_full = asm.rigid_body_modes(full=True)
    R = R_full[asm.free_dofs]
    # combinations of the six that the constraints allow: zero on every fixed DOF
    A = sla.null_space(np.asarray(asm.T @ R) - R_full, rcond=1e-10)
    R = R @ A
    if R.shape[1] == 0:
        return 0
    # ... and that K does not load (to round-off of its largest term)
    k_scale = float(abs(asm.K).max())
    R = R[:, np.abs(asm.K @ R).max(axis=0) <= 1e-9 * k_scale * np.abs(R).max(axis=0)]
    if R.shape[1] == 0:
        return 0
    Mr = R.T @ (asm.M @ R)
    ev = np.linalg.eigvalsh(0.5 * (Mr + Mr.T))
    return int(np.count_nonzero(ev > 1e-9 * ev.max()))


def build_carbody(spec: VehicleSpec, *, cutoff_hz: float | None = None) -> Carbody:
    """Assemble the FE carbody beam and reduce it by Craig-Bampton (module docstring).

    Parameters
    ----------
    spec : VehicleSpec
    cutoff_hz : float, optional
        Fixed-interface cutoff (default ``spec.cutoff_hz``).

    Returns
    -------
    Carbody
    """
    xs = _node_positions(spec)
    fem = FEModel()
    for i, x in enumerate(xs):
        fem.add_node(i, (float(x), 0.0, 0.0))
        fem.fix(i, _FIXED)
    mu = spec.shell_line_mass + spec.fittings_line_mass
    Iz = spec.EI / _E_ALU  # horizontal frame: local y = global Z, E Iz = vertical EI
    for i in range(xs.size - 1):
        fem.add_frame(i, i + 1, E=_E_ALU, G=_E_ALU / 2.6, A=1.0, Iy=Iz, Iz=Iz, J=Iz,
                      rho=mu)  # A = 1 m^2: rho A = line mass (kg/m)
    for e in spec.equipment:
        if e.mount == "rigid":  # bolted: lumped on the attachment node (Fig. 3b of [002])
            fem.add_mass(int(np.argmin(np.abs(xs - e.x))), e.mass)
    asm = fem.assemble()
    bnodes: list[int] = []
    for x in (*spec.pivot_x, *(e.x for e in spec.equipment)):
        j = int(np.argmin(np.abs(xs - x)))
        if j not in bnodes:
            bnodes.append(j)
    bdofs = np.array([asm.dof_index(j, "uz") for j in bnodes], dtype=np.int64)
    fc = spec.cutoff_hz if cutoff_hz is None else float(cutoff_hz)
    cb = craig_bampton(asm.M, asm.K, bdofs, f_cut_hz=fc)
    Kd, Md = asm.K.toarray(), asm.M.toarray()
    lam, V = sla.eigh(Kd, Md)
    lam = np.clip(lam, 0.0, None)
    # the rigid-body modes (bounce and pitch of the free-free car) get no damping: they are
    # the lowest rigid_mode_count(asm) eigenvalues, whatever the mesh makes of lam.max()
    flex = np.arange(lam.size) >= rigid_mode_count(asm)
    om = np.sqrt(lam[flex])
    MV = Md @ V[:, flex]
    # modal damping zeta_k of flexible mode k (zeta_carbody unless the spec sets it)
    zeta = np.array([spec.zeta_mode(k + 1) for k in range(om.size)])
    C_full = MV @ np.diag(2.0 * zeta * om) @ MV.T
    return Carbody(assembly=asm, node_x=xs, cb=cb, boundary_nodes=tuple(bnodes),
                   C_cb=cb.project(C_full), f_free_hz=np.sqrt(lam) / (2.0 * math.pi))


@dataclass(frozen=True, slots=True)
class VehicleModel:
    """Coupled linear vehicle (module docstring) and its real modes.

    Attributes
    ----------
    spec : VehicleSpec
        With ``theta`` applied.
    carbody : Carbody
    M, C, K : (n, n) float arrays
        Coupled matrices on ``x = [u_b; eta; z_1, beta_1, z_2, beta_2; z_e...]``.
    Gamma : (n, 8) float array
        Track input participation (module docstring).
    dof_names : tuple of str
    S : (n_ch, n) float array
        Floor ``uz`` of each sensor from ``x``.
    D_sec : (2, n) float array
        Secondary-suspension drifts ``u_pivot - z_b`` (front, rear) from ``x``.
    D_mount : (n_elastic, n) float array
        Mount drifts ``z_e - u_floor`` of the elastic equipment items from ``x``.
    D_prim : (4, n) float array
        Bogie point over each axle, ``z_b + a_i beta_b``, from ``x`` (the primary stroke
        less the track, :data:`PRIMARY_SITES`).
    f_hz, omega : (n,) float arrays
        Undamped natural frequencies of the coupled model.
    Phi : (n, n) float array
        Mass-normalised real modes.
    channels : tuple of ChannelSpec
        ``floor_<label>_z`` absolute accelerations.
    """

    spec: VehicleSpec
    carbody: Carbody
    M: FloatArray
    C: FloatArray
    K: FloatArray
    Gamma: FloatArray
    dof_names: tuple[str, ...]
    S: FloatArray
    D_sec: FloatArray
    D_mount: FloatArray
    D_prim: FloatArray
    f_hz: FloatArray
    omega: FloatArray
    Phi: FloatArray
    channels: tuple[ChannelSpec, ...]

    @property
    def n_dof(self) -> int:
        """Number of coupled coordinates."""
        return int(self.M.shape[0])

    def rigid_lift(self) -> FloatArray:
        """Coordinates ``x`` of a unit rigid vertical translation of the whole vehicle."""
        r = np.zeros(self.n_dof)
        cb = self.carbody.cb
        r[: cb.n_boundary] = 1.0  # boundary uz; fixed-interface modes stay 0
        for j, name in enumerate(self.dof_names):
            if name.startswith("z_"):
                r[j] = 1.0
        return r

    def mass(self) -> float:
        """Mass moving with a rigid lift, ``r' M r`` (kg): carbody, bogies, equipment."""
        r = self.rigid_lift()
        return float(r @ self.M @ r)

    def damped_modes(self) -> tuple[FloatArray, FloatArray, ComplexArray]:
        """Return frequencies, damping ratios and shapes of the coupled model's complex modes.

        Frequencies ``|lambda| / 2 pi`` (Hz), damping ratios ``-Re lambda / |lambda|``, shapes
        on ``x``; ascending.
        """
        n = self.n_dof
        Minv = np.linalg.inv(self.M)
        A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ self.K, -Minv @ self.C]])
        lam, V = np.linalg.eig(A)
        keep = lam.imag > 0.0
        lam, V = lam[keep], V[:n, keep]
        order = np.argsort(np.abs(lam))
        lam, V = lam[order], V[:, order]
        return np.abs(lam) / (2.0 * math.pi), -lam.real / np.abs(lam), V

    def to_reduced_system(self, *, n_modes: int | None = None,
                          secondary_devices: bool = False,
                          site_devices: Mapping[str, Device] | None = None,
                          device_outputs: Sequence[str] = ()) -> ReducedSystem:
        """Return the modal :class:`ReducedSystem` (module docstring).

        Parameters
        ----------
        n_modes : int, optional
            Lowest real modes kept (default all).
        secondary_devices : bool
            Carry the secondary suspensions as 1-direction
            :class:`~modal_twin.models.devices.LinearDevice` attachments (their spring and
            dashpot removed from ``K_r``, ``C_r``) so that an effect can replace them.
        site_devices : mapping, optional
            Device site (:meth:`sites`: a secondary suspension, an elastic equipment
            hanger or a primary suspension) -> a device law of the registry that replaces
            that element's spring and dashpot; its first direction takes the stroke
            (``u_pivot - z_b``, ``z_e - u_floor``, ``z_b + a_i beta_b - z_i``), a second one
            (of a 2-direction law) none.
        device_outputs : sequence of str
            Sites whose stroke ``<site>_dz`` (m) and, where the element is linear, force
            ``<site>_fz = k d + c d'`` (N) are output after the accelerations.

        Raises
        ------
        OptionError
            ``n_modes`` not an int in ``[1, n]``.
        """
        n = self.n_dof
        r = n if n_modes is None else n_modes
        if isinstance(r, bool) or not isinstance(r, int | np.integer) or not 1 <= r <= n:
            msg = f"n_modes: expected an int in [1, {n}], got {n_modes!r}"
            raise OptionError(msg)
        Phi = self.Phi[:, :r]
        K = np.diag(self.omega[:r] ** 2)
        C = Phi.T @ self.C @ Phi
        devices: tuple[DeviceAttachment, ...] = ()
        given = dict(site_devices or {})
        unknown = sorted(set(given) - set(self.sites()))
        if unknown:
            msg = f"site_devices: expected sites from {list(self.sites())}, got {unknown}"
            raise OptionError(msg)
        atts = []
        for b, site in enumerate(SUSPENSION_SITES):
            if site not in given and not secondary_devices:
                continue
            B1 = self.D_sec[b] @ Phi
            ks, cs = self.spec.suspension("k_secondary", b), self.spec.suspension(
                "c_secondary", b)
            K = K - ks * np.outer(B1, B1)  # the law supplies the element's whole force
            C = C - cs * np.outer(B1, B1)
            dev = given.get(site) or LinearDevice([ks], [cs], name=site)
            atts.append(_along(dev, B1))
        devices = tuple(atts)
        K, C, mounts = self._nonlinear_mounts(Phi, K, C, given)
        K, C, Gamma, primaries = self._primary_devices(Phi, K, C, given)
        devices = devices + mounts + primaries
        SPhi = self.S @ Phi
        z = np.zeros_like(SPhi)
        rows, names = [np.hstack([z, z, SPhi])], [c.name for c in self.channels]
        feed = [np.zeros((SPhi.shape[0], len(INPUT_NAMES)))]
        if device_outputs:  # strokes, then the forces of the sites still linear
            carried = {a.device.name for a in devices}
            sites = {k: v for k, v in self.sites().items() if k in device_outputs}
            DPhi = np.vstack([d for d, _, _ in sites.values()]) @ Phi
            Eu, Ev = (np.vstack(e) for e in zip(*(self.site_inputs(s) for s in sites),
                                                strict=True))
            zd = np.zeros_like(DPhi)
            rows.append(np.hstack([DPhi, zd, zd]))
            feed.append(Eu)
            names += [f"{site}_dz" for site in sites]
            for j, (site, (_, k, c)) in enumerate(sites.items()):
                if site in carried or f"mount_{site}" in carried:
                    continue  # its force is the device's
                rows.append(np.hstack([k * DPhi[j], c * DPhi[j], np.zeros(r)])[None, :])
                feed.append((k * Eu[j] + c * Ev[j])[None, :])
                names.append(f"{site}_fz")
        C_out = np.vstack(rows)
        return ReducedSystem(M=np.eye(r), C=0.5 * (C + C.T), K=0.5 * (K + K.T),
                             Gamma=Phi.T @ Gamma, devices=devices, C_out=C_out,
                             D_out=np.vstack(feed), output_names=tuple(names))


    def sites(self) -> dict[str, tuple[FloatArray, float, float]]:
        """Return the device sites: name -> (stroke row on ``x``, spring k, dashpot c).

        The secondary suspensions (:data:`SUSPENSION_SITES`), every elastic equipment
        hanger (by the item's name), then the primary suspensions (:data:`PRIMARY_SITES`),
        whose stroke is the row's ``x`` part less the track (:meth:`site_inputs`).
        """
        out = {site: (self.D_sec[b], self.spec.suspension("k_secondary", b),
                      self.spec.suspension("c_secondary", b))
               for b, site in enumerate(SUSPENSION_SITES)}
        elastic = [e for e in self.spec.equipment if e.mount == "elastic"]
        for e, d in zip(elastic, self.D_mount, strict=True):
            out[e.name] = (d, e.k_mount, e.c_mount)
        for i, site in enumerate(PRIMARY_SITES):
            out[site] = (self.D_prim[i], self.spec.suspension("k_primary", i // 2),
                         self.spec.suspension("c_primary", i // 2))
        return out

    def site_inputs(self, site: str) -> tuple[FloatArray, FloatArray]:
        """Return the input's share of a site's stroke and of its rate, rows on ``u``.

        ``-1`` on the track ``z_i`` (and its rate) under a primary suspension's wheelset,
        zeros elsewhere (:data:`INPUT_NAMES`).
        """
        eu, ev = np.zeros(len(INPUT_NAMES)), np.zeros(len(INPUT_NAMES))
        if site in PRIMARY_SITES:
            i = PRIMARY_SITES.index(site)
            eu[i] = -1.0
            ev[4 + i] = -1.0
        return eu, ev

    def _primary_devices(self, Phi: FloatArray, K: FloatArray, C: FloatArray,
                         given: Mapping[str, Device]
                         ) -> tuple[FloatArray, FloatArray, FloatArray,
                                    tuple[DeviceAttachment, ...]]:
        """Carry the laws given at primary suspensions as devices (linear element moved).

        The element's spring and dashpot leave ``K``, ``C`` and its track terms leave
        ``Gamma`` (physical coordinates, returned); the device sees the stroke ``g_i' x -
        z_i`` (module docstring).
        """
        Gamma = self.Gamma.copy()
        atts = []
        for i, site in enumerate(PRIMARY_SITES):
            if site not in given:
                continue
            kp = self.spec.suspension("k_primary", i // 2)
            cp = self.spec.suspension("c_primary", i // 2)
            g = self.D_prim[i]
            Gamma[:, i] += kp * g  # was -k_p g: the law supplies the element's whole force
            Gamma[:, 4 + i] += cp * g
            B1 = g @ Phi
            K = K - kp * np.outer(B1, B1)
            C = C - cp * np.outer(B1, B1)
            atts.append(_along(given[site], B1, *self.site_inputs(site)))
        return K, C, Gamma, tuple(atts)

    def _nonlinear_mounts(self, Phi: FloatArray, K: FloatArray, C: FloatArray,
                          given: Mapping[str, Device]
                          ) -> tuple[FloatArray, FloatArray, tuple[DeviceAttachment, ...]]:
        """Carry hardening, softening and given mount laws as devices (linear part moved).

        A hardening mount is a power spring (:class:`CubicSpring`, exponent ``m``), a
        softening one a bilinear elastic spring (:class:`BilinearElastic`, ``kb = r k``
        beyond ``u_s``; with a sharpness ``n`` its rounded knee,
        :class:`SmoothBilinearSpring`), each with the mount's dashpot; a law given for the
        item's hanger replaces its spring and dashpot.
        """
        elastic = [e for e in self.spec.equipment if e.mount == "elastic"]
        atts = []
        for e, d in zip(elastic, self.D_mount, strict=True):
            dev: Device
            if e.name in given:
                dev = given[e.name]
            elif e.u_h_mount > 0.0:
                k3 = e.k_mount / e.u_h_mount ** (e.m_mount - 1.0)
                dev = CubicSpring(e.k_mount, k3, [e.c_mount], name=f"mount_{e.name}",
                                  m=e.m_mount)
            elif e.u_s_mount > 0.0 and e.r_mount < 1.0 and e.n_mount > 0.0:
                dev = SmoothBilinearSpring(e.k_mount, e.r_mount * e.k_mount, e.u_s_mount,
                                           [e.c_mount], name=f"mount_{e.name}", n=e.n_mount)
            elif e.u_s_mount > 0.0 and e.r_mount < 1.0:
                dev = BilinearElastic(e.k_mount, e.r_mount * e.k_mount, e.u_s_mount,
                                      [e.c_mount], name=f"mount_{e.name}")
            else:
                continue
            B1 = d @ Phi
            K = K - e.k_mount * np.outer(B1, B1)
            C = C - e.c_mount * np.outer(B1, B1)
            atts.append(_along(dev, B1))
        return K, C, tuple(atts)


def _along(dev: Device, B1: FloatArray, eu: FloatArray | None = None,
           ev: FloatArray | None = None) -> DeviceAttachment:
    """Attach ``dev`` along one stroke ``B1 q (+ eu u)``, rate ``B1 q' (+ ev u)``.

    A 2-direction law's second direction stays at rest.
    """
    B = np.zeros((dev.n_dir, B1.size))
    B[0] = B1
    if eu is None or ev is None:
        return DeviceAttachment(device=dev, B=B)
    E, Ed = np.zeros((dev.n_dir, eu.size)), np.zeros((dev.n_dir, ev.size))
    E[0], Ed[0] = eu, ev
    return DeviceAttachment(device=dev, B=B, E=E, Ed=Ed)


def _add_pair(A: FloatArray, d: FloatArray, k: float) -> None:
    A += k * np.outer(d, d)  # spring / dashpot k on the drift d' x


def assemble_vehicle(spec: VehicleSpec, *, theta: Mapping[str, float] | None = None,
                     cutoff_hz: float | None = None) -> VehicleModel:
    """Assemble the coupled linear vehicle (module docstring).

    Parameters
    ----------
    spec : VehicleSpec
    theta : mapping, optional
        Parameter values (:func:`~modal_twin.models.vehicle_spec.theta_names`).
    cutoff_hz : float, optional
        Craig-Bampton cutoff (default ``spec.cutoff_hz``).

    Returns
    -------
    VehicleModel

    Raises
    ------
    OptionError, ModelError
        Unknown or invalid ``theta``; a coupled stiffness that is not positive definite.
    """
    spec = apply_theta(spec, theta)
    car = build_carbody(spec, cutoff_hz=cutoff_hz)
    cb = car.cb
    n_cb = cb.Mr.shape[0]
    elastic = [e for e in spec.equipment if e.mount == "elastic"]
    n = n_cb + 4 + len(elastic)
    names = [f"uz_{car.node_x[j]:+.2f}" for j in car.boundary_nodes]
    names += [f"eta_{k + 1}" for k in range(cb.n_modes)]
    names += ["z_bogie_front", "beta_bogie_front", "z_bogie_rear", "beta_bogie_rear"]
    names += [f"z_{e.name}" for e in elastic]
    M = np.zeros((n, n))
    K = np.zeros((n, n))
    C = np.zeros((n, n))
    M[:n_cb, :n_cb] = cb.Mr
    K[:n_cb, :n_cb] = cb.Kr
    C[:n_cb, :n_cb] = car.C_cb
    Gamma = np.zeros((n, len(INPUT_NAMES)))
    D_sec = np.zeros((2, n))
    D_prim = np.zeros((4, n))
    a = 0.5 * spec.wheelbase
    for b, xb in enumerate(spec.pivot_x):
        iz, ib = n_cb + 2 * b, n_cb + 2 * b + 1
        M[iz, iz] = spec.bogie_mass
        M[ib, ib] = spec.bogie_pitch_inertia
        d = np.zeros(n)
        d[car.cb_index(xb)] = 1.0
        d[iz] = -1.0
        D_sec[b] = d
        _add_pair(K, d, spec.suspension("k_secondary", b))
        _add_pair(C, d, spec.suspension("c_secondary", b))
        for s, off in enumerate((a, -a)):
            i = 2 * b + s  # wheelset 1 leads: front bogie, front axle
            g = np.zeros(n)
            g[iz] = 1.0
            g[ib] = off
            D_prim[i] = g
            kp, cp = spec.suspension("k_primary", b), spec.suspension("c_primary", b)
            _add_pair(K, g, kp)
            _add_pair(C, g, cp)
            Gamma[:, i] = -kp * g  # simulator: ... = -Gamma u
            Gamma[:, 4 + i] = -cp * g
    D_mount = np.zeros((len(elastic), n))
    for k, e in enumerate(elastic):
        ie = n_cb + 4 + k
        M[ie, ie] = e.mass
        d = D_mount[k]
        d[ie] = 1.0
        d[car.cb_index(e.x)] = -1.0
        _add_pair(K, d, e.k_mount)
        _add_pair(C, d, e.c_mount)
    S = np.zeros((len(spec.sensors), n))
    for j, sensor in enumerate(spec.sensors):
        S[j, :n_cb] = car.uz_row(sensor.x)
    try:
        lam, Phi = sla.eigh(K, M)
    except np.linalg.LinAlgError as err:
        msg = f"{spec.source}: coupled M is not positive definite ({err})"
        raise ModelError(msg) from err
    if lam[0] <= 1e-12 * lam[-1]:
        msg = (f"{spec.source}: coupled K is not positive definite (lowest eigenvalue "
               f"{lam[0]:.3g}, largest {lam[-1]:.3g})")
        raise ModelError(msg)
    omega = np.sqrt(lam)
    channels = tuple(ChannelSpec(f"floor_{s.label}_z", "acceleration", f"floor_{s.label}",
                                 "z", position_m=(s.x, 0.0, 0.0)) for s in spec.sensors)
    return VehicleModel(spec=spec, carbody=car, M=M, C=C, K=K, Gamma=Gamma,
                        dof_names=tuple(names), S=S, D_sec=D_sec, D_mount=D_mount,
                        D_prim=D_prim, f_hz=omega / (2 * math.pi),
                        omega=omega, Phi=Phi, channels=channels)


def build_vehicle(spec: VehicleSpec | None = None, *, theta: Mapping[str, float] | None = None,
                  n_modes: int | None = None, cutoff_hz: float | None = None,
                  secondary_devices: bool = False,
                  site_devices: Mapping[str, Device] | None = None,
                  device_channels: Sequence[str] = ()) -> Plant:
    """Build the trailer-car :class:`~modal_twin.models.plant.Plant` (module docstring).

    Parameters
    ----------
    spec : VehicleSpec, optional
        Default: :func:`load_vehicle` of :data:`DEFAULT_VEHICLE_YAML`.
    theta : mapping, optional
        ``EI_carbody``, ``m_<equipment>``, ``f_<elastic equipment>`` ... (see
        :func:`~modal_twin.models.vehicle_spec.theta_names`).
    n_modes : int, optional
        Coupled real modes kept (default all).
    cutoff_hz : float, optional
        Craig-Bampton cutoff of the carbody (default the file's, 40 Hz).
    secondary_devices : bool
        Secondary suspensions as linear devices (see
        :meth:`VehicleModel.to_reduced_system`).
    site_devices : mapping, optional
        Device laws at the sites (:meth:`VehicleModel.sites`).
    device_channels : sequence of str
        Sites whose stroke ``<site>_dz`` (role ``device_drift``, m) and force ``<site>_fz``
        (``device_force``, N: spring, dashpot and any law there) are channels too.

    Returns
    -------
    Plant
        Inputs :data:`INPUT_NAMES`; channels ``floor_<label>_z`` (m/s^2, absolute), then
        ``<site>_dz`` (m) and ``<site>_fz`` (N) of the ``device_channels`` sites.

    Examples
    --------
    >>> p = build_vehicle()
    >>> p.input_names[:2], p.channel_names[2]
    (('zt1', 'zt2'), 'floor_mid_z')
    """
    spec = load_vehicle() if spec is None else spec
    vm = assemble_vehicle(spec, theta=theta, cutoff_hz=cutoff_hz)
    system = vm.to_reduced_system(n_modes=n_modes, secondary_devices=secondary_devices,
                                  site_devices=site_devices, device_outputs=device_channels)
    channels, sources = _channels(vm, system, device_channels)
    label = ",".join([*(f"{e.name}:elastic" for e in vm.spec.equipment
                        if e.mount == "elastic"),
                      *(f"{k}:{type(d).__name__}" for k, d in (site_devices or {}).items())]
                     ) or "nominal"
    quantities = ("displacement",) * 4 + ("velocity",) * 4
    return Plant(system, INPUT_NAMES, quantities, channels, sources,
                 name=f"{vm.spec.name}@{label}")



def _channels(vm: VehicleModel, system: ReducedSystem, devices: Sequence[str]
              ) -> tuple[tuple[ChannelSpec, ...], tuple[Source, ...]]:
    """Channels and their sources: accelerations, then the sites' strokes and forces.

    A site's force is an output row while its element is linear, else its device's force
    (the first direction of the device at that site).
    """
    y_index = {n: i for i, n in enumerate(system.output_names)}
    channels = list(vm.channels)
    sources: list[Source] = [("y", y_index[c.name]) for c in vm.channels]
    if not devices:
        return tuple(channels), tuple(sources)
    f_row, rows = {}, 0
    for att in system.devices:
        f_row[att.device.name] = rows
        rows += att.device.n_dir
    for qty, key, role in (("displacement", "d", "device_drift"),
                           ("force", "f", "device_force")):
        for site in (s for s in vm.sites() if s in devices):
            name = f"{site}_{key}z"
            channels.append(ChannelSpec(name, qty, site, "z", role=role))
            sources.append(("y", y_index[name]) if name in y_index else
                           ("force", f_row[site] if site in f_row else f_row[f"mount_{site}"]))
    return tuple(channels), tuple(sources)


def vehicle_info(model: VehicleModel, n_show: int = 12) -> dict[str, Any]:
    """JSON-ready summary: DOFs, mass, and the lowest complex modes with their dominant part.

    The part of a mode is the group (``carbody``, ``bogie_front``, ``bogie_rear`` or an
    elastic equipment item) with the largest share of ``|v_i (M v)_i|``.
    """
    f, zeta, V = model.damped_modes()
    n_cb = model.carbody.cb.Mr.shape[0]
    groups = {"carbody": slice(0, n_cb), "bogie_front": slice(n_cb, n_cb + 2),
              "bogie_rear": slice(n_cb + 2, n_cb + 4)}
    for k, name in enumerate(model.dof_names[n_cb + 4:]):
        groups[name[2:]] = slice(n_cb + 4 + k, n_cb + 5 + k)
    modes = []
    for j in range(min(n_show, f.size)):
        e = np.abs(V[:, j].conj() * (model.M @ V[:, j]))
        share = {g: float(e[s].sum() / e.sum()) for g, s in groups.items()}
        modes.append({"number": j + 1, "f_hz": float(f[j]), "zeta": float(zeta[j]),
                      "part": max(share, key=share.__getitem__), "shares": share})
    return {"name": model.spec.name, "n_dof": model.n_dof,
            "n_cb_modes": model.carbody.cb.n_modes, "total_mass_kg": model.mass(),
            "carbody_f_free_hz": model.carbody.f_free_hz[2:5].tolist(), "modes": modes}
