"""Common frame of the nonlinear device laws: kind codes, array layout and the base class.

Every law is ONE numba-jitted pure function (in its own module) with the signature::

    law(p, s, u, v, f, Kt, Ct, s_new) -> None

``p`` parameters (float64, length :data:`N_PARAM`), ``s`` committed state (length
:data:`N_STATE`; ``s[0:2]`` always holds the committed local displacement), ``u`` and ``v``
the trial local displacement and velocity (2,), outputs written in place: force ``f`` (2,),
tangent stiffness ``Kt = df/du`` (2, 2), tangent damping ``Ct = df/dv`` (2, 2) and the trial
state ``s_new``. The state is only committed by the caller (a time step accepted), so the
same function serves Newton iterations of the simulator and the Python classes below.
Uniaxial laws use only the first component and return zero in the second.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from modal_twin._types import FloatArray
from modal_twin.errors import OptionError, ShapeError, SignalError

__all__ = [
    "KIND_BILINEAR_ELASTIC",
    "KIND_BILINEAR_HYSTERETIC",
    "KIND_BW_ESB",
    "KIND_BW_SDP",
    "KIND_COULOMB",
    "KIND_CUBIC",
    "KIND_GAP",
    "KIND_IWAN",
    "KIND_LINEAR",
    "KIND_MAXWELL",
    "KIND_PRANDTL",
    "KIND_SMOOTH_BILINEAR",
    "N_PARAM",
    "N_STATE",
    "N_STATE_SMALL",
    "Device",
    "DeviceResponse",
    "carry_state",
    "clear_outputs",
    "copy_state",
]


@njit(cache=True, inline="always")
def copy_state(s, s_new):  # pragma: no cover - jitted
    """Copy s to s_new (explicit loop: ``s_new[:] = s`` is ~30 ns slower)."""
    for ic in range(s.shape[0]):
        s_new[ic] = s[ic]


@njit(cache=True, inline="always")
def carry_state(s, u, s_new):  # pragma: no cover - jitted
    """Copy s to s_new with the drift u in s_new[0:2].

    The state update of every law whose only memory is the last drift.
    """
    copy_state(s, s_new)
    s_new[0] = u[0]
    s_new[1] = u[1]


@njit(cache=True, inline="always")
def clear_outputs(f, Kt, Ct):  # pragma: no cover - jitted
    """Zero the force (2,) and the tangents Kt, Ct (2, 2): the prelude of every law.

    A law then writes the directions it has (``f[i]``, ``Kt[i, i]``, ``Ct[i, i]``).
    """
    for i in range(2):
        for j in range(2):
            Kt[i, j] = 0.0
            Ct[i, j] = 0.0
        f[i] = 0.0

KIND_LINEAR = 0
KIND_BILINEAR_ELASTIC = 1
KIND_BILINEAR_HYSTERETIC = 2
KIND_BW_ESB = 3
KIND_BW_SDP = 4
KIND_PRANDTL = 5
KIND_CUBIC = 6
KIND_COULOMB = 7
KIND_GAP = 8
KIND_MAXWELL = 9
KIND_SMOOTH_BILINEAR = 10
KIND_IWAN = 11

N_PARAM = 12
N_STATE = 70  # the Iwan joint keeps 34 per direction (models.devices.iwan)
N_STATE_SMALL = 8  # what every other law reads and writes (s[0:8] at most)


@dataclass(frozen=True, slots=True)
class DeviceResponse:
    """Force history of a device driven along a prescribed local path.

    Attributes
    ----------
    f : FloatArray
        Force, shape (n_dir, nt), N.
    Kt : FloatArray
        Tangent stiffness df/du at each sample, shape (2, 2, nt), N/m.
    state : FloatArray
        Committed state after the last sample, shape (N_STATE,).
    """

    f: FloatArray
    Kt: FloatArray
    state: FloatArray


class Device:
    """Base class: a device is a law kind, a parameter vector and 1 or 2 directions.

    Subclasses set ``kind``, fill ``params`` and may override :meth:`initial_state` and
    :meth:`reference_stiffness`. They never compute forces themselves: :meth:`evaluate`
    and :meth:`respond` call the jitted law, which is the one the simulator calls.
    """

    kind: int = -1
    time_step_index: int = -1
    """Parameter slot of the sample interval for a rate law (-1: the law needs none); the
    simulator writes its ``dt`` there, :meth:`respond` the one it is given."""
    n_state: int = N_STATE_SMALL
    """State slots the law reads and writes (``s[:n_state]``; the others stay zero): the
    simulator gives each plant's devices the largest of its laws' (a copy of the state per
    device and sample costs what it holds), :meth:`evaluate` and :meth:`respond` all
    :data:`N_STATE`."""

    def __init__(self, params: list[float], *, n_dir: int, name: str) -> None:
        if n_dir not in (1, 2):
            msg = f"n_dir: expected 1 or 2, got {n_dir!r}"
            raise ShapeError(msg)
        p = np.zeros(N_PARAM)
        p[: len(params)] = params
        self.params: FloatArray = p
        self.n_dir = int(n_dir)
        self.name = str(name)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r}, n_dir={self.n_dir})"

    def initial_state(self) -> FloatArray:
        """Return the virgin state (zeros unless a law needs otherwise)."""
        return np.zeros(N_STATE)

    def reference_stiffness(self) -> FloatArray:
        """Return a linear (2, 2) stiffness the simulator moves into the linear part.

        The simulator adds ``B^T K_ref B`` to the modal stiffness and subtracts ``K_ref u``
        from the device force: exact, it only makes the linear part non-singular and the
        Newton residual small. Default: the initial tangent at rest.
        """
        ev = self.evaluate(np.zeros(2), np.zeros(2), self.initial_state())
        return ev[1]

    def reference_damping(self) -> FloatArray:
        """Return the linear (2, 2) viscous part moved into the linear modal damping."""
        return np.zeros((2, 2))

    def evaluate(
        self, u: FloatArray, v: FloatArray, state: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Evaluate the law once from a committed state.

        Parameters
        ----------
        u, v : FloatArray
            Trial local displacement (m) and velocity (m/s), shape (n_dir,) or (2,).
        state : FloatArray
            Committed state, shape (N_STATE,).

        Returns
        -------
        f, Kt, Ct, new_state
            Force (2,), tangent stiffness (2, 2), tangent damping (2, 2), trial state.
        """
        from modal_twin.models.devices._dispatch import evaluate_law

        u2 = np.zeros(2)
        v2 = np.zeros(2)
        u2[: self.n_dir] = np.asarray(u, dtype=float).ravel()[: self.n_dir]
        v2[: self.n_dir] = np.asarray(v, dtype=float).ravel()[: self.n_dir]
        f = np.zeros(2)
        Kt = np.zeros((2, 2))
        Ct = np.zeros((2, 2))
        s_new = np.zeros(N_STATE)
        evaluate_law(self.kind, self.params, np.asarray(state, float), u2, v2, f, Kt, Ct, s_new)
        return f, Kt, Ct, s_new

    def respond(self, u: FloatArray, v: FloatArray | None = None, *,
                dt: float | None = None) -> DeviceResponse:
        """Drive the device along a displacement (and velocity) history from rest.

        Parameters
        ----------
        u : FloatArray
            Local displacement, shape (n_dir, nt) or (nt,) for n_dir = 1, m.
        v : FloatArray, optional
            Local velocity, same shape, m/s; zeros if omitted (rate-independent use).
        dt : float, optional
            Sample interval of the history, s: a rate law (``time_step_index >= 0``)
            needs it unless its parameters hold one; other laws ignore it.

        Returns
        -------
        DeviceResponse

        Raises
        ------
        ShapeError
            If ``u`` or ``v`` do not have n_dir rows.
        SignalError
            If ``u`` or ``v`` hold non-finite samples.
        OptionError
            A rate law without a positive ``dt`` (given or held).
        """
        from modal_twin.models.devices._dispatch import drive_law

        params = self.params
        if self.time_step_index >= 0:
            params = params.copy()
            if dt is not None:
                params[self.time_step_index] = float(dt)
            if not (np.isfinite(params[self.time_step_index])
                    and params[self.time_step_index] > 0):
                msg = (f"{self.name}: the law {type(self).__name__} needs the sample interval "
                       f"dt > 0 (respond(u, v, dt=...)), got {dt!r}")
                raise OptionError(msg)

        U = np.atleast_2d(np.asarray(u, dtype=float))
        V = np.zeros_like(U) if v is None else np.atleast_2d(np.asarray(v, dtype=float))
        if U.shape[0] != self.n_dir or V.shape != U.shape:
            msg = (
                f"u, v: expected shape ({self.n_dir}, nt), got {U.shape} and {V.shape}"
            )
            raise ShapeError(msg)
        for nm, arr in (("u", U), ("v", V)):
            bad = np.argwhere(~np.isfinite(arr))
            if bad.size:
                msg = f"{nm}: non-finite sample at index {bad[0, 1]} in direction {bad[0, 0]}"
                raise SignalError(msg)
        U2 = np.zeros((2, U.shape[1]))
        V2 = np.zeros((2, U.shape[1]))
        U2[: self.n_dir] = U
        V2[: self.n_dir] = V
        f, Kt, s = drive_law(self.kind, params, self.initial_state(), U2, V2)
        return DeviceResponse(f=f[: self.n_dir], Kt=Kt, state=s)
