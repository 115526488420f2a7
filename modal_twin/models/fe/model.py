"""FE model builder: nodes, frames, springs, dashpots, masses, rigid links, supports.

Every node carries six DOFs ``ux, uy, uz, rx, ry, rz`` (global axes). Element matrices are
computed when an element is added, so bad input fails at the call that brought it. Each
matrix contribution is stored as ``value * unit`` where ``value`` is a physical parameter
(a modulus, a density, a spring rate, a mass); a contribution may be tied to a named
parameter, which gives the parametric matrices of Sec. 4 of [004]
(``K = K0 + sum_i K_i (theta_i - theta_i0)``, exact because each matrix is linear in its
parameter). :meth:`FEModel.assemble` builds the sparse matrices (COO -> CSR) and the
constraint transformation (supports and rigid links) in :mod:`.assembly`.

References
----------
[004] Base-isolated E-Defense building, Sec. 4 (parametric stiffness).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np

from modal_twin._types import FloatArray, IntArray
from modal_twin.errors import ModelError
from modal_twin.models.fe.elements import (
    DOF_NAMES,
    MassKind,
    frame_local_matrices,
    frame_rotation,
    rotate_to_global,
    section_check,
    two_node_matrix,
)

if TYPE_CHECKING:
    from modal_twin.models.fe.assembly import FEAssembly

__all__ = ["Contribution", "FEModel", "NodeId", "rigid_body_mass_block", "skew"]

NodeId = int | str
MatrixKind = Literal["K", "M", "C"]


@dataclass(frozen=True, slots=True)
class Contribution:
    """One term ``value * unit`` added to matrix ``kind`` on the full DOFs ``dofs``.

    ``param`` names the parameter ``theta`` the term is linear in (``None``: constant).
    ``nominal=False`` marks an *increment* term: it is left out of the nominal matrices and
    only gives the derivative ``unit`` of a scale factor ``theta`` (nominal ``value``), so
    ``K(theta) = K0 + unit (theta - value)`` (element-group parameters).
    """

    kind: MatrixKind
    dofs: IntArray
    unit: FloatArray
    value: float
    param: str | None
    nominal: bool = True


def skew(r: FloatArray) -> FloatArray:
    """Return the cross-product matrix ``S(r)``: ``S(r) @ a == np.cross(r, a)``."""
    x, y, z = (float(v) for v in r)
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def rigid_body_mass_block(r: FloatArray, J: FloatArray, m: float = 1.0) -> FloatArray:
    """Return the 6x6 mass of a body.

    (mass ``m``, rotary inertia ``J`` about its centre) at offset ``r`` from a reference point,
    on the point's ``(u, theta)``.

    ``[[m I, -m S(r)], [m S(r), J - m S(r)^2]]`` (see :meth:`FEModel.add_point_mass`).

    """
    S = skew(np.asarray(r, dtype=float))
    out = np.zeros((6, 6))
    out[:3, :3] = m * np.eye(3)
    out[:3, 3:] = -m * S
    out[3:, :3] = m * S
    out[3:, 3:] = np.asarray(J, dtype=float) - m * S @ S
    return out


def _check_param_name(arg: str, name: str | None) -> None:
    if name is not None and (not isinstance(name, str) or not name):
        msg = f"{arg}: expected a non-empty parameter name, got {name!r}"
        raise ModelError(msg)


class FEModel:
    """Builder of a sparse 3D frame / spring / mass model.

    Examples
    --------
    >>> fem = FEModel()
    >>> _ = fem.add_node(0, (0.0, 0.0, 0.0)), fem.add_node(1, (2.0, 0.0, 0.0))
    >>> _ = fem.add_frame(0, 1, E=210e9, G=81e9, A=1e-3, Iy=1e-6, Iz=1e-6, J=2e-6, rho=7850)
    >>> fem.fix(0)
    >>> asm = fem.assemble()
    >>> asm.K.shape
    (6, 6)
    """

    def __init__(self) -> None:
        self._xyz: dict[NodeId, FloatArray] = {}
        self._index: dict[NodeId, int] = {}
        self._contribs: list[Contribution] = []
        # frame / spring number -> indices of its stiffness terms in _contribs
        self._frame_k: list[list[int]] = []
        self._spring_k: list[list[int]] = []
        self._fixed: set[int] = set()
        # slave full DOF -> list of (master full DOF, coefficient)
        self._slaves: dict[int, list[tuple[int, float]]] = {}
        self.n_frames = 0
        self.n_springs = 0
        self.n_masses = 0

    # ------------------------------------------------------------------ nodes and DOFs
    @property
    def nodes(self) -> tuple[NodeId, ...]:
        """Node ids in creation order (the order of the full DOF vector)."""
        return tuple(self._index)

    @property
    def n_dof_full(self) -> int:
        """Number of full DOFs (6 per node)."""
        return 6 * len(self._index)

    def xyz(self, node: NodeId) -> FloatArray:
        """Return the coordinates (m) of ``node``."""
        self._node_index(node)
        return self._xyz[node].copy()

    def add_node(self, node: NodeId, xyz: Sequence[float] | FloatArray) -> NodeId:
        """Add a node ``node`` (int or str id) at ``xyz`` (m); return its id."""
        if not isinstance(node, int | str) or isinstance(node, bool):
            msg = f"node: expected an int or str id, got {node!r}"
            raise ModelError(msg)
        if node in self._index:
            msg = f"node: id {node!r} already exists"
            raise ModelError(msg)
        p = np.asarray(xyz, dtype=float)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            msg = f"xyz of node {node!r}: expected 3 finite coordinates, got {xyz!r}"
            raise ModelError(msg)
        self._index[node] = len(self._index)
        self._xyz[node] = p
        return node

    def _node_index(self, node: NodeId) -> int:
        try:
            return self._index[node]
        except (KeyError, TypeError):
            msg = f"node: unknown node id {node!r} ({len(self._index)} nodes defined)"
            raise ModelError(msg) from None

    def dof(self, node: NodeId, name: str) -> int:
        """Return the full DOF index of DOF ``name`` (``"ux"`` ... ``"rz"``) of ``node``."""
        base = 6 * self._node_index(node)
        if name not in DOF_NAMES:
            msg = f"dof of node {node!r}: expected one of {list(DOF_NAMES)}, got {name!r}"
            raise ModelError(msg)
        return base + DOF_NAMES.index(name)

    def _node_dofs(self, node: NodeId) -> IntArray:
        return 6 * self._node_index(node) + np.arange(6, dtype=np.int64)

    def _add(self, kind: MatrixKind, dofs: IntArray, unit: FloatArray, value: float,
             param: str | None) -> int:
        self._contribs.append(Contribution(kind, dofs, unit, float(value), param))
        return len(self._contribs) - 1

    # ------------------------------------------------------------------ elements
    def add_frame(
        self, n1: NodeId, n2: NodeId, *, E: float, G: float, A: float, Iy: float,
        Iz: float, J: float, rho: float, orientation: Sequence[float] | None = None,
        Asy: float | None = None, Asz: float | None = None, mass: MassKind = "consistent",
        E_param: str | None = None, rho_param: str | None = None,
    ) -> int:
        """Add a 3D frame element from ``n1`` to ``n2``; return its frame number.

        Parameters
        ----------
        n1, n2 : NodeId
            End nodes (must exist).
        E, G : float
            Young's and shear moduli, Pa (> 0).
        A, Iy, Iz, J : float
            Area (m^2), second moments about local y and z (m^4), torsion constant (m^4).
        rho : float
            Density, kg/m^3 (>= 0).
        orientation : (3,) sequence, optional
            A vector in the local x-y plane (see :func:`.elements.frame_rotation`).
        Asy, Asz : float, optional
            Effective shear areas (``kappa A``, m^2); given -> Timoshenko in that plane.
        mass : {"consistent", "lumped"}
            Mass formulation.
        E_param : str, optional
            Parameter name for this element's modulus. The element stiffness is recorded as
            ``E * (k / E)``: a change of ``E`` scales ``G`` with it (fixed Poisson ratio),
            which keeps the Timoshenko matrix linear in ``E``. Elements sharing a name must
            share the nominal ``E``.
        rho_param : str, optional
            Parameter name for the density (mass matrix linear in ``rho``).

        Returns
        -------
        int
            Frame number (0-based, in order of addition).

        Raises
        ------
        ModelError
            Unknown node, zero length, a non-positive property, a bad orientation.
        """
        k_unit, m_unit = self._frame_units(
            n1, n2, E=E, G=G, A=A, Iy=Iy, Iz=Iz, J=J, rho=rho, orientation=orientation,
            Asy=Asy, Asz=Asz, mass=mass, E_param=E_param, rho_param=rho_param)
        return self._record_frame(n1, n2, k_unit, m_unit, E=E, rho=rho, E_param=E_param,
                                  rho_param=rho_param)

    def _frame_units(
        self, n1: NodeId, n2: NodeId, *, E: float, G: float, A: float, Iy: float, Iz: float,
        J: float, rho: float, orientation: Sequence[float] | None, Asy: float | None,
        Asz: float | None, mass: MassKind, E_param: str | None, rho_param: str | None,
    ) -> tuple[FloatArray, FloatArray]:
        """Return validated global ``k / E`` and ``m / rho`` (12 x 12) of a frame ``n1``-``n2``."""
        label = f"frame {self.n_frames} ({n1!r}-{n2!r})"
        section_check(label, E=E, G=G, A=A, Iy=Iy, Iz=Iz, J=J, rho=rho, Asy=Asy, Asz=Asz)
        _check_param_name("E_param", E_param)
        _check_param_name("rho_param", rho_param)
        self._node_dofs(n1), self._node_dofs(n2)  # unknown nodes raise here
        if n1 == n2:
            msg = f"{label} length: expected two distinct nodes, got {n1!r} twice"
            raise ModelError(msg)
        try:
            r, length = frame_rotation(
                self._xyz[n1], self._xyz[n2], None if orientation is None
                else np.asarray(orientation, dtype=float))
        except ModelError as err:
            msg_0 = f"{label}: {err}"
            raise ModelError(msg_0) from err
        k_loc, m_loc = frame_local_matrices(
            E=E, G=G, A=A, Iy=Iy, Iz=Iz, J=J, rho=rho, length=length, Asy=Asy, Asz=Asz,
            mass=mass)
        m_unit = rotate_to_global(m_loc, r) / rho if rho > 0.0 else np.zeros((12, 12))
        return rotate_to_global(k_loc, r) / E, m_unit

    def _record_frame(self, n1: NodeId, n2: NodeId, k_unit: FloatArray, m_unit: FloatArray,
                      *, E: float, rho: float, E_param: str | None, rho_param: str | None,
                      ) -> int:
        dofs = np.concatenate([self._node_dofs(n1), self._node_dofs(n2)])
        self._frame_k.append([self._add("K", dofs, k_unit, E, E_param)])
        if rho > 0.0:
            self._add("M", dofs, m_unit, rho, rho_param)
        self.n_frames += 1
        return self.n_frames - 1

    def add_member(self, n1: NodeId, n2: NodeId, n_elements: int, **frame: object) -> list[NodeId]:
        """Mesh a straight member ``n1``-``n2`` into ``n_elements`` frames.

        Intermediate nodes get ids ``f"{n1}-{n2}:{j}"``, ``j = 1 .. n_elements - 1``.
        ``frame`` holds the keyword arguments of :meth:`add_frame`.

        Returns
        -------
        list of NodeId
            The chain of nodes from ``n1`` to ``n2``.
        """
        if not isinstance(n_elements, int) or n_elements < 1:
            msg = f"n_elements: expected an int >= 1, got {n_elements!r}"
            raise ModelError(msg)
        p1, p2 = self.xyz(n1), self.xyz(n2)
        chain: list[NodeId] = [n1]
        for j in range(1, n_elements):
            chain.append(self.add_node(f"{n1}-{n2}:{j}", p1 + (p2 - p1) * j / n_elements))
        chain.append(n2)
        # equal elements of one straight member: one rotation and one pair of element
        # matrices for all of them (a 100k-DOF mesh has ~18,000 elements)
        opts = {"orientation": None, "Asy": None, "Asz": None, "mass": "consistent",
                "E_param": None, "rho_param": None, **frame}
        k_unit, m_unit = self._frame_units(chain[0], chain[1], **opts)  # type: ignore[arg-type]
        for a, b in itertools.pairwise(chain):
            self._record_frame(a, b, k_unit, m_unit, E=opts["E"], rho=opts["rho"],  # type: ignore[arg-type]
                               E_param=opts["E_param"], rho_param=opts["rho_param"])  # type: ignore[arg-type]
        return chain

    def _six_by_six(self, arg: str, val: Mapping[str, float] | Sequence[float] | FloatArray
                    ) -> FloatArray:
        if isinstance(val, Mapping):
            out = np.zeros((6, 6))
            for name, v in val.items():
                if name not in DOF_NAMES:
                    msg = f"{arg}: expected DOF names in {list(DOF_NAMES)}, got {name!r}"
                    raise ModelError(msg)
                out[DOF_NAMES.index(name), DOF_NAMES.index(name)] = float(v)
        else:
            a = np.asarray(val, dtype=float)
            if a.shape == (6,):
                out = np.diag(a)
            elif a.shape == (6, 6):
                out = 0.5 * (a + a.T)
                if np.abs(a - a.T).max() > 1e-12 * max(np.abs(a).max(), 1e-300):
                    msg = f"{arg}: expected a symmetric (6, 6) matrix, got an asymmetric one"
                    raise ModelError(msg)
            else:
                msg = f"{arg}: expected a DOF-name mapping, (6,) or (6, 6), got {a.shape}"
                raise ModelError(msg)
        if not np.all(np.isfinite(out)) or np.any(np.diag(out) < 0.0):
            msg = f"{arg}: expected finite values with diagonal >= 0, got diag {np.diag(out)}"
            raise ModelError(msg)
        if np.linalg.eigvalsh(out).min() < -1e-12 * max(np.abs(out).max(), 1e-300):
            msg = f"{arg}: expected a positive semi-definite matrix"
            raise ModelError(msg)
        return out

    def add_spring(
        self, n1: NodeId, n2: NodeId | None = None, *,
        k: Mapping[str, float] | Sequence[float] | FloatArray | None = None,
        c: Mapping[str, float] | Sequence[float] | FloatArray | None = None,
        k_params: Mapping[str, str] | None = None, c_params: Mapping[str, str] | None = None,
        k_scale: str | None = None, c_scale: str | None = None,
    ) -> int:
        """Add a zero-length 6-DOF spring and dashpot from ``n1`` to ``n2`` (or to ground).

        Parameters
        ----------
        n1 : NodeId
            First node.
        n2 : NodeId or None
            Second node; ``None`` connects ``n1`` to ground.
        k, c : mapping DOF name -> value, (6,) or (6, 6), optional
            Stiffness (N/m, N m/rad) and damping (N s/m, N m s/rad) in global axes.
        k_params, c_params : mapping DOF name -> parameter name, optional
            Name the diagonal entry ``k[dof, dof]`` (or ``c``) as a parameter.
        k_scale, c_scale : str, optional
            Name a dimensionless factor (nominal 1) on the whole ``k`` (or ``c``) matrix of
            this element: ``K(theta) = K0 + k_el (theta - 1)`` (Sec. 4 of [004]). Elements
            sharing a name scale together. Not combined with ``k_params`` / ``c_params``.

        Returns
        -------
        int
            Spring number.

        Raises
        ------
        ModelError
            Unknown node or DOF name, negative or asymmetric values, same node twice.
        """
        label = f"spring {self.n_springs} ({n1!r}-{n2!r})"
        d1 = self._node_dofs(n1)
        grounded = n2 is None
        if n2 is not None and n2 == n1:
            msg = f"{label}: expected two distinct nodes, got {n1!r} twice"
            raise ModelError(msg)
        dofs = d1 if n2 is None else np.concatenate([d1, self._node_dofs(n2)])
        terms: list[int] = []
        for arg, val, params, scale, kind in (("k", k, k_params, k_scale, "K"),
                                              ("c", c, c_params, c_scale, "C")):
            if val is None:
                for what, given in ((f"{arg}_params", params), (f"{arg}_scale", scale)):
                    if given:
                        msg = f"{label} {what}: given without {arg}"
                        raise ModelError(msg)
                continue
            mat = self._six_by_six(f"{label} {arg}", val)
            if scale is not None:
                _check_param_name(f"{arg}_scale", scale)
                if params:
                    msg = f"{label}: give {arg}_params or {arg}_scale, not both"
                    raise ModelError(msg)
                j = self._add(kind, dofs, two_node_matrix(mat, grounded), 1.0, scale)  # type: ignore[arg-type]
                terms += [j] if kind == "K" else []
                continue
            for dof_name, pname in (params or {}).items():
                if dof_name not in DOF_NAMES:
                    msg = (f"{label} {arg}_params: expected DOF names in {list(DOF_NAMES)}, "
                           f"got {dof_name!r}")
                    raise ModelError(msg)
                _check_param_name(f"{arg}_params[{dof_name!r}]", pname)
                j = DOF_NAMES.index(dof_name)
                unit6 = np.zeros((6, 6))
                unit6[j, j] = 1.0
                i = self._add(kind, dofs, two_node_matrix(unit6, grounded), mat[j, j], pname)  # type: ignore[arg-type]
                terms += [i] if kind == "K" else []
                mat[j, j] = 0.0
            if np.any(mat != 0.0):
                i = self._add(kind, dofs, two_node_matrix(mat, grounded), 1.0, None)  # type: ignore[arg-type]
                terms += [i] if kind == "K" else []
        self._spring_k.append(terms)
        self.n_springs += 1
        return self.n_springs - 1

    def add_mass(
        self, node: NodeId, m: float, *, inertia: Sequence[float] | FloatArray | None = None,
        m_param: str | None = None,
    ) -> int:
        """Add a lumped mass ``m`` (kg) and rotary inertia at ``node``; return its number.

        ``inertia`` is ``(Jxx, Jyy, Jzz)`` or a symmetric 3x3 tensor (kg m^2, global axes,
        about the node). ``m_param`` names ``m`` as a parameter (translational part only).
        """
        label = f"mass {self.n_masses} at node {node!r}"
        dofs = self._node_dofs(node)
        if not (isinstance(m, int | float) and math.isfinite(m) and m >= 0.0):
            msg = f"{label} m: expected a finite value >= 0, got {m!r}"
            raise ModelError(msg)
        _check_param_name("m_param", m_param)
        unit = np.zeros((6, 6))
        unit[:3, :3] = np.eye(3)
        self._add("M", dofs, unit, float(m), m_param)
        if inertia is not None:
            jj = np.asarray(inertia, dtype=float)
            if jj.shape == (3,):
                jj = np.diag(jj)
            ok = jj.shape == (3, 3) and np.all(np.isfinite(jj)) and np.allclose(jj, jj.T)
            if not ok or np.linalg.eigvalsh(jj).min() < -1e-12 * np.abs(jj).max():
                msg = (f"{label} inertia: expected (3,) >= 0 or a symmetric positive "
                       f"semi-definite (3, 3), got {inertia!r}")
                raise ModelError(msg)
            rot = np.zeros((6, 6))
            rot[3:, 3:] = jj
            self._add("M", dofs, rot, 1.0, None)
        self.n_masses += 1
        return self.n_masses - 1

    def add_point_mass(
        self, node: NodeId, m: float, *, offset: Sequence[float] = (0.0, 0.0, 0.0),
        J: Sequence[float] | FloatArray | None = None, m_param: str | None = None,
    ) -> int:
        """Add a rigid body of mass ``m`` at ``offset`` from ``node``, rigidly attached to it.

        With ``r`` the offset and ``S(r)`` its cross-product matrix (``S(r) a = r x a``), the
        body's velocity is ``v = v_n - S(r) omega_n``, so its kinetic energy gives the 6x6
        mass matrix on the node's DOFs ``(u, theta)``::

            M_b = [[m I, -m S(r)], [m S(r), J - m S(r)^2]]

        (``-m S(r)^2 = m (|r|^2 I - r r')``: the parallel-axis term). The whole block is one
        term linear in ``m`` (``J`` is taken per unit mass), so ``m_param`` scales the
        translation, the eccentricity and the rotary inertia together.

        Parameters
        ----------
        node : NodeId
            Node the body is attached to (a diaphragm slave is fine: the constraint
            transformation carries the block to the master).
        m : float
            Mass, kg (> 0).
        offset : (3,) sequence
            Position of the body's centre of mass relative to ``node``, m.
        J : (3,) or (3, 3), optional
            Rotary inertia about the body's own centre of mass, kg m^2 (global axes).
        m_param : str, optional
            Parameter name of ``m``.

        Returns
        -------
        int
            Mass number.

        Raises
        ------
        ModelError
            Unknown node, ``m <= 0``, a bad offset or inertia.
        """
        label = f"mass {self.n_masses} at node {node!r}"
        dofs = self._node_dofs(node)
        if not (isinstance(m, int | float) and math.isfinite(m) and m > 0.0):
            msg = f"{label} m: expected a finite value > 0, got {m!r}"
            raise ModelError(msg)
        _check_param_name("m_param", m_param)
        r = np.asarray(offset, dtype=float)
        if r.shape != (3,) or not np.all(np.isfinite(r)):
            msg = f"{label} offset: expected 3 finite values, got {offset!r}"
            raise ModelError(msg)
        jj = np.zeros((3, 3)) if J is None else np.asarray(J, dtype=float)
        if jj.shape == (3,):
            jj = np.diag(jj)
        ok = jj.shape == (3, 3) and np.all(np.isfinite(jj)) and np.allclose(jj, jj.T)
        if not ok or np.linalg.eigvalsh(jj).min() < -1e-12 * max(np.abs(jj).max(), 1e-300):
            msg = (f"{label} J: expected (3,) >= 0 or a symmetric positive semi-definite "
                   f"(3, 3), got {J!r}")
            raise ModelError(msg)
        self._add("M", dofs, rigid_body_mass_block(r, jj / m), float(m), m_param)
        self.n_masses += 1
        return self.n_masses - 1

    def add_stiffness_group(self, param: str, *, frames: Iterable[int] = (),
                            springs: Iterable[int] = ()) -> int:
        """Name a dimensionless stiffness factor (nominal 1) of a set of elements.

        Each element's nominal stiffness ``k_e`` gets an increment term, so that
        ``K(theta) = K0 + sum_{e in group} k_e (theta - 1)`` (Sec. 4 of [004]): exact while
        the element's other parameters (its modulus) stay nominal, first order otherwise.
        An element may belong to several groups (a column line and a storey).

        Returns
        -------
        int
            Number of elements in the group.

        Raises
        ------
        ModelError
            Empty group, unknown frame or spring number, bad name.
        """
        _check_param_name("param", param)
        fr, sg = list(frames), list(springs)
        bad = ([f"frame {i}" for i in fr if not 0 <= i < self.n_frames]
               + [f"spring {i}" for i in sg if not 0 <= i < self.n_springs])
        if bad:
            msg = f"stiffness group {param!r}: unknown elements {bad}"
            raise ModelError(msg)
        idx = ([j for i in fr for j in self._frame_k[i]]
               + [j for i in sg for j in self._spring_k[i]])
        if not idx:
            msg = f"stiffness group {param!r}: expected at least one element, got none"
            raise ModelError(msg)
        for j in idx:
            t = self._contribs[j]
            self._contribs.append(Contribution("K", t.dofs, t.unit * t.value, 1.0, param,
                                               nominal=False))
        return len(fr) + len(sg)

    # ------------------------------------------------------------------ constraints
    def fix(self, node: NodeId, dofs: str | Iterable[str] = "all") -> None:
        """Fix (support) DOFs of ``node``: ``"all"`` or an iterable of DOF names."""
        names = DOF_NAMES if dofs == "all" else ([dofs] if isinstance(dofs, str) else dofs)
        for name in names:
            self._fixed.add(self.dof(node, name))

    def _tie(self, slave: int, terms: list[tuple[int, float]], label: str) -> None:
        if slave in self._slaves:
            msg = f"{label}: DOF {self._dof_label(slave)} is already a slave of a constraint"
            raise ModelError(msg)
        self._slaves[slave] = [(m, c) for m, c in terms if c != 0.0]

    def _dof_label(self, dof: int) -> str:
        return f"{self.nodes[dof // 6]!r}:{DOF_NAMES[dof % 6]}"

    def add_rigid_link(self, master: NodeId, slave: NodeId) -> None:
        """Tie all six DOFs of ``slave`` rigidly to ``master``.

        ``u_s = u_m + theta_m x (x_s - x_m)`` and ``theta_s = theta_m`` (small rotations).
        """
        dm, ds = self._node_dofs(master), self._node_dofs(slave)
        if master == slave:
            msg = f"rigid link: expected two distinct nodes, got {master!r} twice"
            raise ModelError(msg)
        dx, dy, dz = self._xyz[slave] - self._xyz[master]
        label = f"rigid link {master!r}->{slave!r}"
        # u = u_m + theta x d: ux += ry dz - rz dy; uy += rz dx - rx dz; uz += rx dy - ry dx
        self._tie(int(ds[0]), [(int(dm[0]), 1.0), (int(dm[4]), dz), (int(dm[5]), -dy)], label)
        self._tie(int(ds[1]), [(int(dm[1]), 1.0), (int(dm[5]), dx), (int(dm[3]), -dz)], label)
        self._tie(int(ds[2]), [(int(dm[2]), 1.0), (int(dm[3]), dy), (int(dm[4]), -dx)], label)
        for j in range(3, 6):
            self._tie(int(ds[j]), [(int(dm[j]), 1.0)], label)

    def add_rigid_diaphragm(
        self, master: NodeId, slaves: Iterable[NodeId], *, normal: Literal["x", "y", "z"] = "z"
    ) -> None:
        """Make a floor rigid in its plane: tie in-plane DOFs of ``slaves`` to ``master``.

        For ``normal="z"``: ``ux_s = ux_m - rz_m dy``, ``uy_s = uy_m + rz_m dx``,
        ``rz_s = rz_m``; the out-of-plane DOFs (uz, rx, ry) stay independent. All slaves
        must lie in the master's plane.
        """
        axes = {"x": (1, 2, 0), "y": (2, 0, 1), "z": (0, 1, 2)}
        if normal not in axes:
            msg = f"normal: expected one of {list(axes)}, got {normal!r}"
            raise ModelError(msg)
        a, b, n = axes[normal]
        dm = self._node_dofs(master)
        scale = max(1.0, float(np.abs(self._xyz[master]).max()))
        for s in slaves:
            ds = self._node_dofs(s)
            if s == master:
                msg = f"rigid diaphragm: slave {s!r} is the master"
                raise ModelError(msg)
            d = self._xyz[s] - self._xyz[master]
            if abs(d[n]) > 1e-9 * max(scale, float(np.abs(self._xyz[s]).max())):
                msg = (f"rigid diaphragm at {master!r}: slave {s!r} expected in the plane "
                       f"{normal} = {self._xyz[master][n]}, got {self._xyz[s][n]}")
                raise ModelError(msg)
            label = f"rigid diaphragm {master!r}->{s!r}"
            # Rotation about the normal axis n: u_a += -r_n d_b, u_b += r_n d_a.
            self._tie(int(ds[a]), [(int(dm[a]), 1.0), (int(dm[3 + n]), -d[b])], label)
            self._tie(int(ds[b]), [(int(dm[b]), 1.0), (int(dm[3 + n]), d[a])], label)
            self._tie(int(ds[3 + n]), [(int(dm[3 + n]), 1.0)], label)

    # ------------------------------------------------------------------ assembly
    def assemble(self) -> FEAssembly:
        """Assemble the sparse matrices, constraints and parametric terms.

        Returns
        -------
        FEAssembly
            See :class:`modal_twin.models.fe.assembly.FEAssembly`.
        """
        from modal_twin.models.fe.assembly import assemble_model

        return assemble_model(
            nodes=self.nodes, xyz=np.array([self._xyz[n] for n in self.nodes]).reshape(-1, 3),
            contributions=tuple(self._contribs), fixed=frozenset(self._fixed),
            slaves=dict(self._slaves))
