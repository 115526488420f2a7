"""Jitted dispatch from a kind code to its law; shared by the device classes and the twin."""

from __future__ import annotations

import numpy as np
from numba import njit

from modal_twin.models.devices.base import (
    KIND_BILINEAR_ELASTIC,
    KIND_BILINEAR_HYSTERETIC,
    KIND_BW_ESB,
    KIND_BW_SDP,
    KIND_COULOMB,
    KIND_CUBIC,
    KIND_GAP,
    KIND_IWAN,
    KIND_LINEAR,
    KIND_MAXWELL,
    KIND_PRANDTL,
    KIND_SMOOTH_BILINEAR,
)
from modal_twin.models.devices.bilinear import law_bilinear_elastic, law_bilinear_hysteretic
from modal_twin.models.devices.bouc_wen import law_bw_esb, law_bw_sdp
from modal_twin.models.devices.coulomb import law_coulomb
from modal_twin.models.devices.cubic import law_cubic
from modal_twin.models.devices.gap import law_gap
from modal_twin.models.devices.iwan import law_iwan
from modal_twin.models.devices.linear import law_linear
from modal_twin.models.devices.maxwell import law_maxwell
from modal_twin.models.devices.prandtl import law_prandtl
from modal_twin.models.devices.smooth_bilinear import law_smooth_bilinear

__all__ = ["drive_law", "evaluate_law"]


@njit(cache=True)
def evaluate_law(kind, p, s, u, v, f, Kt, Ct, s_new):  # noqa: C901  # pragma: no cover - jitted
    """Call the law of ``kind`` (base.KIND_*); outputs written in place.

    The KIND_* are module-level ints, which numba freezes as compile-time constants: the
    comparisons compile to the same code as literals. numba's disk cache is keyed on this
    file only: after changing a code in base.py, or a law in its own file (the Bouc-Wen
    ``uncoupled`` slot), touch this file (and twin/kernels.py).
    """
    if kind == KIND_LINEAR:
        law_linear(p, s, u, v, f, Kt, Ct, s_new)
    elif kind == KIND_BILINEAR_ELASTIC:
        law_bilinear_elastic(p, s, u, v, f, Kt, Ct, s_new)
    elif kind == KIND_BILINEAR_HYSTERETIC:
        law_bilinear_hysteretic(p, s, u, v, f, Kt, Ct, s_new)
    elif kind == KIND_BW_ESB:
        law_bw_esb(p, s, u, v, f, Kt, Ct, s_new)
    elif kind == KIND_BW_SDP:
        law_bw_sdp(p, s, u, v, f, Kt, Ct, s_new)
    elif kind == KIND_PRANDTL:
        law_prandtl(p, s, u, v, f, Kt, Ct, s_new)
    elif kind == KIND_CUBIC:
        law_cubic(p, s, u, v, f, Kt, Ct, s_new)
    elif kind == KIND_COULOMB:
        law_coulomb(p, s, u, v, f, Kt, Ct, s_new)
    elif kind == KIND_GAP:
        law_gap(p, s, u, v, f, Kt, Ct, s_new)
    elif kind == KIND_MAXWELL:
        law_maxwell(p, s, u, v, f, Kt, Ct, s_new)
    elif kind == KIND_SMOOTH_BILINEAR:
        law_smooth_bilinear(p, s, u, v, f, Kt, Ct, s_new)
    elif kind == KIND_IWAN:
        law_iwan(p, s, u, v, f, Kt, Ct, s_new)
    else:
        msg = "unknown device kind"
        raise ValueError(msg)


@njit(cache=True)
def drive_law(kind, p, s0, U, V):  # pragma: no cover - jitted
    """Drive one law along U, V (2, nt) committing every sample; return f, Kt, final state."""
    nt = U.shape[1]
    F = np.zeros((2, nt))
    KT = np.zeros((2, 2, nt))
    s = s0.copy()
    s_new = np.zeros_like(s0)
    f = np.zeros(2)
    Kt = np.zeros((2, 2))
    Ct = np.zeros((2, 2))
    u = np.zeros(2)
    v = np.zeros(2)
    for k in range(nt):
        u[0] = U[0, k]
        u[1] = U[1, k]
        v[0] = V[0, k]
        v[1] = V[1, k]
        evaluate_law(kind, p, s, u, v, f, Kt, Ct, s_new)
        F[0, k] = f[0]
        F[1, k] = f[1]
        KT[:, :, k] = Kt
        s[:] = s_new
    return F, KT, s
