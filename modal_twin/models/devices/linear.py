"""Linear spring-dashpot device (the k-c model of Eq. (1) of [004])."""

from __future__ import annotations

import numpy as np
from numba import njit

from modal_twin._types import FloatArray
from modal_twin.errors import ModelError
from modal_twin.models.devices.base import KIND_LINEAR, Device, carry_state

__all__ = ["LinearDevice", "law_linear", "table6_updated"]


@njit(cache=True)
def law_linear(p, s, u, v, f, Kt, Ct, s_new):  # pragma: no cover - jitted
    """f = k u + c v per direction, Eq. (1) of [004]; p = [kx, ky, cx, cy]."""
    for i in range(2):
        f[i] = p[i] * u[i] + p[2 + i] * v[i]  # Eq. (1) of [004]
        for j in range(2):
            Kt[i, j] = 0.0
            Ct[i, j] = 0.0
        Kt[i, i] = p[i]
        Ct[i, i] = p[2 + i]
    carry_state(s, u, s_new)


class LinearDevice(Device):
    """Uncoupled linear stiffness and viscous damping in 1 or 2 directions.

    Parameters
    ----------
    k : sequence of float
        Stiffness per direction, N/m (length n_dir).
    c : sequence of float
        Damping coefficient per direction, N s/m (length n_dir).
    name : str
        Label.
    """

    kind = KIND_LINEAR

    def __init__(self, k: list[float], c: list[float], *, name: str = "linear") -> None:
        k = [float(x) for x in np.atleast_1d(k)]
        c = [float(x) for x in np.atleast_1d(c)]
        if len(k) != len(c) or len(k) not in (1, 2):
            msg = f"k, c: expected equal lengths 1 or 2, got {len(k)} and {len(c)}"
            raise ModelError(msg)
        if min(k) < 0 or min(c) < 0:
            msg = f"k, c: expected non-negative values, got k={k}, c={c}"
            raise ModelError(msg)
        n = len(k)
        kk = k + [0.0] * (2 - n)
        cc = c + [0.0] * (2 - n)
        super().__init__(kk + cc, n_dir=n, name=name)

    def reference_damping(self) -> FloatArray:
        """Return diag(c)."""
        return np.diag(self.params[2:4])


# Table 6 of [004], "updated k" (kN/m) and "updated c" (Mg/s), x then y.
_TABLE6_UPDATED = {
    "RB1": ((1173.0, 1044.0), (24.83, 20.47)),
    "RB2": ((1130.0, 1165.0), (26.90, 24.20)),
    "ESB1": ((1587.0, 1571.0), (45.42, 45.64)),
    "ESB2": ((1595.0, 1349.0), (82.06, 60.85)),
    "SDP1": ((3793.0, 3709.0), (159.20, 134.68)),
    "SDP2": ((3881.0, 3995.0), (182.22, 180.45)),
}


def table6_updated(device: str) -> LinearDevice:
    """Return the updated linear k-c model of an isolation device, Table 6 of [004].

    Parameters
    ----------
    device : {"RB1", "RB2", "ESB1", "ESB2", "SDP1", "SDP2"}

    Returns
    -------
    LinearDevice
        Bidirectional, k in N/m (table kN/m x 1e3), c in N s/m (table Mg/s x 1e3).

    Raises
    ------
    ModelError
        For an unknown device label.
    """
    if device not in _TABLE6_UPDATED:
        msg = f"device: expected one of {sorted(_TABLE6_UPDATED)}, got {device!r}"
        raise ModelError(msg)
    k, c = _TABLE6_UPDATED[device]
    return LinearDevice([1e3 * x for x in k], [1e3 * x for x in c], name=device)
