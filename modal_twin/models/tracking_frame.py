r"""A small tracking frame with contact stiffnesses, as the theodolite frame of [000].

A plane frame in x-z (DOFs ``ux``, ``uz``, ``ry`` per node; DOF labels ``"<node>:x"``,
``"<node>:z"``, ``"<node>:ry"``): a base beam held at its centre (the azimuth bearing),
two arms standing on its ends, and the horizontal axis carried by the arm tops with the
instrument's mass at its middle and the elevation motor's on the right arm (the
asymmetry keeps the two arms' modes apart). As in [000] (section 3, the parametric FE model), the
joints are not rigid: the arm feet sit on the base through a **contact stiffness**
(translational and rotational springs between coincident nodes, ``feet``) and the axis
sits in the arm tops through **bearings** (translational springs, free rotation,
``bearings``). Their stiffnesses are the model's parameters:

.. math::
   K(\theta) = K_{beams} + \sum_j (1 + \theta_j) K_j,

with :math:`K_j` the nominal springs of joint group ``j`` (``theta_j = 0``: nominal;
``-0.3``: 30 % softer). Beams are 3D frame elements
(:func:`~modal_twin.models.fe.elements.frame_local_matrices`) kept to their in-plane DOFs.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.errors import ModelError
from modal_twin.models.fe.elements import frame_local_matrices, frame_rotation, rotate_to_global

__all__ = ["JOINTS", "FrameSpec", "frame_matrices", "frame_outline"]

JOINTS = ("feet", "bearings")
"""The contact stiffness groups (the parameters), in order."""
_PLANE = np.array([0, 2, 4])  # ux, uz, ry of a node among its 6 DOFs


@dataclass(frozen=True, slots=True)
class FrameSpec:
    """Dimensions, sections and nominal contact stiffnesses of the frame (SI units)."""

    half_width_m: float = 0.3
    height_m: float = 0.5
    elements: int = 3               # beam elements per half base, per arm, per half axis
    E_pa: float = 2.1e11
    G_pa: float = 8.1e10
    rho_kg_m3: float = 7850.0
    base: tuple[float, float] = (1.1e-3, 5.5e-7)   # area m^2, second moment m^4
    arm: tuple[float, float] = (8.0e-4, 2.5e-7)
    axis: tuple[float, float] = (6.0e-4, 1.5e-7)
    instrument_kg: float = 6.0
    motor_kg: float = 2.5            # the elevation motor on the right arm's top
    foot_n_m: float = 5.0e7          # translational contact stiffness of a foot
    foot_nm_rad: float = 4.0e4       # rotational contact stiffness of a foot
    bearing_n_m: float = 2.0e6       # translational stiffness of an axis bearing


def _beam(K: FloatArray, M: FloatArray, idx: Mapping[int, int], n1: int, n2: int,
          xyz: Mapping[int, FloatArray], section: tuple[float, float], s: FrameSpec) -> None:
    r, length = frame_rotation(xyz[n1], xyz[n2], np.array([0.0, 1.0, 0.0]))  # local y = Y
    A, inertia = section
    k, m = frame_local_matrices(E=s.E_pa, G=s.G_pa, A=A, Iy=inertia, Iz=inertia,
                                J=2 * inertia, rho=s.rho_kg_m3, length=length)
    sel = np.concatenate([_PLANE, 6 + _PLANE])
    kg, mg = rotate_to_global(k, r)[np.ix_(sel, sel)], rotate_to_global(m, r)[np.ix_(sel, sel)]
    dofs = [idx[n1] + d for d in range(3)] + [idx[n2] + d for d in range(3)]
    ok = [i for i, d in enumerate(dofs) if d >= 0]
    sub = np.array(dofs)[ok]
    K[np.ix_(sub, sub)] += kg[np.ix_(ok, ok)]
    M[np.ix_(sub, sub)] += mg[np.ix_(ok, ok)]


def _spring(K: FloatArray, idx: Mapping[int, int], n1: int, n2: int,
            k3: tuple[float, float, float]) -> None:
    for d, kd in enumerate(k3):
        a, b = idx[n1] + d, idx[n2] + d
        for i, j, sgn in ((a, a, 1.0), (b, b, 1.0), (a, b, -1.0), (b, a, -1.0)):
            if i >= 0 and j >= 0:
                K[i, j] += sgn * kd


def frame_outline(spec: FrameSpec | None = None) -> list[int]:
    """Node numbers around the frame, closed: the base, the right arm, the axis, the left arm.

    The members' own order (base 100.., arms 200.. / 300.. upwards, axis 400..), so the nodes
    of a test on the frame joined in this order draw it (UFF 82 trace line).
    """
    n = (spec or FrameSpec()).elements
    base, axis = [100 + i for i in range(2 * n + 1)], [400 + i for i in range(2 * n + 1)]
    left, right = [200 + i for i in range(n + 1)], [300 + i for i in range(n + 1)]
    return [*base, *right, *axis[::-1], *left[::-1], base[0]]


def frame_matrices(spec: FrameSpec | None = None,
                   theta: Mapping[str, float] | None = None) -> dict[str, np.ndarray]:
    """Mass, stiffness and joint matrices of the frame (a matrix model's arrays).

    Parameters
    ----------
    theta : mapping, optional
        Relative change of each joint group's stiffness (:data:`JOINTS`; missing: 0).

    Returns
    -------
    dict
        ``M``, ``K0`` (beams plus the joints at ``theta``), ``K_<joint>`` (the nominal
        springs of each group: the parameters' matrices), ``dofs`` (labels) and
        ``node_xyz`` (``(n_nodes, 4)``: node number, x, y, z), as
        :func:`~modal_twin.models.matrix_model.load_matrix_model` reads them from ``.npz``.

    Raises
    ------
    ModelError
        Unknown joint names or a stiffness that would not stay positive.
    """
    s = spec or FrameSpec()
    th = dict(theta or {})
    bad = sorted(set(th) - set(JOINTS))
    if bad or any(not (v > -1.0) for v in th.values()):
        msg = f"theta: expected joints {list(JOINTS)} with values > -1, got {th}"
        raise ModelError(msg)
    n, w, h = s.elements, s.half_width_m, s.height_m
    xyz: dict[int, FloatArray] = {}
    base = [100 + i for i in range(2 * n + 1)]
    left, right = [200 + i for i in range(n + 1)], [300 + i for i in range(n + 1)]
    axis = [400 + i for i in range(2 * n + 1)]
    for i, nd in enumerate(base):
        xyz[nd] = np.array([-w + i * w / n, 0.0, 0.0])
    for i, (a, b) in enumerate(zip(left, right, strict=True)):
        xyz[a], xyz[b] = np.array([-w, 0.0, i * h / n]), np.array([w, 0.0, i * h / n])
    for i, nd in enumerate(axis):
        xyz[nd] = np.array([-w + i * w / n, 0.0, h])
    held = base[n]  # the centre of the base: the azimuth bearing, held
    idx: dict[int, int] = {}
    labels: list[str] = []
    for nd in xyz:
        if nd == held:
            idx[nd] = -10  # its DOFs are not in the model
            continue
        idx[nd] = len(labels)
        labels += [f"{nd}:x", f"{nd}:z", f"{nd}:ry"]
    ndof = len(labels)
    K, M = np.zeros((ndof, ndof)), np.zeros((ndof, ndof))
    for chain, sec in ((base, s.base), (left, s.arm), (right, s.arm), (axis, s.axis)):
        for a, b in itertools.pairwise(chain):
            _beam(K, M, idx, a, b, xyz, sec, s)
    mid = idx[axis[n]]
    M[mid, mid] += s.instrument_kg
    M[mid + 1, mid + 1] += s.instrument_kg
    top = idx[right[-1]]
    M[top, top] += s.motor_kg
    M[top + 1, top + 1] += s.motor_kg
    joints = {j: np.zeros((ndof, ndof)) for j in JOINTS}
    foot = (s.foot_n_m, s.foot_n_m, s.foot_nm_rad)
    _spring(joints["feet"], idx, base[0], left[0], foot)
    _spring(joints["feet"], idx, base[-1], right[0], foot)
    for top, end in ((left[-1], axis[0]), (right[-1], axis[-1])):
        _spring(joints["bearings"], idx, top, end, (s.bearing_n_m, s.bearing_n_m, 0.0))
    K0 = K + sum((1.0 + th.get(j, 0.0)) * joints[j] for j in JOINTS)
    nodes = np.array([[nd, *xyz[nd]] for nd in xyz if nd != held])
    return {"M": M, "K0": K0, **{f"K_{j}": joints[j] for j in JOINTS},
            "dofs": np.array(labels), "node_xyz": nodes}
