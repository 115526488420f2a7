"""Bilinear rubber-bearing laws: the elastic one of Eq. (9) of [004] and a hysteretic twin.

Eq. (9) of [004], per horizontal direction (uncoupled, identical in x and y)::

    f = k u + c u' - (k - kb)(u + ub)[1 - H(u + ub)] - (k - kb)(u - ub) H(u - ub)

i.e. stiffness ``k`` for |u| <= ub and ``kb`` beyond, with no hysteresis (a nonlinear
elastic spring, Fig. 17 of [004]). NOTE: the paper prints ``+`` before the two Heaviside
terms, which would give a post-yield stiffness 2k - kb > k, contradicting its own
definition of kb as the post-yield stiffness (Table 10: kb = 0.786 < k = 1.075 MN/m) and
the softening observed in Test 016; the minus signs above are implemented.

The hysteretic bilinear (kinematic hardening) is the classic alternative: a linear spring
``kb`` in parallel with an elastic-perfectly-plastic element of stiffness ``k - kb`` and
yield displacement ``ub``; its loop area per cycle of amplitude X > ub is
``4 (k - kb) ub (X - ub)``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from modal_twin._types import FloatArray
from modal_twin.errors import ModelError
from modal_twin.models.devices.base import (
    KIND_BILINEAR_ELASTIC,
    KIND_BILINEAR_HYSTERETIC,
    Device,
    carry_state,
    clear_outputs,
    copy_state,
)

__all__ = [
    "BilinearElastic",
    "BilinearHysteretic",
    "law_bilinear_elastic",
    "law_bilinear_hysteretic",
    "table10_rubber_bearing",
]


@njit(cache=True)
def law_bilinear_elastic(p, s, u, v, f, Kt, Ct, s_new):  # pragma: no cover - jitted
    """Eq. (9) of [004] (sign-corrected); p = [k, kb, ub, cx, cy, n_dir, y_scale]."""
    ub = p[2]
    nd = int(p[5])
    clear_outputs(f, Kt, Ct)
    for i in range(2):
        if i >= nd:
            continue
        sc = 1.0 if i == 0 else p[6]  # y stiffnesses are y_scale times x's
        k = p[0] * sc
        kb = p[1] * sc
        x = u[i]
        fi = k * x + p[3 + i] * v[i]  # Eq. (9) of [004], linear part
        kt = k
        if x + ub < 0.0:
            fi -= (k - kb) * (x + ub)  # Eq. (9), [1 - H(u + ub)] term
            kt = kb
        elif x - ub > 0.0:
            fi -= (k - kb) * (x - ub)  # Eq. (9), H(u - ub) term
            kt = kb
        f[i] = fi
        Kt[i, i] = kt
        Ct[i, i] = p[3 + i]
    carry_state(s, u, s_new)


@njit(cache=True)
def law_bilinear_hysteretic(p, s, u, v, f, Kt, Ct, s_new):  # pragma: no cover - jitted
    """Kinematic-hardening bilinear; p = [k, kb, ub, cx, cy, n_dir, y_scale]; s[2:4] elastic."""
    ub = p[2]
    nd = int(p[5])
    copy_state(s, s_new)
    clear_outputs(f, Kt, Ct)
    for i in range(2):
        if i >= nd:
            continue
        sc = 1.0 if i == 0 else p[6]
        k = p[0] * sc
        kb = p[1] * sc
        e = s[2 + i] + (u[i] - s[i])  # elastic trial (return mapping)
        kt = k
        if e > ub:
            e = ub
            kt = kb
        elif e < -ub:
            e = -ub
            kt = kb
        f[i] = kb * u[i] + (k - kb) * e + p[3 + i] * v[i]
        Kt[i, i] = kt
        Ct[i, i] = p[3 + i]
        s_new[2 + i] = e
    s_new[0] = u[0]
    s_new[1] = u[1]


def _check(k: float, kb: float, ub: float, c: list[float]) -> None:
    if not (k > 0 and 0 <= kb <= k and ub > 0) or min(c) < 0:
        msg = (
            f"k, kb, ub, c: expected k > 0, 0 <= kb <= k, ub > 0, c >= 0, "
            f"got k={k}, kb={kb}, ub={ub}, c={c}"
        )
        raise ModelError(msg)


class BilinearElastic(Device):
    """Bilinear elastic rubber bearing, Eq. (9) of [004], uncoupled x / y.

    Parameters
    ----------
    k : float
        Initial stiffness, N/m.
    kb : float
        Post-yield stiffness (k-bar), N/m.
    ub : float
        Yield displacement (u-bar), m.
    c : sequence of float
        Viscous damping per direction, N s/m (length n_dir).
    name : str
        Label.
    y_scale : float
        Stiffnesses in y over those in x (an anisotropic bearing; the yield displacement is
        the same), default 1.
    """

    kind = KIND_BILINEAR_ELASTIC

    def __init__(
        self, k: float, kb: float, ub: float, c: list[float], *, name: str = "RB",
        y_scale: float = 1.0,
    ) -> None:
        c = [float(x) for x in np.atleast_1d(c)]
        _check(k, kb, ub, c)
        if not y_scale > 0:
            msg = f"y_scale: expected > 0, got {y_scale}"
            raise ModelError(msg)
        n = len(c)
        cc = c + [0.0] * (2 - n)
        super().__init__([k, kb, ub, *cc, float(n), float(y_scale)], n_dir=n, name=name)

    def reference_damping(self) -> FloatArray:
        """Return diag(c)."""
        return np.diag(self.params[3:5])


class BilinearHysteretic(BilinearElastic):
    """Hysteretic bilinear (kinematic hardening), same parameters as :class:`BilinearElastic`."""

    kind = KIND_BILINEAR_HYSTERETIC


# Table 10 of [004]: k (MN/m), kb (MN/m), ub (m), cxx, cyy (Mg/s).
_TABLE10_RB = {
    "RB1": (1.075e6, 0.786e6, 0.0258, 24.83e3, 20.47e3),
    "RB2": (1.025e6, 0.772e6, 0.0309, 26.90e3, 24.20e3),
}


def table10_rubber_bearing(device: str) -> BilinearElastic:
    """Return RB1 or RB2 as calibrated in Table 10 of [004] (bidirectional, SI units).

    Raises
    ------
    ModelError
        For a label other than "RB1" or "RB2".
    """
    if device not in _TABLE10_RB:
        msg = f"device: expected one of {sorted(_TABLE10_RB)}, got {device!r}"
        raise ModelError(msg)
    k, kb, ub, cx, cy = _TABLE10_RB[device]
    return BilinearElastic(k, kb, ub, [cx, cy], name=device)
