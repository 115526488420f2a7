"""Model summary: DOF count, total mass, lowest modes with frequency, damping and direction.

The dominant direction of a mode is read from its kinetic-energy split. Nodes are grouped
(one group per rigid floor; a node outside every group is its own group). For each group
with translational masses ``m_i`` at plan positions ``(x_i, y_i)`` and rotary inertias
``J_i`` about z, the mode's in-plane motion is fitted by a rigid motion of the group's
centre of mass (mass-weighted least squares, exact for a rigid diaphragm)::

    u_c = sum m_i u_i / m,   v_c = sum m_i v_i / m,
    theta = [sum m_i ((x_i - x_c) v_i - (y_i - y_c) u_i) + sum J_i rz_i] / J_c

and the energies ``E_x = m u_c^2``, ``E_y = m v_c^2``, ``E_t = J_c theta^2`` (torsion) and
``E_z = sum m_i w_i^2`` are summed over groups and normalised to fractions. The label is
the largest of x, y, z, torsion.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.errors import ShapeError
from modal_twin.models.fe import FEAssembly, NodeId

__all__ = ["DIRECTIONS", "ModeInfo", "ModelInfo", "direction_fractions", "model_info"]

DIRECTIONS: tuple[str, ...] = ("x", "y", "z", "torsion")
"""Labels of the energy fractions, in column order."""


@dataclass(frozen=True, slots=True)
class ModeInfo:
    """One mode of the summary.

    Attributes
    ----------
    number : int
        1-based mode number.
    f_hz : float
        Natural frequency, Hz.
    zeta : float
        Damping ratio (fraction; NaN if not given).
    direction : str
        Dominant direction, one of :data:`DIRECTIONS`.
    fractions : (4,) float array
        Kinetic-energy fractions in x, y, z, torsion (sum 1).
    """

    number: int
    f_hz: float
    zeta: float
    direction: str
    fractions: FloatArray


@dataclass(frozen=True, slots=True)
class ModelInfo:
    """Summary of a structural model.

    Attributes
    ----------
    name : str
    n_dof : int
        Free DOFs.
    n_dof_full : int
        DOFs before supports and constraints (6 per node).
    n_nodes : int
    total_mass_kg : float
    modes : tuple of ModeInfo
    """

    name: str
    n_dof: int
    n_dof_full: int
    n_nodes: int
    total_mass_kg: float
    modes: tuple[ModeInfo, ...]

    def table(self) -> str:
        """Return a fixed-width text table of the summary."""
        head = (f"{self.name}: {self.n_nodes} nodes, {self.n_dof} free DOFs "
                f"({self.n_dof_full} full), total mass {self.total_mass_kg / 1e3:.2f} t")
        lines = [head, f"{'mode':>4} {'f [Hz]':>9} {'zeta [%]':>8} {'dir':>8} "
                       f"{'x':>5} {'y':>5} {'z':>5} {'tors':>5}"]
        for m in self.modes:
            fr = " ".join(f"{v:5.2f}" for v in m.fractions)
            lines.append(f"{m.number:>4d} {m.f_hz:9.4f} {100 * m.zeta:8.2f} "
                         f"{m.direction:>8} {fr}")
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-ready dict (plain floats, ints, strings, lists)."""
        return {
            "name": self.name, "n_dof": self.n_dof, "n_dof_full": self.n_dof_full,
            "n_nodes": self.n_nodes, "total_mass_kg": self.total_mass_kg,
            "modes": [{"number": m.number, "f_hz": m.f_hz,
                       "zeta": None if np.isnan(m.zeta) else m.zeta,
                       "direction": m.direction,
                       "fractions": dict(zip(DIRECTIONS, m.fractions.tolist(), strict=True))}
                      for m in self.modes],
        }


