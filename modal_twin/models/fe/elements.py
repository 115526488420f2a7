"""Element matrices: 3D frame (Euler-Bernoulli or Timoshenko), 6-DOF springs, lumped masses.

All matrices are in the node DOF order ``ux, uy, uz, rx, ry, rz`` (node 1 then node 2 for
two-node elements), SI units (N, m, kg, rad). Frame matrices are formed in the local axes
(x along the element, y and z the principal axes of the section) and rotated to global axes
with ``k_g = R.T @ k_l @ R`` where ``R = blockdiag(r, r, r, r)`` and the rows of ``r`` are
the local unit vectors in global coordinates.

References
----------
J. S. Przemieniecki, *Theory of Matrix Structural Analysis*, McGraw-Hill, 1968, Sec. 5.6
(frame stiffness with shear deformation) and Sec. 11.3 (consistent mass with shear
deformation and rotary inertia); the same matrices are derived from interdependent
interpolation in Friedman & Kosmatka, Computers & Structures 47 (1993) 473-481.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.errors import ModelError

__all__ = [
    "DOF_NAMES",
    "frame_local_matrices",
    "frame_rotation",
    "frame_shear_factors",
    "two_node_matrix",
]

DOF_NAMES: tuple[str, ...] = ("ux", "uy", "uz", "rx", "ry", "rz")
"""Names of the six DOFs of every node, in their storage order."""

MassKind = Literal["consistent", "lumped"]

# Sign change from the x-y plane convention (theta = dv/dx) to the x-z plane
# convention (theta_y = -dw/dx), applied to (w1, theta_y1, w2, theta_y2).
_S_XZ = np.diag([1.0, -1.0, 1.0, -1.0])


def frame_rotation(
    xyz1: FloatArray, xyz2: FloatArray, orientation: FloatArray | None
) -> tuple[FloatArray, float]:
    """Return the 3x3 direction-cosine matrix of a frame element and its length.

    Parameters
    ----------
    xyz1, xyz2 : (3,) float arrays
        Node coordinates, m.
    orientation : (3,) float array or None
        Any vector in the local x-y plane, not parallel to the element. ``None`` picks
        global Z, or global X for an element within 1e-3 rad of vertical (columns then
        have local y = global X).

    Returns
    -------
    r : (3, 3) float array
        Rows are the local x, y, z unit vectors in global coordinates.
    length : float
        Element length, m.

    Raises
    ------
    ModelError
        If the element has zero length or the orientation vector is parallel to it.
    """
    dx = np.asarray(xyz2, dtype=float) - np.asarray(xyz1, dtype=float)
    length = float(np.linalg.norm(dx))
    scale = max(float(np.linalg.norm(xyz1)), float(np.linalg.norm(xyz2)), 1.0)
    if length <= 1e-12 * scale:
        msg = f"frame length: expected > 0, got {length!r} (nodes at {list(xyz1)})"
        raise ModelError(msg)
    ex = dx / length
    if orientation is None:
        v = np.array([1.0, 0.0, 0.0]) if abs(ex[2]) > 1.0 - 5e-7 else np.array([0.0, 0.0, 1.0])
    else:
        v = np.asarray(orientation, dtype=float)
        if v.shape != (3,) or not np.all(np.isfinite(v)):
            msg = f"orientation: expected a finite (3,) vector, got {orientation!r}"
            raise ModelError(msg)
    ez = np.cross(ex, v)
    nz = float(np.linalg.norm(ez))
    if nz <= 1e-9 * max(float(np.linalg.norm(v)), 1e-300):
        msg = f"orientation: expected a vector not parallel to the element axis {ex}, got {v}"
        raise ModelError(msg)
    ez /= nz
    ey = np.cross(ez, ex)
    return np.vstack([ex, ey, ez]), length


def frame_shear_factors(
    E: float, G: float, Iy: float, Iz: float, length: float,
    Asy: float | None, Asz: float | None,
) -> tuple[float, float]:
    """Return the shear-flexibility ratios ``(phi_y, phi_z)`` of a frame element.

    ``phi_y = 12 E Iz / (G Asy L^2)`` (bending in the local x-y plane, shear along y) and
    ``phi_z = 12 E Iy / (G Asz L^2)``; zero when the shear area is ``None`` (Euler-Bernoulli).
    """
    phi_y = 0.0 if Asy is None else 12.0 * E * Iz / (G * Asy * length**2)
    phi_z = 0.0 if Asz is None else 12.0 * E * Iy / (G * Asz * length**2)
    return phi_y, phi_z


def _bending_stiffness(EI: float, L: float, phi: float) -> FloatArray:
    """Return the 4x4 bending stiffness on (v1, th1, v2, th2), th = dv/dx (Przemieniecki 5.6)."""
    a = EI / ((1.0 + phi) * L**3)
    return a * np.array(
        [
            [12.0, 6.0 * L, -12.0, 6.0 * L],
            [6.0 * L, (4.0 + phi) * L**2, -6.0 * L, (2.0 - phi) * L**2],
            [-12.0, -6.0 * L, 12.0, -6.0 * L],
            [6.0 * L, (2.0 - phi) * L**2, -6.0 * L, (4.0 + phi) * L**2],
        ]
    )


def _bending_mass(rhoA: float, rhoI: float, L: float, phi: float) -> FloatArray:
    """Return the 4x4 consistent bending mass on (v1, th1, v2, th2), th = dv/dx.

    Translational inertia with shear-deformable interpolation plus rotary inertia
    ``rhoI`` (Przemieniecki Sec. 11.3); ``phi = 0, rhoI = 0`` gives the classical
    Euler-Bernoulli matrix ``rho A L / 420 [156, 22L, 54, -13L; ...]``.
    """
    p = phi
    c = rhoA * L / (1.0 + p) ** 2
    m1 = 13.0 / 35.0 + 7.0 * p / 10.0 + p**2 / 3.0
    m2 = (11.0 / 210.0 + 11.0 * p / 120.0 + p**2 / 24.0) * L
    m3 = 9.0 / 70.0 + 3.0 * p / 10.0 + p**2 / 6.0
    m4 = (13.0 / 420.0 + 3.0 * p / 40.0 + p**2 / 24.0) * L
    m5 = (1.0 / 105.0 + p / 60.0 + p**2 / 120.0) * L**2
    m6 = (1.0 / 140.0 + p / 60.0 + p**2 / 120.0) * L**2
    mt = c * np.array(
        [[m1, m2, m3, -m4], [m2, m5, m4, -m6], [m3, m4, m1, -m2], [-m4, -m6, -m2, m5]]
    )
    if rhoI == 0.0:
        return mt
    d = rhoI / ((1.0 + p) ** 2 * L)
    r1 = 6.0 / 5.0
    r2 = (1.0 / 10.0 - p / 2.0) * L
    r3 = (2.0 / 15.0 + p / 6.0 + p**2 / 3.0) * L**2
    r4 = (1.0 / 30.0 + p / 6.0 - p**2 / 6.0) * L**2
    mr = d * np.array(
        [[r1, r2, -r1, r2], [r2, r3, -r2, -r4], [-r1, -r2, r1, -r2], [r2, -r4, -r2, r3]]
    )
    return mt + mr


def frame_local_matrices(
    *, E: float, G: float, A: float, Iy: float, Iz: float, J: float, rho: float,
    length: float, Asy: float | None = None, Asz: float | None = None,
    mass: MassKind = "consistent",
) -> tuple[FloatArray, FloatArray]:
    """Return the 12x12 local stiffness and mass matrices of a 3D frame element.

    Euler-Bernoulli when both shear areas are ``None``; otherwise Timoshenko in the planes
    whose shear area is given (shear flexibility ``phi`` and rotary inertia ``rho I``).

    Parameters
    ----------
    E, G : float
        Young's and shear moduli, Pa.
    A, Iy, Iz, J : float
        Area (m^2), second moments about local y and z (m^4), torsion constant (m^4).
    rho : float
        Density, kg/m^3 (0 for a massless element).
    length : float
        Element length, m.
    Asy, Asz : float or None
        Effective shear areas ``kappa A`` for shear along local y and z, m^2.
    mass : {"consistent", "lumped"}
        Consistent mass, or a diagonal lumped mass (``rho A L / 2`` per translation,
        ``rho (Iy + Iz) L / 2`` per torsional rotation, no bending rotary inertia).

    Returns
    -------
    k, m : (12, 12) float arrays
        Local stiffness (N/m, N m/rad) and mass (kg, kg m^2).
    """
    L = length
    k = np.zeros((12, 12))
    m = np.zeros((12, 12))
    phi_y, phi_z = frame_shear_factors(E, G, Iy, Iz, L, Asy, Asz)
    ax = np.array([0, 6])
    tx = np.array([3, 9])
    bar = np.array([[1.0, -1.0], [-1.0, 1.0]])
    k[np.ix_(ax, ax)] = E * A / L * bar
    k[np.ix_(tx, tx)] = G * J / L * bar
    ixy = np.array([1, 5, 7, 11])  # v, rz: bending about local z
    ixz = np.array([2, 4, 8, 10])  # w, ry: bending about local y
    k[np.ix_(ixy, ixy)] = _bending_stiffness(E * Iz, L, phi_y)
    k[np.ix_(ixz, ixz)] = _S_XZ @ _bending_stiffness(E * Iy, L, phi_z) @ _S_XZ
    if mass == "lumped":
        d = np.zeros(12)
        d[[0, 1, 2, 6, 7, 8]] = rho * A * L / 2.0
        d[tx] = rho * (Iy + Iz) * L / 2.0
        return k, np.diag(d)
    if mass != "consistent":
        msg = f"mass: expected one of ['consistent', 'lumped'], got {mass!r}"
        raise ModelError(msg)
    pair = np.array([[2.0, 1.0], [1.0, 2.0]]) / 6.0
    m[np.ix_(ax, ax)] = rho * A * L * pair
    m[np.ix_(tx, tx)] = rho * (Iy + Iz) * L * pair
    rot_y = rho * Iz if Asy is not None else 0.0
    rot_z = rho * Iy if Asz is not None else 0.0
    m[np.ix_(ixy, ixy)] = _bending_mass(rho * A, rot_y, L, phi_y)
    m[np.ix_(ixz, ixz)] = _S_XZ @ _bending_mass(rho * A, rot_z, L, phi_z) @ _S_XZ
    return k, m


def rotate_to_global(mat: FloatArray, r: FloatArray) -> FloatArray:
    """Return ``R.T @ mat @ R`` with ``R = blockdiag(r, r, r, r)`` for a 12x12 matrix."""
    big = np.kron(np.eye(4), r)
    out: FloatArray = big.T @ mat @ big
    return 0.5 * (out + out.T)


def two_node_matrix(k6: FloatArray, grounded: bool) -> FloatArray:
    """Return the matrix of a 6-DOF spring (or dashpot) ``k6`` between two nodes or to ground.

    Zero-length element: ``[[k6, -k6], [-k6, k6]]`` on (node 1, node 2), or ``k6`` alone on
    node 1 when ``grounded``. Offsets between the two nodes do not couple rotations.
    """
    if grounded:
        return np.array(k6, dtype=float)
    return np.block([[k6, -k6], [-k6, k6]])


def section_check(name: str, **values: float | None) -> None:
    """Raise :class:`ModelError` naming the first value that is not finite and positive.

    ``rho`` may be zero; ``None`` values are skipped.
    """
    for key, val in values.items():
        if val is None:
            continue
        ok = math.isfinite(val) and (val >= 0.0 if key == "rho" else val > 0.0)
        if not ok:
            expect = ">= 0" if key == "rho" else "> 0"
            msg = f"{name} {key}: expected a finite value {expect}, got {val!r}"
            raise ModelError(msg)
