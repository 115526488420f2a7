"""Sparse assembly and constraint elimination of an :class:`~.model.FEModel`.

Element terms are gathered in COO triplets and summed into CSR matrices. Supports and
rigid links (master-slave) are eliminated with one sparse transformation ``T`` of shape
``(n_full, n_free)``: ``u_full = T u``, so that ``K = T' K_full T`` (likewise ``M``, ``C`` and
every parameter derivative). Fixed DOFs are zero rows of ``T``; a slave DOF's row holds its
master coefficients (chains of links are resolved; cycles are refused).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from modal_twin._types import FloatArray, IntArray
from modal_twin.errors import ModelError, ShapeError
from modal_twin.models.fe.elements import DOF_NAMES
from modal_twin.models.fe.parametric import Kind, ParametricMatrices

if TYPE_CHECKING:
    from modal_twin.models.fe.model import Contribution, NodeId

__all__ = ["FEAssembly", "assemble_model"]


@dataclass(frozen=True, slots=True)
class FEAssembly:
    """Assembled model: reduced (free) matrices, full matrices and the DOF maps.

    Attributes
    ----------
    nodes : tuple of NodeId
        Node ids; node ``p`` owns full DOFs ``6 p .. 6 p + 5``.
    xyz : (n_nodes, 3) float array
        Node coordinates, m.
    K, M, C : (n, n) scipy.sparse.csr_array
        Nominal stiffness (N/m), mass (kg) and damping (N s/m) on the free DOFs.
    K_full, M_full, C_full : (n_full, n_full) scipy.sparse.csr_array
        The same before supports and rigid links.
    T : (n_full, n) scipy.sparse.csr_array
        ``u_full = T @ u`` (fixed DOFs: zero rows; slaves: their master coefficients).
    free_dofs : (n,) int array
        Full index of each free DOF.
    parametric : ParametricMatrices
        ``K(theta)``, ``dK(i)``, ... on the free DOFs (Sec. 4 of [004]).
    """

    nodes: tuple[NodeId, ...]
    xyz: FloatArray
    K: sp.csr_array
    M: sp.csr_array
    C: sp.csr_array
    K_full: sp.csr_array
    M_full: sp.csr_array
    C_full: sp.csr_array
    T: sp.csr_array
    free_dofs: IntArray

    parametric: ParametricMatrices

    @property
    def n_dof(self) -> int:
        """Number of free DOFs."""
        return int(self.free_dofs.size)

    def full_dof_index(self, node: NodeId, name: str) -> int:
        """Return the full DOF index of ``(node, name)``."""
        try:
            p = self.nodes.index(node)
        except ValueError:
            msg = f"node: unknown node id {node!r}"
            raise ModelError(msg) from None
        if name not in DOF_NAMES:
            msg = f"dof of node {node!r}: expected one of {list(DOF_NAMES)}, got {name!r}"
            raise ModelError(msg)
        return 6 * p + DOF_NAMES.index(name)

    def dof_index(self, node: NodeId, name: str) -> int:
        """Return the free DOF index of ``(node, name)``; fixed or slave DOFs raise."""
        full = self.full_dof_index(node, name)
        pos = int(np.searchsorted(self.free_dofs, full))
        if pos >= self.free_dofs.size or self.free_dofs[pos] != full:
            msg = f"dof {node!r}:{name}: expected a free DOF, got a fixed or slave DOF"
            raise ModelError(msg)
        return pos

    def dof_labels(self) -> list[tuple[NodeId, str]]:
        """Return ``(node, dof name)`` of every free DOF, in order."""
        return [(self.nodes[d // 6], DOF_NAMES[d % 6]) for d in self.free_dofs.tolist()]

    def expand(self, u: FloatArray) -> FloatArray:
        """Return full DOF vectors ``T @ u`` for free DOF vectors ``u`` ((n,) or (n, k))."""
        arr = np.asarray(u, dtype=float)
        if arr.shape[0] != self.n_dof:
            msg = f"u: expected first dimension {self.n_dof}, got shape {arr.shape}"
            raise ShapeError(msg)
        return np.asarray(self.T @ arr)

    def rigid_body_modes(self, ref: Sequence[float] | FloatArray = (0.0, 0.0, 0.0), *,
                         full: bool = False) -> FloatArray:
        """Return the six rigid-body vectors (translations x, y, z; rotations about ref).

        Returns
        -------
        (n, 6) float array
            On the free DOFs, or on all ``n_full`` DOFs when ``full``.
        """
        d = self.xyz - np.asarray(ref, dtype=float)
        n_nodes = len(self.nodes)
        rb = np.zeros((n_nodes, 6, 6))
        for j in range(3):
            e = np.zeros(3)
            e[j] = 1.0
            rb[:, j, j] = 1.0
            rb[:, :3, 3 + j] = np.cross(e, d)
            rb[:, 3 + j, 3 + j] = 1.0
        out = rb.reshape(6 * n_nodes, 6)
        return out if full else out[self.free_dofs]

    def rigid_body_mass(self, ref: Sequence[float] = (0.0, 0.0, 0.0)) -> FloatArray:
        """Return the 6x6 rigid-body mass ``R' M_full R`` about ``ref`` (kg, kg m, kg m^2)."""
        rb = self.rigid_body_modes(ref, full=True)
        return np.asarray(rb.T @ (self.M_full @ rb))

    def total_mass(self) -> float:
        """Return the total mass (kg), supported DOFs included."""
        return float(self.rigid_body_mass()[0, 0])


