"""Names of carbody modes from their shapes: bending, torsion, diamond, breathing, rigid.

At each cross-section ring (station ``x_s``) the in-plane displacements ``(v_k, w_k)`` of the
ring's nodes at ``(y_k, z_k)`` (``y', z'`` about the ring's centre) are projected on six
section templates, orthonormalised in this order (Gram-Schmidt, so each is the part not
explained by the ones before)::

    lateral    (1, 0)        vertical   (0, 1)        rotation   (-z', y')
    diamond    (z', y')      (rhombic shear of the section; its rotation part removed)
    breathing  (y', z'), (y', -z')   (area change and ovalisation: floor and roof apart)

and the rest is ``local``. The squared coefficients summed over the stations give each
template's share of the mode's section motion; the largest names the mode
(``vertical`` / ``lateral`` -> bending, ``rotation`` -> torsion). Its order comes from the
sign changes of the template's coefficient along ``x`` (nodes): a free-free bending mode of
order ``n`` has ``n + 1`` nodes, torsion ``n``, diamond and breathing ``n - 1``. A mode
with more than 70 % of its kinetic energy in the equipment bodies is named after the
equipment that moves most; above 40 % a body mode's label adds ``with <equipment>``. A
mode is **rigid** when its mass-weighted projection on the six rigid-body vectors of the
node coordinates holds more than half of it: ``p' (R' M R)^-1 p > 0.5`` with ``p = R' M phi``
(a physical rule, no threshold relative to the spectrum).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modal_twin._types import BoolArray, FloatArray
from modal_twin.errors import ShapeError
from modal_twin.models.carbody3d import CarbodyFE

__all__ = [
    "SECTION_TEMPLATES",
    "CarbodyMode",
    "name_modes",
    "rigid_mode_mask",
    "section_fractions",
]

SECTION_TEMPLATES: tuple[str, ...] = ("lateral", "vertical", "rotation", "diamond",
                                      "breathing", "local")
"""Share names of :func:`section_fractions`, in column order."""

_TYPE = {"lateral": "lateral bending", "vertical": "vertical bending", "rotation": "torsion",
         "diamond": "diamond", "breathing": "breathing", "local": "local"}
_EQUIPMENT_SHARE = 0.7  # kinetic-energy share above which a mode is the equipment's
_WITH_EQUIPMENT = 0.4  # above this, the label names the equipment that moves with the body
_ORDER_SHIFT = {"lateral": -1, "vertical": -1, "rotation": 0, "diamond": 1, "breathing": 1}


@dataclass(frozen=True, slots=True)
class CarbodyMode:
    """A named carbody mode.

    Attributes
    ----------
    number : int
        1-based index among the modes given.
    f_hz : float
    kind : str
        ``"rigid"``, ``"vertical bending"``, ``"lateral bending"``, ``"torsion"``,
        ``"diamond"``, ``"breathing"``, ``"local"`` or ``"equipment"``.
    order : int
        Order of the dominant shape (0 for rigid, equipment and local modes).
    label : str
        ``kind order``, with a second share above 30 % after ``+`` (e.g.
        ``"torsion 1 + lateral bending 1"``) and ``with <equipment>`` when more than 40 %
        of the kinetic energy is in the equipment (the body moving most is named), or, for
        an equipment mode, the equipment's name.
    fractions : (6,) float array
        Shares of :data:`SECTION_TEMPLATES` (sum 1).
    equipment_share : float
        Kinetic-energy fraction in the equipment bodies.
    """

    number: int
    f_hz: float
    kind: str
    order: int
    label: str
    fractions: FloatArray
    equipment_share: float


def rigid_mode_mask(car: CarbodyFE, Phi: FloatArray) -> BoolArray:
    """Return True for modes mostly in the span of the rigid-body vectors (module docstring)."""
    asm = car.asm
    Phi = np.asarray(Phi, dtype=float)
    if Phi.ndim != 2 or Phi.shape[0] != asm.n_dof:
        msg = f"Phi: expected ({asm.n_dof}, r), got {Phi.shape}"
        raise ShapeError(msg)
    R = asm.rigid_body_modes()
    MR = np.asarray(asm.M @ R)
    G = R.T @ MR
    P = MR.T @ Phi
    norm = np.einsum("ij,ij->j", Phi, np.asarray(asm.M @ Phi))
    share = np.einsum("ij,ij->j", P, np.linalg.solve(G, P)) / norm
    return np.asarray(share > 0.5)


def _templates(yz: FloatArray) -> FloatArray:
    """Orthonormal section templates (2 n_ring, 6) (module docstring)."""
    y, z = (yz - yz.mean(axis=0)).T
    one, zero = np.ones_like(y), np.zeros_like(y)
    cols = [(one, zero), (zero, one), (-z, y), (z, y), (y, z), (y, -z)]
    B = np.column_stack([np.concatenate(c) for c in cols])
    Q, _ = np.linalg.qr(B)
    return Q


def section_fractions(car: CarbodyFE, Phi: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Return each mode's section shares (r, 6) and the coefficients (r, n_st, 6).

    The breathing share adds its two templates; its coefficient profile is the larger one.
    """
    asm = car.asm
    Phi = np.asarray(Phi, dtype=float)
    if Phi.ndim != 2 or Phi.shape[0] != asm.n_dof:
        msg = f"Phi: expected ({asm.n_dof}, r), got {Phi.shape}"
        raise ShapeError(msg)
    U = asm.expand(Phi).reshape(len(asm.nodes), 6, -1)
    index = {n: i for i, n in enumerate(asm.nodes)}
    rows = np.array([[index[n] for n in ring] for ring in car.ring])  # (n_st, n_ring)
    Q = _templates(car.ring_yz)
    vw = np.concatenate([U[rows, 1, :], U[rows, 2, :]], axis=1)  # (n_st, 2 n_ring, r)
    C = np.einsum("sjr,jt->rst", vw, Q)  # (r, n_st, 6)
    total = np.einsum("sjr,sjr->r", vw, vw)
    E = np.zeros((Phi.shape[1], 6))
    E[:, :5] = (C[:, :, :5] ** 2).sum(axis=1)
    E[:, 4] += (C[:, :, 5] ** 2).sum(axis=1)
    E[:, 5] = np.clip(total - E[:, :5].sum(axis=1), 0.0, None)
    big = np.abs(C[:, :, 5]).max(axis=1) > np.abs(C[:, :, 4]).max(axis=1)
    C[big, :, 4] = C[big, :, 5]
    tot = E.sum(axis=1, keepdims=True)
    F = np.divide(E, tot, out=np.zeros_like(E), where=tot > 0)
    return F, C[:, :, :5]


