"""Data of the twin simulator: the reduced structure with its devices, and a result block.

:class:`ReducedSystem` is Eq. (12) of [004]: a reduced linear structure (M, C, K of the
modal or Craig-Bampton coordinates, base-input participation Gamma) with nonlinear
devices attached through drift matrices, and the outputs as C_out [q; q'; q''] + D_out a_g.
:class:`modal_twin.twin.simulator.Simulator` integrates it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from modal_twin._types import FloatArray, IntArray
from modal_twin.errors import ModelError, ShapeError
from modal_twin.models.devices.base import Device

__all__ = ["DeviceAttachment", "ReducedSystem", "SimResult"]


@dataclass(frozen=True, slots=True)
class DeviceAttachment:
    """A device and the matrices that extract its local drift from q (and the input).

    Attributes
    ----------
    device : Device
        The law (1 or 2 directions).
    B : FloatArray
        Shape (n_dir, n): u_d = B q (m per unit of q).
    E, Ed : FloatArray or None
        Shape (n_dir, n_in): the part of the drift and of its rate the input carries
        itself, ``u_d = B q + E a``, ``u_d' = B q' + Ed a`` (a vehicle's primary suspension:
        its stroke is the bogie over the axle minus the track there); None: none.
    """

    device: Device
    B: FloatArray
    E: FloatArray | None = None
    Ed: FloatArray | None = None


def _check_input_share(i: int, att: DeviceAttachment, n_in: int) -> None:
    """Refuse an ``E`` or ``Ed`` of device ``i`` not shaped (n_dir, n_in)."""
    for key in ("E", "Ed"):
        X = getattr(att, key)
        if X is not None and np.shape(X) != (att.device.n_dir, n_in):
            msg = (f"devices[{i}].{key} ({att.device.name}): expected "
                   f"({att.device.n_dir}, {n_in}), got {np.shape(X)}")
            raise ShapeError(msg)


@dataclass(frozen=True, slots=True)
class ReducedSystem:
    """Reduced linear structure with nonlinear devices, Eq. (12) of [004].

    Attributes
    ----------
    M, C, K : FloatArray
        (n, n) mass (identity if mass-normalised), damping and stiffness of the linear part.
    Gamma : FloatArray
        (n, n_in) participation of the base acceleration a_g (e.g. Phi^T M P), SI.
    devices : tuple of DeviceAttachment
        Nonlinear devices.
    C_out : FloatArray
        (n_out, 3 n) output matrix acting on [q; q'; q''].
    D_out : FloatArray
        (n_out, n_in) direct feed-through of a_g (absolute accelerations).
    output_names : tuple of str
        Optional channel names (length n_out or empty).
    """

    M: FloatArray
    C: FloatArray
    K: FloatArray
    Gamma: FloatArray
    devices: tuple[DeviceAttachment, ...]
    C_out: FloatArray
    D_out: FloatArray
    output_names: tuple[str, ...] = field(default=())

    def __post_init__(self) -> None:
        """Validate shapes and finiteness."""
        n = np.shape(self.M)[0] if np.ndim(self.M) == 2 else -1
        for name, A, shape in (
            ("M", self.M, (n, n)),
            ("C", self.C, (n, n)),
            ("K", self.K, (n, n)),
        ):
            if np.shape(A) != shape or n < 1:
                msg = f"{name}: expected (n, n) with n = {n}, got {np.shape(A)}"
                raise ShapeError(msg)
        n_in = np.shape(self.Gamma)[1] if np.ndim(self.Gamma) == 2 else -1
        if np.shape(self.Gamma) != (n, n_in):
            msg = f"Gamma: expected (n, n_in) with n = {n}, got {np.shape(self.Gamma)}"
            raise ShapeError(msg)
        n_out = np.shape(self.C_out)[0] if np.ndim(self.C_out) == 2 else -1
        if np.shape(self.C_out) != (n_out, 3 * n):
            msg = f"C_out: expected (n_out, 3 n) = (n_out, {3 * n}), got {np.shape(self.C_out)}"
            raise ShapeError(msg)
        if np.shape(self.D_out) != (n_out, n_in):
            msg = f"D_out: expected ({n_out}, {n_in}), got {np.shape(self.D_out)}"
            raise ShapeError(msg)
        if self.output_names and len(self.output_names) != n_out:
            msg = f"output_names: expected {n_out} names, got {len(self.output_names)}"
            raise ShapeError(msg)
        for i, att in enumerate(self.devices):
            if np.shape(att.B) != (att.device.n_dir, n):
                msg = (
                    f"devices[{i}].B ({att.device.name}): expected ({att.device.n_dir}, {n}), "
                    f"got {np.shape(att.B)}"
                )
                raise ShapeError(msg)
            _check_input_share(i, att, n_in)
        for name in ("M", "C", "K", "Gamma", "C_out", "D_out"):
            if not np.all(np.isfinite(getattr(self, name))):
                msg = f"{name}: expected finite entries, found NaN or inf"
                raise ModelError(msg)

    @property
    def n(self) -> int:
        """Number of reduced coordinates."""
        return int(np.shape(self.M)[0])

    @property
    def n_in(self) -> int:
        """Number of base-acceleration inputs."""
        return int(np.shape(self.Gamma)[1])


@dataclass(frozen=True, slots=True)
class SimResult:
    """Time histories of a (block of a) simulation.

    Attributes
    ----------
    t : FloatArray
        (nt,) time of each sample, s.
    y : FloatArray
        (n_out, nt) outputs (C_out [q; q'; q''] + D_out a_g), SI.
    q, qd, qdd : FloatArray or None
        (n, nt) reduced coordinates and their first two derivatives (None when the
        simulator was built with ``modal_histories=False``).
    drift : FloatArray
        (n_rows, nt) device drifts, one row per device direction (order of ``rows``), m.
    force : FloatArray
        (n_rows, nt) device forces, N.
    rows : tuple of str
        "name.x" / "name.y" label of each drift / force row.
    newton_iterations : IntArray
        (nt,) device-law evaluations per sample, summed over its integration steps (0 for
        the rest sample; one per step is the rule).
    cond_V : float
        Condition number of the modal eigenvector matrix.
    method : str
        Integration method.
    """

    t: FloatArray
    y: FloatArray
    q: FloatArray | None
    qd: FloatArray | None
    qdd: FloatArray | None
    drift: FloatArray
    force: FloatArray
    rows: tuple[str, ...]
    newton_iterations: IntArray
    cond_V: float  # noqa: N815 - matrix symbol V
    method: str
