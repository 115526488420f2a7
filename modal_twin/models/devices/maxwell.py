"""Maxwell damper: a dashpot behind a spring (in series), beside an optional parallel spring.

Per direction, uncoupled: a branch of stiffness ``kb`` in series with a dashpot ``c``
carries the force ``f_m``, relaxing with the time constant ``tau = c / kb``::

    f_m' + f_m / tau = kb u',        f = kp u + f_m                               (1)

(the standard linear solid when ``kp > 0``). In steady harmonic motion ``u = U e^{i w t}``
the force is ``K(w) U e^{i w t}`` with the complex stiffness

    K(w) = kp + kb i w c / (kb + i w c)                                           (2)

a dashpot ``c`` at ``w tau << 1`` and a spring ``kb`` at ``w tau >> 1``: a damper whose
rubber bushes or oil compressibility stiffen it at high frequency. ``kb -> inf`` is the
plain dashpot.

Time discretisation: (1) is a rate law, so the device needs the sample interval ``dt``
(parameter slot :attr:`MaxwellDamper.time_step_index`, filled by the twin's simulator and
by :meth:`~modal_twin.models.devices.base.Device.respond`). Over a step the velocity is
taken linear between its committed value ``v0`` and the trial ``v`` (the twin's first-order
hold); (1) is then integrated exactly::

    E = exp(-dt / tau),   f_m = E f_m0 + c [v0 (1 - E) + (v - v0) (1 - tau (1 - E) / dt)]

so the tangents are ``Kt = kp``, ``Ct = c (1 - tau (1 - E) / dt)``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from modal_twin._types import ComplexArray, FloatArray
from modal_twin.errors import ModelError
from modal_twin.models.devices.base import KIND_MAXWELL, Device, carry_state, clear_outputs

__all__ = ["MaxwellDamper", "law_maxwell", "maxwell_stiffness"]

_DT = 8  # parameter slot of the sample interval


@njit(cache=True)
def law_maxwell(p, s, u, v, f, Kt, Ct, s_new):  # pragma: no cover - jitted
    """p = [kpx, kpy, kbx, kby, cx, cy, n_dir, -, dt]; s[2:4] v0, s[4:6] branch force."""
    nd = int(p[6])
    dt = p[_DT]
    clear_outputs(f, Kt, Ct)
    carry_state(s, u, s_new)
    for i in range(2):
        if i >= nd:
            continue
        kb = p[2 + i]
        c = p[4 + i]
        v0 = s[2 + i]
        fm = s[4 + i]
        if kb > 0.0 and c > 0.0 and dt > 0.0:
            tau = c / kb
            one_e = -math.expm1(-dt / tau)  # 1 - E, Eq. (1) integrated over the step
            ct = c * (1.0 - tau * one_e / dt)
            fm = (1.0 - one_e) * fm + c * v0 * one_e + ct * (v[i] - v0)
        else:
            ct = 0.0  # no branch (or no step: the committed branch force)
        f[i] = p[i] * u[i] + fm
        Kt[i, i] = p[i]
        Ct[i, i] = ct
        s_new[2 + i] = v[i]
        s_new[4 + i] = fm


def maxwell_stiffness(kp: float, kb: float, c: float, omega: FloatArray) -> ComplexArray:
    """Return the complex stiffness ``K(w)`` of Eq. (2) (module docstring), N/m."""
    w = np.asarray(omega, dtype=float)
    return np.asarray(kp + kb * 1j * w * c / (kb + 1j * w * c), dtype=complex)


class MaxwellDamper(Device):
    """Dashpot ``c`` in series with a spring ``kb``, beside a spring ``kp`` (module docstring).

    Parameters
    ----------
    kp : sequence of float
        Parallel stiffness per direction, N/m (length n_dir; 0 for the bare Maxwell element).
    kb : sequence of float
        Series (bushing) stiffness per direction, N/m.
    c : sequence of float
        Dashpot per direction, N s/m.
    name : str
        Label.
    dt : float, optional
        Sample interval, s; the simulator and :meth:`respond` (``dt=``) set it.
    """

    kind = KIND_MAXWELL
    time_step_index = _DT

    def __init__(self, kp: list[float], kb: list[float], c: list[float], *,
                 name: str = "maxwell", dt: float = 0.0) -> None:
        kp, kb, c = ([float(x) for x in np.atleast_1d(a)] for a in (kp, kb, c))
        n = len(c)
        if n not in (1, 2) or len(kp) != n or len(kb) != n:
            msg = f"kp, kb, c: expected equal lengths 1 or 2, got {len(kp)}, {len(kb)}, {n}"
            raise ModelError(msg)
        if min(kp) < 0 or min(kb) <= 0 or min(c) < 0 or not np.all(np.isfinite(kp + kb + c)):
            msg = f"kp, kb, c: expected kp >= 0, kb > 0, c >= 0, got {kp}, {kb}, {c}"
            raise ModelError(msg)
        if not (np.isfinite(dt) and dt >= 0):
            msg = f"dt: expected a sample interval >= 0, got {dt!r}"
            raise ModelError(msg)
        pad = [0.0] * (2 - n)
        super().__init__([*kp, *pad, *kb, *pad, *c, *pad, float(n), 0.0, float(dt)],
                         n_dir=n, name=name)

    def reference_stiffness(self) -> FloatArray:
        """Return diag(kp): the static stiffness."""
        return np.diag(self.params[0:2])

    def relaxation_time(self) -> FloatArray:
        """Return ``tau = c / kb`` per direction, s."""
        return np.asarray(self.params[4:6] / np.where(self.params[2:4] > 0,
                                                      self.params[2:4], np.inf))
