"""Base-isolated building twin: FE assembly, base input, outputs, devices, modal reduction.

The building of [004] (four storeys on six isolators RB1, RB2, ESB1, ESB2, SDP1, SDP2 on
the E-Defense 6-DOF table) is described in ``config/structures/building.yaml`` and read by
:mod:`modal_twin.models.structure_yaml`. In coordinates ``x`` relative to the rigid table
(Eq. (12) of [004])::

    M x'' + C x' + K x = -M P a_g + K_iso^nom x_iso - B_iso f_iso(x_iso, x_iso')   (12)

with ``P`` (n x 6) the rigid-body motion of every DOF for a unit table-centre translation
(x, y, z) or rotation (about x, y, z through ``input.origin``), and ``x_iso = G_iso x``
the device drifts (each device is a grounded spring, so its drift is the relative motion
of its node). The linear model keeps every device as its nominal linear spring-dashpot
(Eq. (1) of [004], Table 6 "updated"). Modal reduction with the ``r`` lowest modes of
that model (``x = Phi q``, ``Phi' M Phi = I``, as in Sec. 6 of [004], 36 modes)::

    q'' + C_r q' + K_r q = -Gamma a_g - sum_d B_d' f_d(B_d q, B_d q')
    K_r = diag(omega^2) - sum_{d nonlinear} B_d' k_d B_d
    C_r = Phi' C_dev Phi + diag(2 zeta_add omega) - sum_{d nonlinear} B_d' c_d B_d
    Gamma = Phi' M P,   B_d = G_d Phi (2 x r)

Removing ``B_d' k_d B_d`` is the modal form of the ``K_iso^nom x_iso`` term of Eq. (12);
the device's own viscous term is removed too because every law of
:mod:`modal_twin.models.devices` carries its ``c``. Outputs (absolute accelerations of
the sensors, Sec. 2 of [004]): ``y = S (Phi q'' + P a_g)``.

Damping (Sec. 6 of [004]): the devices' dashpots give ``Phi' C_dev Phi`` (non-classical,
dominant in the isolation modes). Modes ``j >= n_isolation_modes`` get added modal
damping ``zeta_add_j = max(0, zeta_target_j - zeta_dev_j)`` with ``zeta_dev_j =
(Phi' C_dev Phi)_jj / (2 omega_j)``; the targets (YAML ``damping``) are Table 2 of [004]
for modes 4-6 (3.21, 3.41, 3.17 %), 4.14 % for the vertical mode 7 (Table 3) and 3.31 %
(mean of Table 2 modes 4-8) for all later modes, exactly as [004] builds its damping.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.sparse.linalg as spla

from modal_twin._types import FloatArray
from modal_twin.errors import ModelError, OptionError
from modal_twin.models.building_parameters import (
    added_mass_matrix,
    damping_targets,
    split_theta,
)
from modal_twin.models.devices import Device
from modal_twin.models.fe import FEAssembly, solve_modes
from modal_twin.models.fe.definite import check_entries, positive_definite
from modal_twin.models.reduced import DeviceAttachment, ReducedSystem
from modal_twin.models.structure_yaml import StructureSpec, load_structure, make_device

__all__ = [
    "DEFAULT_BUILDING_YAML",
    "INPUT_NAMES",
    "BuildingModel",
    "ModalBuilding",
    "build_building",
    "check_stability",
    "modal_reduction",
    "positive_definite",
]

_log = logging.getLogger(__name__)

DEFAULT_BUILDING_YAML = (Path(__file__).resolve().parents[2] / "config" / "structures"
                         / "building.yaml")
"""The building of [004] shipped with the package."""

INPUT_NAMES: tuple[str, ...] = ("ax", "ay", "az", "arx", "ary", "arz")
"""Table-centre accelerations (m/s^2, rad/s^2), the 6 x 1 input of Eq. (12) of [004]."""

_RIGID_NAMES = ("x translation", "y translation", "z translation", "rotation about x",
                "rotation about y", "rotation about z")
Theta = Mapping[str, float] | Sequence[float] | FloatArray | None


@dataclass(frozen=True, slots=True)
class BuildingModel:
    """Assembled building with its input, output and device maps (free DOFs, n of them).

    Attributes
    ----------
    spec : StructureSpec
        The parsed YAML.
    assembly : FEAssembly
        Nominal matrices, ``T``, ``K(theta)`` (Sec. 4 of [004]).
    P : (n, 6) float array
        Influence matrix of the table-centre acceleration (Eq. (12) of [004]).
    S : (n_ch, n) float array
        Sensor rows: relative acceleration of each channel from ``x''``.
    S_P : (n_ch, 6) float array
        ``S @ P``: the rigid-body part of the absolute acceleration.
    channel_names : tuple of str
        ``<sensor>_<dir>``, e.g. ``F0_C1_x`` ... ``R_P2_z``.
    channel_xyz : (n_ch, 3) float array
        Sensor positions, m.
    device_names : tuple of str
    G : (n_dev, 2, n) float array
        Horizontal drift (x, y) of each device relative to the table: ``u_d = G[d] x``.
    Gz : (n_dev, n) float array
        Vertical displacement of each device's node.
    k_dev, c_dev : (n_dev, 2) float arrays
        Nominal horizontal stiffness (N/m) and damping (N s/m) (Table 6 of [004]).
    kz_dev : (n_dev,) float array
        Vertical stiffness, N/m.
    """

    spec: StructureSpec
    assembly: FEAssembly
    P: FloatArray
    S: FloatArray
    S_P: FloatArray
    channel_names: tuple[str, ...]
    channel_xyz: FloatArray
    device_names: tuple[str, ...]
    G: FloatArray
    Gz: FloatArray
    k_dev: FloatArray
    c_dev: FloatArray
    kz_dev: FloatArray

    @property
    def n_dof(self) -> int:
        """Number of free DOFs."""
        return self.assembly.n_dof

    def device_forces(self, x: FloatArray, *, theta: Theta = None) -> FloatArray:
        """Return the linear-spring forces ``(fx, fy, fz)`` of every device, N.

        Parameters
        ----------
        x : (n,) float array
            Displacement relative to the table, m.
        theta : optional
            Parameter values (device ``k_<name>_<x|y>`` are used when present).

        Returns
        -------
        (n_dev, 3) float array
            Force each device exerts on the table (= on the structure with minus sign).
        """
        k = self._k_at(theta)
        out = np.empty((len(self.device_names), 3))
        out[:, :2] = k * np.einsum("dij,j->di", self.G, np.asarray(x, dtype=float))
        out[:, 2] = self.kz_dev * (self.Gz @ x)
        return out

    def _k_at(self, theta: Theta) -> FloatArray:
        par = self.assembly.parametric
        th = par.theta_vector(theta)
        k = self.k_dev.copy()
        for d, name in enumerate(self.device_names):
            for a, ax in enumerate("xy"):
                k[d, a] = th[par.index(f"k_{name}_{ax}")]
        return k

    def _c_at(self, theta: Theta) -> FloatArray:
        par = self.assembly.parametric
        th = par.theta_vector(theta)
        c = self.c_dev.copy()
        for d, name in enumerate(self.device_names):
            for a, ax in enumerate("xy"):
                key = f"c_{name}_{ax}"
                if key in par.names:
                    c[d, a] = th[par.index(key)]
        return c

    def gravity_loads(self) -> FloatArray:
        """Return the static vertical load carried by each device under gravity, N (>= 0 down).

        Solves ``K x = -g M e_z`` (e_z: unit vertical rigid translation) on the nominal model.
        """
        asm = self.assembly
        f = -self.spec.gravity * np.asarray(asm.M @ self.P[:, 2])
        x = spla.spsolve(asm.K.tocsc(), f)
        return -self.device_forces(x)[:, 2]

    def nonlinear_devices(self, names: Iterable[str] | None = None) -> dict[str, Device]:
        """Return the nonlinear laws named in the YAML (``type``), ESB weights from gravity.

        Parameters
        ----------
        names : iterable of str, optional
            Devices to build (default: all).

        Raises
        ------
        OptionError
            Unknown device name.
        """
        want = self.device_names if names is None else tuple(names)
        bad = [n for n in want if n not in self.device_names]
        if bad:
            msg = f"names: expected devices from {list(self.device_names)}, got {bad}"
            raise OptionError(msg)
        W = self.gravity_loads()
        out: dict[str, Device] = {}
        for spec in self.spec.devices:
            if spec.name in want:
                d = self.device_names.index(spec.name)
                out[spec.name] = make_device(spec, weight=float(max(W[d], 0.0)))
        return out


def check_stability(spec: StructureSpec, asm: FEAssembly) -> None:
    """Refuse a model that is not stably supported, naming the reason.

    Two checks: (1) without fixed supports, the 6x6 stiffness ``R' K_full R`` of the rigid
    body motions (about ``input.origin``) must be positive in every direction -- it is the
    sum of the device springs, so a zero names the missing isolator direction; (2) ``K``
    must be positive definite (Cholesky); if not, the DOF that dominates the softest
    eigenvector is named.

    Raises
    ------
    ModelError
        With the direction or DOF and the relative eigenvalue found.
    """
    has_support = bool(np.any(np.diff(asm.T.indptr) == 0))  # fixed DOFs: empty rows of T
    if not has_support:
        R = asm.rigid_body_modes(spec.input_origin, full=True)
        d = np.diag(np.asarray(R.T @ (asm.K_full @ R)))
        for block in (slice(0, 3), slice(3, 6)):
            scale = max(float(np.abs(d[block]).max()), np.finfo(float).tiny)
            for j in range(block.start, block.stop):
                if d[j] <= 1e-9 * scale:
                    msg = (f"{spec.source}: model is unstable: no support stiffness against "
                           f"rigid-body {_RIGID_NAMES[j]} (R'KR = {d[j]:.3g}, scale "
                           f"{scale:.3g}); give the devices stiffness in that direction")
                    raise ModelError(msg)
    ok, pivot = positive_definite(asm.K)
    if ok:
        return
    labels = asm.dof_labels()
    if asm.K.shape[0] <= _DENSE_NAMING_MAX:  # name the DOF of the softest eigenvector
        lam, V = np.linalg.eigh(asm.K.toarray())
        j = int(np.argmax(np.abs(V[:, 0])))
        node, dof = labels[j]
        msg = (f"{spec.source}: K is singular or indefinite: softest eigenvalue "
               f"{lam[0]:.3g} (largest {lam[-1]:.3g}), mechanism dominated by {node!r}:{dof}")
    else:
        node, dof = labels[pivot]
        msg = (f"{spec.source}: K is singular or indefinite: non-positive pivot of its "
               f"LDL' factorisation at {node!r}:{dof}")
    raise ModelError(msg)


_DENSE_NAMING_MAX = 3000  # DOFs up to which a failed check names the softest eigenvector


def build_building(path: str | Path | None = None, *, spec: StructureSpec | None = None
                   ) -> BuildingModel:
    """Assemble the building of a structure file (default: :data:`DEFAULT_BUILDING_YAML`).

    Parameters
    ----------
    path : str or Path, optional
        Structure YAML.
    spec : StructureSpec, optional
        An already parsed structure (takes precedence over ``path``).

    Returns
    -------
    BuildingModel

    Raises
    ------
    ConfigError, ModelError
        From the loader, or an unstable / singular model (:func:`check_stability`).
    """
    if spec is None:
        spec = load_structure(DEFAULT_BUILDING_YAML if path is None else path)
    asm = spec.model.assemble()
    check_stability(spec, asm)
    P = asm.rigid_body_modes(spec.input_origin)  # Eq. (12) of [004]: influence matrix P
    Tc = asm.T.tocsr()  # rows of T only: a dense T is (n_full, n), 85 GB at 100k DOF

    def t_row(i: int) -> FloatArray:
        return Tc[[i]].toarray().ravel()

    rows, names, xyz = [], [], []
    for s in spec.sensors:
        for d in s.directions:
            rows.append(t_row(asm.full_dof_index(s.node, "u" + d)))
            names.append(f"{s.name}_{d}")
            xyz.append(spec.model.xyz(s.node))
    n = asm.n_dof
    S = np.array(rows).reshape(-1, n)
    nd = len(spec.devices)
    G = np.zeros((nd, 2, n))
    Gz = np.zeros((nd, n))
    for di, dev in enumerate(spec.devices):
        G[di, 0] = t_row(asm.full_dof_index(dev.node, "ux"))
        G[di, 1] = t_row(asm.full_dof_index(dev.node, "uy"))
        Gz[di] = t_row(asm.full_dof_index(dev.node, "uz"))
    return BuildingModel(
        spec=spec, assembly=asm, P=P, S=S, S_P=S @ P, channel_names=tuple(names),
        channel_xyz=np.array(xyz).reshape(-1, 3),
        device_names=tuple(d.name for d in spec.devices), G=G, Gz=Gz,
        k_dev=np.array([d.k for d in spec.devices]).reshape(-1, 2),
        c_dev=np.array([d.c for d in spec.devices]).reshape(-1, 2),
        kz_dev=np.array([d.kz for d in spec.devices]))


@dataclass(frozen=True, slots=True)
class ModalBuilding:
    """Modal reduction of the linear building (all devices as linear springs).

    Attributes
    ----------
    f_hz, omega : (r,) float arrays
        Undamped natural frequencies of the full linear model, Hz and rad/s.
    Phi : (n, r) float array
        Mass-normalised mode shapes on the free DOFs.
    zeta : (r,) float array
        Damping ratio ``C_r[j, j] / (2 omega_j)`` (classical estimate; the isolation modes
        are non-classically damped, Sec. 3.1 of [004]).
    zeta_added : (r,) float array
        Added modal damping (module docstring).
    M, C, K : (r, r) float arrays
        ``I``, ``Phi' C_dev Phi + diag(2 zeta_add omega)``, ``diag(omega^2)``.
    Gamma : (r, 6) float array
        ``Phi' M P`` (Eq. (12) of [004]).
    device_names : tuple of str
    B : (n_dev, 2, r) float array
        Device drifts ``u_d = B[d] q``, relative to the table.
    k_dev, c_dev : (n_dev, 2) float arrays
        Linear device stiffness and damping used in ``K`` and ``C``.
    C_acc : (n_ch, 3 r) float array
        Absolute accelerations from ``[q; q'; q'']``.
    D_acc : (n_ch, 6) float array
        Their feed-through of ``a_g``.
    channel_names : tuple of str
    theta : (n_theta,) float array
        Assembly parameters the model was built with.
    theta_modal : mapping, optional
        Damping and added-mass parameters it was built with
        (:mod:`modal_twin.models.building_parameters`).
    """

    f_hz: FloatArray
    omega: FloatArray
    Phi: FloatArray
    zeta: FloatArray
    zeta_added: FloatArray
    M: FloatArray
    C: FloatArray
    K: FloatArray
    Gamma: FloatArray
    device_names: tuple[str, ...]
    B: FloatArray
    k_dev: FloatArray
    c_dev: FloatArray
    C_acc: FloatArray
    D_acc: FloatArray
    channel_names: tuple[str, ...]
    theta: FloatArray
    theta_modal: Mapping[str, float] | None = None

    @property
    def n_modes(self) -> int:
        """Number of modal coordinates r."""
        return int(self.omega.size)

    def _index(self, name: str) -> int:
        try:
            return self.device_names.index(name)
        except ValueError:
            msg = f"device: expected one of {list(self.device_names)}, got {name!r}"
            raise OptionError(msg) from None

    def drift_matrix(self, name: str) -> FloatArray:
        """Return ``B_d`` (2 x r) of device ``name``."""
        return self.B[self._index(name)]

    def device_linear_part(self, name: str) -> tuple[FloatArray, FloatArray]:
        """Return ``(B_d' k_d B_d, B_d' c_d B_d)``: the modal stiffness and damping of a device.

        This is the term Eq. (12) of [004] cancels (``K_iso^nom``) when the device's
        nonlinear law supplies its force instead.
        """
        d = self._index(name)
        b = self.B[d]
        return b.T @ (self.k_dev[d][:, None] * b), b.T @ (self.c_dev[d][:, None] * b)

    def linear_part(self, nonlinear: Iterable[str] = ()) -> tuple[FloatArray, FloatArray]:
        """Return ``(K_r, C_r)`` with the linear springs of the ``nonlinear`` devices removed."""
        K = self.K.copy()
        C = self.C.copy()
        for name in nonlinear:
            dk, dc = self.device_linear_part(name)
            K -= dk  # Eq. (12) of [004]: + K_iso^nom x_iso on the right-hand side
            C -= dc
        return K, C

    def to_reduced_system(
        self, devices: Mapping[str, Device] | None = None, *,
        outputs: Sequence[str] = ("acc",),
    ) -> ReducedSystem:
        """Return the :class:`~modal_twin.twin.simulator.ReducedSystem` of Eq. (12) of [004].

        Parameters
        ----------
        devices : mapping name -> Device, optional
            Devices whose force comes from a (nonlinear) law; their linear spring and
            dashpot are removed from ``K`` and ``C``. ``None``: fully linear model.
        outputs : sequence of {"acc", "drift", "force"}
            Output rows, in this order: the absolute accelerations (channel names), the
            drifts ``<device>_dx`` / ``_dy`` (m) and the forces ``<device>_fx`` / ``_fy`` (N)
            of the devices that stay linear (forces of law devices are in ``SimResult.force``).

        Raises
        ------
        OptionError
            Unknown output or device name.
        """
        devices = dict(devices or {})
        for name in devices:
            self._index(name)
        valid = ("acc", "drift", "force")
        bad = [o for o in outputs if o not in valid]
        if bad or not outputs:
            msg = f"outputs: expected a non-empty subset of {list(valid)}, got {list(outputs)}"
            raise OptionError(msg)
        r = self.n_modes
        K, C = self.linear_part(devices)
        blocks: list[FloatArray] = []
        feed: list[FloatArray] = []
        names: list[str] = []
        for o in outputs:
            if o == "acc":
                blocks.append(self.C_acc)
                feed.append(self.D_acc)
                names += self.channel_names
            elif o == "drift":
                nb = 2 * len(self.B)
                blocks.append(np.hstack([self.B.reshape(-1, r), np.zeros((nb, 2 * r))]))
                feed.append(np.zeros((2 * len(self.B), 6)))
                names += [f"{n}_d{a}" for n in self.device_names for a in "xy"]
            else:
                lin = [d for d, n in enumerate(self.device_names) if n not in devices]
                for d in lin:
                    b = self.B[d]
                    blocks.append(np.hstack([self.k_dev[d][:, None] * b,
                                             self.c_dev[d][:, None] * b, np.zeros((2, r))]))
                    feed.append(np.zeros((2, 6)))
                    names += [f"{self.device_names[d]}_f{a}" for a in "xy"]
        att = tuple(DeviceAttachment(device=dev, B=self.drift_matrix(name))
                    for name, dev in devices.items())
        return ReducedSystem(M=self.M.copy(), C=C, K=K, Gamma=self.Gamma.copy(), devices=att,
                             C_out=np.vstack(blocks), D_out=np.vstack(feed),
                             output_names=tuple(names))


def modal_reduction(building: BuildingModel, n_modes: int | None = None, *,
                    theta: Theta = None) -> ModalBuilding:
    """Reduce the linear building to its lowest modes (module docstring, Eq. (12) of [004]).

    Parameters
    ----------
    building : BuildingModel
    n_modes : int, optional
        Number of modes r (default: YAML ``reduction.n_modes``, 36 as in Sec. 6 of [004]).
    theta : mapping or array, optional
        Parameter values (concrete moduli ``E_*``, device ``k_*`` / ``c_*``, group factors,
        and, in a mapping, the damping and added-mass parameters of
        :mod:`~modal_twin.models.building_parameters`); nominal if None.

    Returns
    -------
    ModalBuilding

    Raises
    ------
    OptionError
        Bad ``n_modes``.
    ModelError
        Singular or indefinite ``K(theta)``.
    """
    asm = building.assembly
    par = asm.parametric
    r = building.spec.n_modes if n_modes is None else n_modes
    n_mass = int(np.count_nonzero(asm.M.diagonal() > 0.0))
    if isinstance(r, bool) or not isinstance(r, int | np.integer) or not 1 <= r <= n_mass:
        msg = f"n_modes: expected an int in [1, {n_mass}] (DOFs with mass), got {r!r}"
        raise OptionError(msg)
    if isinstance(theta, Mapping):
        theta, modal = split_theta(building, theta)
    else:
        modal = split_theta(building, None)[1]
    th = par.theta_vector(theta)
    K, M, C = par.K(th), par.M(th), par.C(th)
    if theta is not None:
        check_entries("M(theta)", M, positive_diagonal=False)
        check_entries("C(theta)", C, positive_diagonal=False)
        ok, j = positive_definite(K)
        if not ok:
            node, dof = asm.dof_labels()[j]
            msg = (f"theta: K(theta) is not positive definite at {node!r}:{dof} (DOF {j}): "
                   "a modulus or stiffness <= 0, or not finite?")
            raise ModelError(msg)
    dM = added_mass_matrix(building, modal)
    if dM is not None:
        M = M + dM
    sol = solve_modes(K, M, int(r))
    Phi, omega = sol.Phi, sol.omega
    Cdev = Phi.T @ (C @ Phi)
    zeta_dev = np.diag(Cdev) / (2.0 * omega)
    spec = building.spec.damping
    target = damping_targets(spec, r, modal)
    lo = spec.n_isolation_modes
    zeta_add = np.where(np.arange(r) >= lo, np.maximum(target - zeta_dev, 0.0), 0.0)
    Cr = Cdev + np.diag(2.0 * zeta_add * omega)  # Sec. 6 of [004]: added modal damping
    alpha = modal.get(spec.alpha_param or "", spec.rayleigh_alpha)
    beta = modal.get(spec.beta_param or "", spec.rayleigh_beta)
    if alpha or beta:  # Phi' (alpha M + beta K) Phi = alpha I + beta diag(omega^2)
        Cr = Cr + np.diag(alpha + beta * omega**2)
    Cr = 0.5 * (Cr + Cr.T)
    Gamma = Phi.T @ (M @ building.P)  # Eq. (12) of [004]: Phi' M P
    B = np.einsum("dij,jr->dir", building.G, Phi)
    SPhi = building.S @ Phi
    C_acc = np.hstack([np.zeros_like(SPhi), np.zeros_like(SPhi), SPhi])
    return ModalBuilding(
        f_hz=sol.f_hz, omega=omega, Phi=Phi, zeta=np.diag(Cr) / (2.0 * omega),
        zeta_added=zeta_add, M=np.eye(r), C=Cr, K=np.diag(omega**2), Gamma=Gamma,
        device_names=building.device_names, B=B, k_dev=building._k_at(th),
        c_dev=building._c_at(th), C_acc=C_acc, D_acc=building.S_P.copy(),
        channel_names=building.channel_names, theta=th, theta_modal=modal)
