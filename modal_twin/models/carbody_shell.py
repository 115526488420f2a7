"""The Craig-Bampton shell carbody as the 3D vehicle's carbody ([002] Sec. 5.1).

The shell carbody (:mod:`modal_twin.models.carbody3d`) reduced by Craig-Bampton on its
interface nodes (:mod:`modal_twin.models.carbody_reduction`: the air-spring seats, the
centre pins and the equipment hangers, six DOFs each; the equipment bodies stay inside the
carbody on their elastic or bolted hangers, except the boxes the vehicle file hangs
itself, whose hanger nodes' translations are the carbody's ``hangers``) becomes a
:class:`~modal_twin.models.carbody_interface.ReducedCarbody` in four steps.

1. **Rigid-body subspace by a physical rule.** The reduced rigid-body vectors ``R_r`` are
   the rigid motions of the node coordinates restricted to the boundary rows, modal rows
   zero (CB eq. 1). The reduced stiffness is made to annihilate them exactly::

       K_r <- P' K_r P,   P = I - R_r (R_r' M_r R_r)^-1 R_r' M_r

   and the free-free modes of ``(K_r, M_r)`` whose mass-weighted share in ``span(R_r)``
   exceeds one half are the rigid ones (:func:`~modal_twin.models.carbody_reduction.
   reduced_rigid_mask`); exactly six must be found, none is picked by the size of its
   eigenvalue.
2. **Damping.** Modal damping ``zeta`` on every flexible free-free mode plus the
   equipment mounts' dashpots projected through the CB basis::

       C_r = M_r Phi_f diag(2 zeta omega) Phi_f' M_r + T' C T

   (``Phi_f`` mass-normalised; rigid modes undamped).
3. **Seats** (the interface of the secondary suspension). The seat's translations are the
   seat node's; its rotations are those of the bolster, rigidly bolted to the underframe
   ([002] Sec. 5.1), from the two seat nodes of that bolster (``y_L = -y_R = b``)::

       theta_x = (u_zL - u_zR) / (2 b),  theta_z = -(u_xL - u_xR) / (2 b),
       theta_y = (r_yL + r_yR) / 2

   (the shell's drilling rotation is never used). Seats ``seat_1L .. seat_2R``; the centre
   pins are the extra seats ``pivot_1, pivot_2`` (traction rod, lateral damper). Floor
   points are the underframe nodes nearest [002]'s points; rows of ``T`` recover them.
   The carbody's ``motion`` (what stands for it in a vehicle mode's shares) is its
   mass-weighted rigid motion about ``G`` and the elastic translations of its seats.
4. **Modal basis for speed** (``f_keep_hz``; None keeps the CB coordinates). The
   coordinates become the six rigid modes, the flexible free-free modes below
   ``f_keep_hz``, and the **residual-flexibility** vectors of the translations of the
   seats and centre pins (MacNeal's residual attachment modes: the static response to a
   unit force that the dropped modes carry)::

       psi_j = sum_{dropped k} phi_k phi_k' e_j / omega_k^2

   orthonormalised and diagonalised among themselves. The kept modes are exact (the
   residual vectors are mass- and stiffness-orthogonal to them) and a stiff suspension at
   a seat sees the right static flexibility there, so the carbody on stiff supports is
   still right (Craig and Chang's argument for residual flexibility).

The shell's frame has ``z = 0`` at the underframe; in the vehicle it is lifted to the
seat height ``z0`` (the air springs carry the bolsters).

References
----------
R. H. MacNeal, "A hybrid method of component mode synthesis", Computers & Structures 1
(1971) 581-601. R. R. Craig, C.-J. Chang, "On the use of attachment modes in substructure
coupling for dynamic analysis", AIAA paper 77-405 (1977).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg as sla

from modal_twin._types import BoolArray, ComplexArray, FloatArray
from modal_twin.errors import ModelError, OptionError
from modal_twin.models.carbody3d import CarbodyFE, CarbodyParams, build_carbody
from modal_twin.models.carbody_interface import ReducedCarbody, offset_matrix
from modal_twin.models.carbody_modes import name_modes
from modal_twin.models.carbody_reduction import (
    reduce_carbody,
    reduced_rigid_mask,
    reduced_rigid_vectors,
)
from modal_twin.models.craig_bampton import CBReduction
from modal_twin.models.fe import NodeId
from modal_twin.models.vehicle3d_spec import Vehicle3DSpec

__all__ = [
    "ShellCarbody",
    "reduced_shell",
    "shell_carbody",
    "shell_mode_labels",
    "vehicle_shell_carbody",
]

_TRANSLATIONS = ("ux", "uy", "uz")


@dataclass(frozen=True, slots=True)
class ShellCarbody:
    """The shell carbody behind a vehicle's :class:`ReducedCarbody` (module docstring).

    Attributes
    ----------
    car : CarbodyFE
    cb : CBReduction
    basis : (n_cb, n) float array
        CB coordinates per carbody coordinate (identity without the modal step).
    f_free_hz : (n_free,) float array
        Free-free frequencies of the CB carbody (rigid ones 0), Hz.
    rigid : (n_free,) bool array
        Rigid modes among them (physical rule, module docstring step 1).
    z0 : float
        Height of the shell's ``z = 0`` (underframe) above rail, m.
    rigid_mass : (6, 6) float array
        Rigid-body mass about the centre of gravity ``G`` (kg, kg m, kg m^2).
    cg : (3,) float array
        ``G`` in the shell's frame, m.
    """

    car: CarbodyFE
    cb: CBReduction
    basis: FloatArray
    f_free_hz: FloatArray
    rigid: BoolArray
    z0: float
    rigid_mass: FloatArray
    cg: FloatArray

    def recover(self, qc: FloatArray) -> FloatArray:
        """Shell free-DOF vectors (n_fe, k) of carbody coordinates ``qc`` (n, k)."""
        return np.asarray(self.cb.T @ (self.basis @ np.asarray(qc)))


def _rows(car: CarbodyFE, cb: CBReduction, node: NodeId, dofs: Sequence[str]) -> FloatArray:
    idx = [car.asm.dof_index(node, d) for d in dofs]
    return np.asarray(cb.T[idx])


def _seat_matrices(car: CarbodyFE, cb: CBReduction) -> dict[str, tuple[FloatArray, FloatArray]]:
    """Seats and centre pins, six DOFs each (module docstring step 3), shell frame."""
    xyz = {n: car.asm.xyz[i] for i, n in enumerate(car.asm.nodes)}
    out: dict[str, tuple[FloatArray, FloatArray]] = {}
    for b, end in enumerate(("front", "rear"), start=1):
        nL, nR = car.seats[f"{end}_left"], car.seats[f"{end}_right"]
        uL, uR = _rows(car, cb, nL, _TRANSLATIONS), _rows(car, cb, nR, _TRANSLATIONS)
        width = float(xyz[nL][1] - xyz[nR][1])
        rot = np.vstack([(uL[2] - uR[2]) / width,
                         0.5 * (_rows(car, cb, nL, ("ry",))[0] + _rows(car, cb, nR, ("ry",))[0]),
                         -(uL[0] - uR[0]) / width])
        for name, node, u in ((f"seat_{b}L", nL, uL), (f"seat_{b}R", nR, uR),
                              (f"pivot_{b}", car.pivots[end],
                               _rows(car, cb, car.pivots[end], _TRANSLATIONS))):
            out[name] = (np.asarray(xyz[node], dtype=float), np.vstack([u, rot]))
    return out


def _floor_points(car: CarbodyFE, cb: CBReduction, points: Mapping[str, tuple[float, float]]
                  ) -> dict[str, tuple[FloatArray, FloatArray]]:
    out: dict[str, tuple[FloatArray, FloatArray]] = {}
    floor = [k for k, (_, z) in enumerate(car.ring_yz) if abs(z) < 1e-9]
    for label, (x, y) in points.items():
        i = int(np.argmin(np.abs(car.stations - x)))
        k = floor[int(np.argmin(np.abs(car.ring_yz[floor, 0] - y)))]
        node = car.ring[i, k]
        out[label] = (np.array([car.stations[i], car.ring_yz[k, 0], 0.0]),
                      _rows(car, cb, node, _TRANSLATIONS))
    return out


def _rigid_free_modes(car: CarbodyFE, cb: CBReduction
                      ) -> tuple[FloatArray, FloatArray, FloatArray, BoolArray]:
    """Return ``Kr`` without rigid stiffness, free-free ``lam``, ``V`` and the rigid mask."""
    Mr = cb.Mr
    Rr = reduced_rigid_vectors(car, cb)
    MR = Mr @ Rr
    P = np.eye(Mr.shape[0]) - Rr @ np.linalg.solve(Rr.T @ MR, MR.T)
    Kr = P.T @ cb.Kr @ P
    Kr = 0.5 * (Kr + Kr.T)
    lam, V = sla.eigh(Kr, Mr)
    rigid = reduced_rigid_mask(Rr, Mr, V)
    if int(rigid.sum()) != 6:
        msg = (f"carbody: expected six rigid modes by projection on the rigid-body vectors, "
               f"found {int(rigid.sum())} (is the shell connected?)")
        raise ModelError(msg)
    lam = np.where(rigid, 0.0, lam)
    return Kr, lam, V, rigid


def _residual_vectors(cb: CBReduction, lam: FloatArray, V: FloatArray, drop: BoolArray,
                      load_cols: FloatArray) -> FloatArray:
    """Residual attachment vectors of the dropped modes, orthonormalised (module step 4)."""
    Vd = V[:, drop]
    Psi = Vd @ ((Vd.T @ load_cols) / lam[drop][:, None])
    U, s, _ = np.linalg.svd(Psi, full_matrices=False)
    return np.asarray(U[:, s > 1e-9 * s[0]]) if s.size and s[0] > 0 else np.zeros((V.shape[0], 0))


def _hanger_matrices(car: CarbodyFE, cb: CBReduction, boxes: Sequence[str]
                     ) -> dict[str, tuple[FloatArray, FloatArray]]:
    """Hanger nodes ``<box>_h1 .. _h4`` of the boxes the vehicle hangs: translations."""
    xyz = {n: car.asm.xyz[i] for i, n in enumerate(car.asm.nodes)}
    return {f"{box}_h{j + 1}": (np.asarray(xyz[node], dtype=float),
                                _rows(car, cb, node, _TRANSLATIONS))
            for box in boxes for j, node in enumerate(car.hangers[box])}


def shell_carbody(car: CarbodyFE, cb: CBReduction, *, points: Mapping[str, tuple[float, float]],
                  z0: float, zeta: float = 0.02, f_keep_hz: float | None = 40.0,
                  name: str = "shell", hung: Sequence[str] = ()) -> ReducedCarbody:
    """Return the CB shell carbody as the vehicle's reduced carbody (module docstring).

    Parameters
    ----------
    car : CarbodyFE
        The shell carbody (seats at the vehicle's air-spring half spacing).
    cb : CBReduction
        Its Craig-Bampton reduction (:func:`~modal_twin.models.carbody_reduction.
        reduce_carbody`).
    points : mapping label -> (x, y)
        Floor accelerometers, m; each is the underframe node nearest to it.
    z0 : float
        Height of the underframe (the shell's ``z = 0``) above rail, m.
    zeta : float
        Modal damping ratio of the flexible free-free modes.
    f_keep_hz : float or None
        Flexible modes kept in the modal basis, Hz (plus residual vectors); None keeps the
        CB coordinates.
    hung : sequence of str
        Equipment boxes the vehicle hangs (``params.hung_outside``): their hanger nodes'
        translations are the carbody's ``hangers`` (and get residual vectors, step 4).

    Returns
    -------
    ReducedCarbody
        Its ``source`` is the :class:`ShellCarbody`.

    Raises
    ------
    ModelError
        Not six rigid modes.
    OptionError
        A negative ``zeta`` or a non-positive ``f_keep_hz``.
    """
    if not (np.isfinite(zeta) and 0.0 <= zeta < 1.0):
        msg = f"zeta: expected a finite value in [0, 1), got {zeta!r}"
        raise OptionError(msg)
    if f_keep_hz is not None and not (np.isfinite(f_keep_hz) and f_keep_hz > 0.0):
        msg = f"f_keep_hz: expected a finite value > 0 or None, got {f_keep_hz!r}"
        raise OptionError(msg)
    Kr, lam, V, rigid = _rigid_free_modes(car, cb)
    Mr = cb.Mr
    w = np.sqrt(lam)
    flex = ~rigid
    MVf = Mr @ V[:, flex]
    Cr = MVf @ np.diag(2.0 * zeta * w[flex]) @ MVf.T + cb.project(car.asm.C)  # step 2
    seats = _seat_matrices(car, cb)
    pts = _floor_points(car, cb, points)
    hang = _hanger_matrices(car, cb, hung)
    lift = np.array([0.0, 0.0, z0])
    if f_keep_hz is None:
        basis = np.eye(Mr.shape[0])
        dl = car.asm.dof_labels()
        labels = [f"{dl[d][0]}_{dl[d][1]}" for d in cb.boundary_dofs.tolist()] + [
            f"eta{k + 1}" for k in range(cb.n_modes)]
        M, K, C = Mr, Kr, Cr
    else:
        keep = rigid | (w < 2.0 * np.pi * f_keep_hz)
        loads = np.hstack([seats[s][1][:3].T for s in sorted(seats)]  # T' e_j, translations
                          + [P.T for _, P in hang.values()])
        Res = _residual_vectors(cb, lam, V, ~keep, loads)
        Mres, Kres = Res.T @ Mr @ Res, Res.T @ Kr @ Res
        lr, Vr = sla.eigh(0.5 * (Kres + Kres.T), 0.5 * (Mres + Mres.T))
        basis = np.hstack([V[:, keep], Res @ Vr])
        M = basis.T @ Mr @ basis
        K = basis.T @ Kr @ basis
        C = basis.T @ Cr @ basis
        M, K, C = (0.5 * (A + A.T) for A in (M, K, C))
        f_keep = w[keep] / (2.0 * np.pi)
        labels = [f"rigid{k + 1}" for k in range(6)] + [
            f"flex{k + 1}_{f:.1f}Hz" for k, f in enumerate(f_keep[~rigid[keep]])] + [
            f"residual{k + 1}_{np.sqrt(max(x, 0.0)) / (2 * np.pi):.0f}Hz"
            for k, x in enumerate(lr)]
    cg = car.asm.rigid_body_mass()
    G = np.array([cg[1, 5], cg[2, 3], cg[0, 4]]) / cg[0, 0]  # m x_c, m y_c, m z_c
    Rg = np.zeros_like(reduced_rigid_vectors(car, cb))
    Rg[: cb.n_boundary] = car.asm.rigid_body_modes(G)[cb.boundary_dofs]
    MRg = Mr @ Rg
    fit = np.linalg.solve(Rg.T @ MRg, MRg.T @ basis)  # least squares in M_r (6, n)
    seat_map = {s: (p + lift, T @ basis) for s, (p, T) in seats.items()}
    elastic = [T[:3] @ basis - offset_matrix(p - G) @ fit for s, (p, T) in sorted(seats.items())]
    motion = np.vstack([fit, *elastic])
    pt_map = {s: (p + lift, P @ basis) for s, (p, P) in pts.items()}
    hang_map = {s: (p + lift, P @ basis) for s, (p, P) in hang.items()}
    source = ShellCarbody(car=car, cb=cb, basis=basis, f_free_hz=w / (2.0 * np.pi),
                          rigid=rigid, z0=float(z0), rigid_mass=Rg.T @ MRg, cg=G)
    return ReducedCarbody(name=name, M=M, K=K, C=C, seats=seat_map, points=pt_map,
                          coordinates=tuple(labels), motion=motion, source=source,
                          hangers=hang_map)


_RIGID_NAMES = ("surge", "sway", "bounce", "roll", "pitch", "yaw")


def shell_mode_labels(carbody: ReducedCarbody, f_hz: FloatArray, Qc: ComplexArray | FloatArray
                      ) -> list[str] | None:
    """Name vehicle modes by the shape of their carbody part, None for a non-shell carbody.

    Each column of ``Qc`` (carbody coordinates, complex eigenvector parts allowed: turned to
    their largest real part) is recovered on the shell and named by
    :func:`~modal_twin.models.carbody_modes.name_modes`; a rigid one by its largest
    rigid motion's kinetic energy (``surge .. yaw`` about ``G``).
    """
    src = carbody.source
    if not isinstance(src, ShellCarbody):
        return None
    Qz = np.atleast_2d(np.asarray(Qc))
    if np.iscomplexobj(Qz):
        top = Qz[np.argmax(np.abs(Qz), axis=0), np.arange(Qz.shape[1])]
        Qz = Qz * (np.abs(top) / np.where(top == 0, 1.0, top))
    Q = np.asarray(Qz.real, dtype=np.float64)
    named = name_modes(src.car, np.asarray(f_hz, dtype=float), src.recover(Q))
    assert carbody.motion is not None
    rig = carbody.motion[:6] @ Q
    energy = np.diag(src.rigid_mass)[:, None] * rig ** 2
    return [_RIGID_NAMES[int(np.argmax(energy[:, j]))] if m.kind == "rigid" else m.label
            for j, m in enumerate(named)]


_CACHE: dict[str, tuple[CarbodyFE, CBReduction]] = {}
_CACHE_SIZE = 2


def reduced_shell(params: CarbodyParams, f_cut_hz: float) -> tuple[CarbodyFE, CBReduction]:
    """Build and Craig-Bampton reduce the shell carbody; the last two are kept in memory."""
    key = f"{params!r} f_cut={f_cut_hz!r}"
    if key not in _CACHE:
        car = build_carbody(params)
        cb = reduce_carbody(car, f_cut_hz=f_cut_hz)
        while len(_CACHE) >= _CACHE_SIZE:
            _CACHE.pop(next(iter(_CACHE)))
        _CACHE[key] = (car, cb)
    return _CACHE[key]


def vehicle_shell_carbody(spec: Vehicle3DSpec) -> ReducedCarbody:
    """Return the shell carbody of a 3D vehicle spec (``spec.shell``; module docstring).

    The seats take the air springs' half spacing, the underframe sits at the seat height,
    the floor points are the spec's.
    """
    sh = spec.shell
    params = replace(sh.params, seat_half_spacing=spec.v("secondary", "half_spacing"),
                     pivot_spacing=spec.v("carbody", "pivot_spacing"),
                     length=spec.v("carbody", "length"))
    hung = spec.hung_equipment
    if hung:  # the vehicle's boxes replace the shell's items of their names
        names = {e.name for e in hung}
        params = replace(params, equipment=tuple(
            e for e in params.equipment if e.name not in names) + hung,
            hung_outside=tuple(e.name for e in hung))
    car, cb = reduced_shell(params, sh.f_cut_hz)
    state = "in service" if params.in_service else "empty"
    return shell_carbody(car, cb, points={p.label: (p.x, p.y) for p in spec.floor_points},
                         z0=spec.v("secondary", "seat_height"), zeta=sh.zeta,
                         f_keep_hz=sh.f_keep_hz, name=f"shell ({state}, CB)",
                         hung=params.hung_outside)
