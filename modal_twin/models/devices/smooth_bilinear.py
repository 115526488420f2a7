"""Smooth bilinear elastic spring: the Richard-Abbott / Menegotto-Pinto backbone, no memory.

Per direction, uncoupled (Richard & Abbott 1975, Eq. (1); the same curve in the normalised
form of Menegotto & Pinto 1973, ``f* = b u* + (1 - b) u* / (1 + |u*|^n)^(1/n)``)::

    f = kb u + (k - kb) u / (1 + |u / ub|^n)^(1/n) + c u'

Tangent ``k`` at rest, ``kb`` for ``|u| >> ub``; the two asymptotes meet at ``|u| = ub``
as those of the bilinear spring of Eq. (9) of [004] do, and the sharpness ``n`` rounds the
knee: ``n -> inf`` is that bilinear spring, ``n = 1`` the softest knee. Its tangent::

    df/du = kb + (k - kb) (1 + |u / ub|^n)^(-(n + 1) / n)

It softens for ``kb < k`` (a rubber mount, an elastomeric bearing whose stiffness falls
smoothly with the stroke) and hardens towards ``kb`` for ``kb > k``. Elastic: it loads and
unloads along the same curve (no hysteresis; the Menegotto-Pinto steel law adds memory of
the last reversal, this one has none).

References: R. M. Richard, B. J. Abbott, "Versatile elastic-plastic stress-strain formula",
J. Eng. Mech. Div. ASCE 101 (EM4), 511-515, 1975; M. Menegotto, P. E. Pinto, IABSE
Symposium on Resistance and Ultimate Deformability of Structures, Lisbon, 1973.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from modal_twin._types import FloatArray
from modal_twin.errors import ModelError
from modal_twin.models.devices.base import (
    KIND_SMOOTH_BILINEAR,
    Device,
    carry_state,
    clear_outputs,
)

__all__ = ["SmoothBilinearSpring", "law_smooth_bilinear"]

N_MIN, N_MAX = 0.5, 100.0  # sharpness accepted (1: softest knee used, 100: bilinear)


@njit(cache=True)
def law_smooth_bilinear(p, s, u, v, f, Kt, Ct, s_new):  # pragma: no cover - jitted
    """Richard-Abbott curve per direction; p = [k, kb, ub, cx, cy, n_dir, y_scale, n]."""
    ub = p[2]
    nd = int(p[5])
    n = p[7]
    clear_outputs(f, Kt, Ct)
    for i in range(2):
        if i >= nd:
            continue
        sc = 1.0 if i == 0 else p[6]  # y stiffnesses are y_scale times x's
        k = p[0] * sc
        kb = p[1] * sc
        x = u[i]
        a = abs(x) / ub
        # d = (1 + a^n)^(1/n), written so that a^n never overflows
        d = (1.0 + a**n) ** (1.0 / n) if a <= 1.0 else a * (1.0 + a ** (-n)) ** (1.0 / n)
        f[i] = kb * x + (k - kb) * x / d + p[3 + i] * v[i]
        Kt[i, i] = kb + (k - kb) * d ** (-(n + 1.0))
        Ct[i, i] = p[3 + i]
    carry_state(s, u, s_new)


class SmoothBilinearSpring(Device):
    """Smooth bilinear (Richard-Abbott) elastic spring with a dashpot, uncoupled x / y.

    Parameters
    ----------
    k : float
        Initial stiffness, N/m.
    kb : float
        Stiffness approached at large drift, N/m (< k softening, > k hardening).
    ub : float
        Drift at which the two asymptotes meet, m.
    c : sequence of float
        Viscous damping per direction, N s/m (length n_dir).
    name : str
        Label.
    n : float
        Sharpness of the knee, in [0.5, 100] (large: the bilinear spring).
    y_scale : float
        Stiffnesses in y over those in x (``ub`` and ``n`` the same), default 1.
    """

    kind = KIND_SMOOTH_BILINEAR

    def __init__(self, k: float, kb: float, ub: float, c: list[float], *,
                 name: str = "smooth_bilinear", n: float = 2.0, y_scale: float = 1.0) -> None:
        c = [float(x) for x in np.atleast_1d(c)]
        if not (k > 0 and kb >= 0 and ub > 0) or min(c) < 0 or len(c) not in (1, 2):
            msg = (f"k, kb, ub, c: expected k > 0, kb >= 0, ub > 0, c >= 0 with 1 or 2 "
                   f"entries, got k={k}, kb={kb}, ub={ub}, c={c}")
            raise ModelError(msg)
        if not N_MIN <= n <= N_MAX:
            msg = f"n: expected a sharpness in [{N_MIN}, {N_MAX}], got {n}"
            raise ModelError(msg)
        if not y_scale > 0:
            msg = f"y_scale: expected > 0, got {y_scale}"
            raise ModelError(msg)
        nd = len(c)
        cc = c + [0.0] * (2 - nd)
        super().__init__([k, kb, ub, *cc, float(nd), float(y_scale), float(n)], n_dir=nd,
                         name=name)

    def reference_damping(self) -> FloatArray:
        """Return diag(c)."""
        return np.diag(self.params[3:5])