def _nodes(profile: FloatArray) -> int:
    """Sign changes of a station profile, ignoring values below 5 % of its peak."""
    peak = float(np.abs(profile).max())
    if peak == 0.0:
        return 0
    sig = np.sign(profile[np.abs(profile) > 0.05 * peak])
    return int(np.count_nonzero(sig[1:] != sig[:-1]))


def _equipment_share(car: CarbodyFE, Phi: FloatArray) -> FloatArray:
    asm = car.asm
    if not car.equipment_nodes:
        return np.zeros(Phi.shape[1])
    full = asm.expand(Phi)
    idx = [asm.full_dof_index(n, d) for n in car.equipment_nodes.values()
           for d in ("ux", "uy", "uz", "rx", "ry", "rz")]
    Mq = asm.M_full[idx][:, idx].toarray()
    eq = full[idx]
    norm = np.einsum("ij,ij->j", full, np.asarray(asm.M_full @ full))
    return np.asarray(np.einsum("ij,ij->j", eq, Mq @ eq) / norm)


def name_modes(car: CarbodyFE, f_hz: FloatArray, Phi: FloatArray) -> list[CarbodyMode]:
    """Name each mode of ``car`` (module docstring).

    Parameters
    ----------
    car : CarbodyFE
    f_hz : (r,) float array
        Natural frequencies, Hz.
    Phi : (n, r) float array
        Mode shapes on the free DOFs of ``car.asm``.

    Returns
    -------
    list of CarbodyMode

    Raises
    ------
    ShapeError
        ``Phi`` does not match the model or ``f_hz``.
    """
    f = np.asarray(f_hz, dtype=float).ravel()
    Phi = np.asarray(Phi, dtype=float)
    if Phi.ndim != 2 or Phi.shape[1] != f.size:
        msg = f"Phi: expected (n, {f.size}), got {Phi.shape}"
        raise ShapeError(msg)
    rigid = rigid_mode_mask(car, Phi)
    F, C = section_fractions(car, Phi)
    eq = _equipment_share(car, Phi)
    out: list[CarbodyMode] = []
    for j in range(f.size):
        if rigid[j]:
            kind, order, label = "rigid", 0, "rigid"
        elif eq[j] > _EQUIPMENT_SHARE:
            name = _dominant_equipment(car, Phi[:, j])
            kind, order, label = "equipment", 0, f"equipment {name}"
        else:
            rank = np.argsort(F[j])[::-1]
            parts: list[tuple[str, int]] = []
            for t in rank[:2]:
                tname = SECTION_TEMPLATES[t]
                if parts and F[j, t] < 0.3:
                    break
                if tname == "local":
                    parts.append(("local", 0))
                    continue
                n = _nodes(C[j, :, t])
                parts.append((_TYPE[tname], max(1, n + _ORDER_SHIFT[tname])))
            kind, order = parts[0]
            label = " + ".join(k if o == 0 else f"{k} {o}" for k, o in parts)
            if eq[j] > _WITH_EQUIPMENT:
                label += f" with {_dominant_equipment(car, Phi[:, j])}"
        out.append(CarbodyMode(number=j + 1, f_hz=float(f[j]), kind=kind, order=order,
                               label=label, fractions=F[j], equipment_share=float(eq[j])))
    return out


def _dominant_equipment(car: CarbodyFE, phi: FloatArray) -> str:
    asm = car.asm
    full = asm.expand(phi[:, None])[:, 0]
    best, name = -1.0, ""
    for eq_name, node in car.equipment_nodes.items():
        i = [asm.full_dof_index(node, d) for d in ("ux", "uy", "uz")]
        m = float(asm.M_full[i[0], i[0]])
        e = m * float(np.sum(full[i] ** 2))
        if e > best:
            best, name = e, eq_name
    return name