def direction_fractions(asm: FEAssembly, Phi: FloatArray,
                        groups: Sequence[Sequence[NodeId]] = ()) -> FloatArray:
    """Return the kinetic-energy fractions (x, y, z, torsion) of each mode (module docstring).

    Parameters
    ----------
    asm : FEAssembly
    Phi : (n, r) float array
        Mode shapes on the free DOFs.
    groups : sequence of node sequences
        Rigid floors; other nodes with mass are single-node groups.

    Returns
    -------
    (r, 4) float array
        Rows sum to 1 (a mode without translational mass motion gives zeros).

    Raises
    ------
    ShapeError
        ``Phi`` not (n, r).
    """
    Phi = np.asarray(Phi, dtype=float)
    if Phi.ndim != 2 or Phi.shape[0] != asm.n_dof:
        msg = f"Phi: expected ({asm.n_dof}, r), got {Phi.shape}"
        raise ShapeError(msg)
    U = asm.expand(Phi).reshape(len(asm.nodes), 6, -1)
    md = asm.M_full.diagonal().reshape(-1, 6)
    m, jz = md[:, 0], md[:, 5]
    index = {n: i for i, n in enumerate(asm.nodes)}
    grouped = [np.array([index[n] for n in g], dtype=np.int64) for g in groups]
    seen = set(np.concatenate(grouped).tolist()) if grouped else set()
    grouped += [np.array([i]) for i in range(len(asm.nodes)) if i not in seen and m[i] > 0]
    E = np.zeros((Phi.shape[1], 4))
    for g in grouped:
        mg = m[g]
        mt = float(mg.sum())
        if mt <= 0.0:
            continue
        xy = asm.xyz[g, :2]
        c = (mg[:, None] * xy).sum(0) / mt
        d = xy - c
        Jc = float((mg * (d**2).sum(1)).sum() + jz[g].sum())
        u, v, w, rz = U[g, 0], U[g, 1], U[g, 2], U[g, 5]
        uc = (mg[:, None] * u).sum(0) / mt
        vc = (mg[:, None] * v).sum(0) / mt
        E[:, 0] += mt * uc**2
        E[:, 1] += mt * vc**2
        E[:, 2] += (mg[:, None] * w**2).sum(0)
        if Jc > 0.0:
            th = ((mg[:, None] * (d[:, :1] * v - d[:, 1:] * u)).sum(0)
                  + (jz[g][:, None] * rz).sum(0)) / Jc
            E[:, 3] += Jc * th**2
    tot = E.sum(1, keepdims=True)
    return np.divide(E, tot, out=np.zeros_like(E), where=tot > 0)


def model_info(asm: FEAssembly, f_hz: FloatArray, Phi: FloatArray,
               zeta: FloatArray | None = None, *, groups: Sequence[Sequence[NodeId]] = (),
               name: str = "model", n_show: int | None = None) -> ModelInfo:
    """Summarise a model and its lowest modes.

    Parameters
    ----------
    asm : FEAssembly
    f_hz : (r,) float array
        Natural frequencies, Hz.
    Phi : (n, r) float array
        Mode shapes (free DOFs).
    zeta : (r,) float array, optional
        Damping ratios (fractions).
    groups : sequence of node sequences
        Rigid floors (see :func:`direction_fractions`).
    name : str
    n_show : int, optional
        Number of modes listed (default all).

    Returns
    -------
    ModelInfo

    Raises
    ------
    ShapeError
        Inconsistent ``f_hz``, ``Phi``, ``zeta``.

    Examples
    --------
    >>> from modal_twin.models.fe import FEModel, solve_modes
    >>> fem = FEModel(); _ = fem.add_node(0, (0, 0, 0))
    >>> _ = fem.add_mass(0, 2.0, inertia=(1, 1, 1)); _ = fem.add_spring(0, k=[8, 8, 8, 8, 8, 1])
    >>> asm = fem.assemble(); sol = solve_modes(asm.K, asm.M, 6)
    >>> info = model_info(asm, sol.f_hz, sol.Phi)
    >>> info.modes[0].direction, round(info.modes[0].f_hz * 2 * 3.141592653589793, 6)
    ('torsion', 1.0)
    """
    f = np.asarray(f_hz, dtype=float).ravel()
    if np.shape(Phi) != (asm.n_dof, f.size):
        msg = f"Phi: expected ({asm.n_dof}, {f.size}), got {np.shape(Phi)}"
        raise ShapeError(msg)
    z = np.full(f.size, np.nan) if zeta is None else np.asarray(zeta, dtype=float).ravel()
    if z.size != f.size:
        msg = f"zeta: expected {f.size} values, got {z.size}"
        raise ShapeError(msg)
    fr = direction_fractions(asm, Phi, groups)
    k = f.size if n_show is None else min(int(n_show), f.size)
    modes = tuple(ModeInfo(number=j + 1, f_hz=float(f[j]), zeta=float(z[j]),
                           direction=DIRECTIONS[int(np.argmax(fr[j]))], fractions=fr[j])
                  for j in range(k))
    return ModelInfo(name=name, n_dof=asm.n_dof, n_dof_full=6 * len(asm.nodes),
                     n_nodes=len(asm.nodes), total_mass_kg=asm.total_mass(), modes=modes)
