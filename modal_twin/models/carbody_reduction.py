"""Craig-Bampton carbody: interface at the air-spring seats, centre pins and hangers.

The 3D shell carbody (:mod:`modal_twin.models.carbody3d`) is reduced with
:func:`modal_twin.models.craig_bampton.craig_bampton` keeping the six DOFs of every interface
node physical (the secondary suspension's seats and centre pins, the equipment hangers'
carbody nodes), plus the fixed-interface modes below a cut-off ([002] Sec. 5: a CB carbody
in the vehicle-track model). The reduced model's rigid-body vectors are those of the node
coordinates restricted to the boundary rows with zero modal coordinates (CB eq. 1: a
rigid motion of the boundary gives the rigid motion of the interior through the constraint
modes), so its rigid modes are found by projection on them (:func:`reduced_rigid_mask`),
never by a threshold relative to the spectrum.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from modal_twin._types import BoolArray, FloatArray
from modal_twin.errors import ShapeError
from modal_twin.models.carbody3d import CarbodyFE
from modal_twin.models.craig_bampton import CBReduction, craig_bampton

__all__ = ["reduce_carbody", "reduced_modes", "reduced_rigid_mask", "reduced_rigid_vectors"]


def reduce_carbody(car: CarbodyFE, *, f_cut_hz: float = 60.0,
                   n_modes: int | None = None) -> CBReduction:
    """Return the Craig-Bampton reduction of ``car`` on its interface nodes.

    Parameters
    ----------
    car : CarbodyFE
    f_cut_hz : float
        Keep the fixed-interface modes below this, Hz (accurate to about half of it).
    n_modes : int, optional
        Upper limit on the number of fixed-interface modes.

    Returns
    -------
    CBReduction
        Boundary order: :meth:`CarbodyFE.interface_nodes`, six DOFs each.
    """
    return craig_bampton(car.asm.M, car.asm.K, car.interface_dofs(), n_modes=n_modes,
                         f_cut_hz=f_cut_hz)


def reduced_rigid_vectors(car: CarbodyFE, cb: CBReduction) -> FloatArray:
    """Return the six rigid-body vectors (n_b + n_q, 6) of the reduced coordinates."""
    R = car.asm.rigid_body_modes()
    out = np.zeros((cb.n_boundary + cb.n_modes, 6))
    out[:cb.n_boundary] = R[cb.boundary_dofs]
    return out


def reduced_rigid_mask(Rr: FloatArray, Mr: FloatArray, V: FloatArray) -> BoolArray:
    """Return True for reduced modes whose ``Mr``-weighted share in ``span(Rr)`` is > 1/2.

    Parameters
    ----------
    Rr : (n_r, 6) float array
        Rigid-body vectors of the reduced coordinates.
    Mr : (n_r, n_r) float array
        Reduced mass.
    V : (n_r, k) float array
        Mode shapes.
    """
    if Rr.shape[0] != Mr.shape[0] or V.shape[0] != Mr.shape[0]:
        msg = f"Rr, V: expected {Mr.shape[0]} rows like Mr, got {Rr.shape[0]} and {V.shape[0]}"
        raise ShapeError(msg)
    MR = Mr @ Rr
    P = MR.T @ V
    share = np.einsum("ij,ij->j", P, np.linalg.solve(Rr.T @ MR, P))
    norm = np.einsum("ij,ij->j", V, Mr @ V)
    return np.asarray(share / norm > 0.5)


def reduced_modes(car: CarbodyFE, cb: CBReduction) -> tuple[FloatArray, FloatArray, BoolArray]:
    """Return the reduced model's frequencies (Hz), shapes (mass-normalised) and rigid mask.

    Negative round-off on the rigid modes is clipped to 0 Hz.
    """
    lam, V = sla.eigh(cb.Kr, cb.Mr)
    f = np.sqrt(np.clip(lam, 0.0, None)) / (2.0 * np.pi)
    return f, V, reduced_rigid_mask(reduced_rigid_vectors(car, cb), cb.Mr, V)