def _coo(n: int, terms: list[Contribution], scale: bool) -> sp.csr_array:
    if not terms:
        return sp.csr_array((n, n), dtype=float)
    rows = np.concatenate([np.repeat(t.dofs, t.dofs.size) for t in terms])
    cols = np.concatenate([np.tile(t.dofs, t.dofs.size) for t in terms])
    vals = np.concatenate([(t.unit * (t.value if scale else 1.0)).ravel() for t in terms])
    mat = sp.coo_array((vals, (rows, cols)), shape=(n, n)).tocsr()
    mat.eliminate_zeros()
    return sp.csr_array(mat)


def _transformation(n_full: int, fixed: frozenset[int], slaves: dict[int, list[tuple[int, float]]],
                    label: list[str]) -> tuple[sp.csr_array, IntArray]:
    """Return ``T`` and the free DOFs; resolve chains of slaves to independent masters."""
    for s in slaves:
        if s in fixed:
            msg = f"constraints: DOF {label[s]} is both fixed and a slave of a rigid link"
            raise ModelError(msg)
    resolved: dict[int, dict[int, float]] = {}

    def resolve(dof: int, stack: tuple[int, ...]) -> dict[int, float]:
        if dof not in slaves:
            return {} if dof in fixed else {dof: 1.0}
        if dof in resolved:
            return resolved[dof]
        if dof in stack:
            msg = f"constraints: a cycle of rigid links passes through DOF {label[dof]}"
            raise ModelError(msg)
        acc: dict[int, float] = {}
        for master, coef in slaves[dof]:
            for m2, c2 in resolve(master, (*stack, dof)).items():
                acc[m2] = acc.get(m2, 0.0) + coef * c2
        resolved[dof] = acc
        return acc

    free = np.array([d for d in range(n_full) if d not in fixed and d not in slaves],
                    dtype=np.int64)
    col_of = {int(d): j for j, d in enumerate(free)}
    rows, cols, vals = [], [], []
    for d in range(n_full):
        for m, c in resolve(d, ()).items():
            rows.append(d)
            cols.append(col_of[m])
            vals.append(c)
    T = sp.coo_array((vals, (rows, cols)), shape=(n_full, free.size)).tocsr()
    return sp.csr_array(T), free


def _project(T: sp.csr_array, A: sp.csr_array) -> sp.csr_array:
    out = sp.csr_array(T.T @ A @ T)
    return sp.csr_array(0.5 * (out + out.T))


def assemble_model(*, nodes: tuple[NodeId, ...], xyz: FloatArray,
                   contributions: tuple[Contribution, ...], fixed: frozenset[int],
                   slaves: dict[int, list[tuple[int, float]]]) -> FEAssembly:
    """Assemble an :class:`FEAssembly` from the builder's records (see :class:`.FEModel`)."""
    n_full = 6 * len(nodes)
    if n_full == 0:
        msg = "model: expected at least one node, got none"
        raise ModelError(msg)
    label = [f"{nodes[d // 6]!r}:{DOF_NAMES[d % 6]}" for d in range(n_full)]
    full = {k: _coo(n_full, [t for t in contributions if t.kind == k and t.nominal], True)
            for k in "KMC"}
    names: list[str] = []
    kinds: list[Kind] = []
    theta0: list[float] = []
    groups: dict[str, list[Contribution]] = {}
    for t in contributions:
        if t.param is None:
            continue
        if t.param not in groups:
            names.append(t.param)
            kinds.append(t.kind)
            theta0.append(t.value)
            groups[t.param] = []
        i = names.index(t.param)
        if t.kind != kinds[i]:
            msg = f"parameter {t.param!r}: enters both {kinds[i]} and {t.kind}; use two names"
            raise ModelError(msg)
        if abs(t.value - theta0[i]) > 1e-12 * max(abs(theta0[i]), abs(t.value)):
            msg = (f"parameter {t.param!r}: nominal values differ between its elements "
                   f"({theta0[i]!r} and {t.value!r}); use one nominal value per name")
            raise ModelError(msg)
        groups[t.param].append(t)
    T, free = _transformation(n_full, fixed, slaves, label)
    red = {k: _project(T, full[k]) for k in "KMC"}
    diag = np.abs(red["K"].diagonal()) + np.abs(red["M"].diagonal()) + np.abs(red["C"].diagonal())
    idle = [label[free[j]] for j in np.flatnonzero(diag == 0.0)]
    if idle:
        msg = (f"model: {len(idle)} free DOF(s) have neither stiffness nor mass, e.g. "
               f"{idle[:6]}; fix them or connect them")
        raise ModelError(msg)
    derivs = tuple(_project(T, _coo(n_full, groups[n], False)) for n in names)
    par = ParametricMatrices(
        names=tuple(names), kinds=tuple(kinds), theta0=np.array(theta0, dtype=float),
        K0=red["K"], M0=red["M"], C0=red["C"], derivatives=derivs)
    return FEAssembly(
        nodes=nodes, xyz=np.asarray(xyz, dtype=float), K=red["K"], M=red["M"], C=red["C"],
        K_full=full["K"], M_full=full["M"], C_full=full["C"], T=T, free_dofs=free,
        parametric=par)
