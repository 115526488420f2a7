"""Jitted time-stepping loop of the modal twin (see :mod:`modal_twin.twin.simulator`).

Work is split by what depends on the device forces. Everything of a sample that depends on
its input alone (the input projections of the modal state and of the drift prediction) is
one block product per sub-block of samples before their loop (:func:`project_inputs`); the
outputs are one BLAS product after it (:mod:`modal_twin.twin.simulator`). One call of
:func:`run_block` then advances a run of samples with only the device feedback in the
compiled loop: the first-order-hold propagation of the diagonal modal state, the drift
prediction, the implicit solve for the device forces and the state commit. All work arrays
are allocated once per call; the loop itself allocates nothing. Complex modal quantities are
carried as [real; imaginary] float vectors. Small matrix products are written as fixed loops
(dot form four rows at a time over the 2 ns modal coordinates, :func:`gemv_t` axpy form four
rows per pass over the short dimensions) so that the compiler vectorises them without BLAS
call overhead, in an order that depends only on the shapes (the state does not depend on how
a record is split into blocks). The device laws are called directly (an if-chain on the kind
code instead of a call through ``evaluate_law``: that extra call level cost ~45 ns per
device and sample), one branch per kind code of the device registry
(:data:`modal_twin.models.devices.registry.KINDS`); a code without a branch stops the block
with ``STATUS_UNKNOWN_KIND`` (test/twin/test_kernel_laws.py runs every registry law through
the kernel and through the law's own implementation). The Bouc-Wen devices advance their
hysteretic variables together (:func:`modal_twin.models.devices.bouc_wen.bw_advance_many`,
which reads the SDP's ``uncoupled`` slot ``BW_UNCOUPLED``; numba's cache of this file does
not see a change in that one: clear it after one). The law functions are compiled on
their own, without the loop's fast-math flags, so every law returns exactly what
:meth:`Device.evaluate` returns (test/twin/test_simulator.py checks it bitwise).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from modal_twin._types import FloatArray, IntArray
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
from modal_twin.models.devices.bouc_wen import bw_advance_many, bw_esb_force, bw_sdp_force
from modal_twin.models.devices.coulomb import law_coulomb
from modal_twin.models.devices.cubic import law_cubic
from modal_twin.models.devices.gap import law_gap
from modal_twin.models.devices.iwan import law_iwan
from modal_twin.models.devices.linear import law_linear
from modal_twin.models.devices.maxwell import law_maxwell
from modal_twin.models.devices.prandtl import law_prandtl
from modal_twin.models.devices.smooth_bilinear import law_smooth_bilinear

__all__ = [
    "FLAG_JINV",
    "FLAG_STARTED",
    "STATUS_DIVERGED",
    "STATUS_NONFINITE",
    "STATUS_OK",
    "STATUS_UNKNOWN_KIND",
    "BlockRows",
    "DeviceArrays",
    "LoopMatrices",
    "LoopState",
    "gemv_dot4",
    "gemv_t",
    "invert_inplace",
    "project_inputs",
    "run_block",
]

STATUS_OK = 0
STATUS_NONFINITE = 1
STATUS_DIVERGED = 2
STATUS_UNKNOWN_KIND = 3  # a device's kind code has no branch in run_block

FLAG_STARTED = 0  # flags[0]: a previous sample exists (else the next one is the rest state)
FLAG_JINV = 1  # flags[1]: Jinv holds the inverse of a device Jacobian (possibly stale)
FLAG_REFRESH = 2  # flags[2]: number of Jacobian refreshes (diagnostic counter)


@njit(cache=True, inline="always")
def _swap_rows(J, Jinv, k, piv):  # pragma: no cover - jitted
    """Exchange rows k and piv of J and of Jinv."""
    for j in range(J.shape[1]):
        tmp = J[k, j]
        J[k, j] = J[piv, j]
        J[piv, j] = tmp
        tmp = Jinv[k, j]
        Jinv[k, j] = Jinv[piv, j]
        Jinv[piv, j] = tmp


@njit(cache=True)
def invert_inplace(J, Jinv):  # pragma: no cover - jitted
    """Jinv = J^-1 by Gauss-Jordan elimination with partial pivoting (J is destroyed).

    A zero pivot leaves inf / nan in Jinv; the caller detects it as a non-finite state.
    """
    n = J.shape[0]
    for i in range(n):
        for j in range(n):
            Jinv[i, j] = 0.0
        Jinv[i, i] = 1.0
    for k in range(n):
        piv = k
        big = abs(J[k, k])
        for i in range(k + 1, n):
            if abs(J[i, k]) > big:
                big = abs(J[i, k])
                piv = i
        if piv != k:
            _swap_rows(J, Jinv, k, piv)
        inv = 1.0 / J[k, k]
        for j in range(n):
            J[k, j] *= inv
            Jinv[k, j] *= inv
        for i in range(n):
            if i != k:
                m = J[i, k]
                if m != 0.0:
                    for j in range(n):
                        J[i, j] -= m * J[k, j]
                        Jinv[i, j] -= m * Jinv[k, j]


@njit(cache=True, fastmath={"reassoc", "contract"}, inline="always")
def gemv_t(y, AT, x):  # pragma: no cover - jitted
    """y += AT^T x in axpy form, four rows of AT per pass over y (AT is (m, n), y (n,)).

    The order of the operations depends only on the shapes, so the result of a sample
    never depends on how a record was split into blocks.
    """
    m = x.shape[0]
    n = y.shape[0]
    m4 = m - m % 4
    for j in range(0, m4, 4):
        x0 = x[j]
        x1 = x[j + 1]
        x2 = x[j + 2]
        x3 = x[j + 3]
        for i in range(n):
            y[i] += AT[j, i] * x0 + AT[j + 1, i] * x1 + AT[j + 2, i] * x2 + AT[j + 3, i] * x3
    for j in range(m4, m):
        xj = x[j]
        for i in range(n):
            y[i] += AT[j, i] * xj


@njit(cache=True, fastmath={"reassoc", "contract"}, inline="always")
def gemv_dot4(y, A, x):  # pragma: no cover - jitted
    """y += A x in dot form, four rows of A per pass over x (A is (m, n), m a multiple of 4).

    Each pass keeps four running sums, so x is read once per four rows; the order of the
    operations depends only on the shapes (see :func:`gemv_t`).
    """
    n = x.shape[0]
    for i in range(0, A.shape[0], 4):
        a0 = 0.0
        a1 = 0.0
        a2 = 0.0
        a3 = 0.0
        for r in range(n):
            xr = x[r]
            a0 += A[i, r] * xr
            a1 += A[i + 1, r] * xr
            a2 += A[i + 2, r] * xr
            a3 += A[i + 3, r] * xr
        y[i] += a0
        y[i + 1] += a1
        y[i + 2] += a2
        y[i + 3] += a3


@njit(cache=True, fastmath={"reassoc", "contract"})
def project_inputs(ag, k_begin, k_end, PinT, Ain):  # pragma: no cover - jitted
    """Block product before the per-sample loop: ``Ain[k - k_begin] = Pin a_k``.

    ``PinT`` (n_in, m) is the transposed map from the inputs of a sample to everything of
    it that does not depend on the device forces (see :func:`run_block`). Every row is
    computed by :func:`gemv_t` on its own, so a sample's numbers depend only on the
    shapes, never on how the record was split into blocks (a BLAS product may order a
    sum differently at the edge of a tile).
    """
    m = PinT.shape[1]
    n_in = ag.shape[0]
    ak = np.empty(n_in)
    for k in range(k_begin, k_end):
        row = Ain[k - k_begin]
        for c in range(n_in):
            ak[c] = ag[c, k]
        for i in range(m):
            row[i] = 0.0
        gemv_t(row, PinT, ak)


class LoopMatrices(NamedTuple):
    """Constant matrices of the linear part the loop multiplies (float64, C-contiguous).

    ns complex modes, nf = 2 n_dev device rows, n_in inputs (see :func:`run_block`).

    Attributes
    ----------
    PinT : (n_in, 4 ns + 4 nf)
        Transposed map from the inputs of a sample to everything of it that depends on its
        input alone: rows [E1 g_k; E0 g_k; Ua1 a_k; Ua0 a_k] with g_k = Ga a_k (complex
        vectors split [Re; Im]).
    coef : (6, ns)
        Rows Re / Im of exp(lambda dt) and of the first-order-hold weights E0, E1.
    GfT : (nf, 2 ns)
        Transposed force projection [Re; Im] V^-1 B_f.
    Q : (2 nf, 2 ns)
        P exp(Lambda dt), P the map modal state -> [u; v].
    HfT : (nf, 2 nf)
        Transposed map P (exp(Lambda dt) E1 + E0) Gf.
    HT : (nf, 2 nf)
        Transposed map P E1 Gf: ft -> [u; v] of the implicit step.
    """

    PinT: FloatArray
    coef: FloatArray
    GfT: FloatArray
    Q: FloatArray
    HfT: FloatArray
    HT: FloatArray


class DeviceArrays(NamedTuple):
    """The devices as the loop sees them (n_dev devices; constant during a run).

    Attributes
    ----------
    kinds : (n_dev,) int64
        Kind codes, :data:`modal_twin.models.devices.registry.KINDS`.
    bw_idx : (m,) int64
        The Bouc-Wen devices, whose hysteretic variables are advanced together
        (:func:`modal_twin.models.devices.bouc_wen.bw_advance_many`).
    params : (n_dev, N_PARAM)
        Law parameters.
    consts : (n_dev,)
        Per-device constant of a law (ESB: its pressure factor).
    Kr, Cr : (n_dev, 2, 2)
        Reference stiffness and damping moved into the linear part.
    kjump, cjump : (n_dev,)
        Stiffness and damping a law may switch to that neither its tangent nor Kr shows
        (contact, sticking), for the error bound of :func:`run_block`.
    """

    kinds: IntArray
    bw_idx: IntArray
    params: FloatArray
    consts: FloatArray
    Kr: FloatArray
    Cr: FloatArray
    kjump: FloatArray
    cjump: FloatArray


class LoopState(NamedTuple):
    """What the loop carries from one sample (and one block) to the next, updated in place.

    Attributes
    ----------
    Xh : (2 ns,)
        The part ``exp(Lambda dt) xi_k + E0 w_k`` of the next predicted modal state known
        after sample k (w_k: projected input and force).
    base : (2 nf,)
        The part ``Q xi_p + Ua0 a`` of the next drift prediction.
    ft, ft_old : (nf,)
        Residual device force ``f - Kr u - Cr v`` of the last two samples.
    Jinv : (nf, nf)
        Inverse device Jacobian kept between samples.
    flags : (3,) int64
        See FLAG_*.
    states : (n_dev, S)
        Committed device states, S the largest ``n_state`` of the plant's laws
        (:class:`~modal_twin.models.devices.base.Device`).
    """

    Xh: FloatArray
    base: FloatArray
    ft: FloatArray
    ft_old: FloatArray
    Jinv: FloatArray
    flags: IntArray
    states: FloatArray


class BlockRows(NamedTuple):
    """Work and output rows of one kernel call (rows per sample of the block).

    Attributes
    ----------
    Ain : (n_sub, 4 ns + 4 nf)
        Work: the input projections of n_sub samples (:func:`project_inputs`), a sub-block
        small enough to stay in the L2 cache.
    Z : (k_end - k_begin, 2 ns + n_in + nf)
        Rows [X; a_g; f] for the output products (the device forces are its last nf
        columns).
    U : (k_end - k_begin, nf)
        The drifts (the caller transposes Z and U per chunk: writing (nf, nb) arrays here
        would touch nf pages per sample).
    out_it : (nb,) int64
        Device evaluations per sample.
    """

    Ain: FloatArray
    Z: FloatArray
    U: FloatArray
    out_it: IntArray


# run_block stays one function on purpose: split along its steps (device laws, Newton
# correction, modal commit) into numba helpers, its results were bitwise the same but the
# per-sample loop took 1.51-1.56 us instead of 1.27-1.32 us with inline="always" helpers
# and 1.84 us with separately compiled ones (bench_twin.py --repeat 9, 2026-11-24); helpers
# for only the rarely run parts (rest state, Newton correction) still cost 6-10 % of a
# step (2026-11-25). The twin's speed is a goal of its own (issue 14), so the steps are
# marked by comments below. Its arrays come in four typed groups (LoopMatrices,
# DeviceArrays, LoopState, BlockRows), unpacked once per call: that costs nothing measurable.
@njit(cache=True, fastmath={"reassoc", "contract"})
def run_block(  # noqa: C901 (one loop on purpose, see above)
    ag, k_begin, k_end, lin, dev, st, rows, rtol, max_iter,
):  # pragma: no cover - jitted
    """Advance the modal state over samples ``k_begin <= k < k_end`` of a block.

    Parameters
    ----------
    ag : (n_in, nb) float64
        Input.
    k_begin, k_end : int
        Samples of ``ag`` to advance.
    lin : LoopMatrices
        The linear part. Everything of a sample that depends on its input alone is computed
        by :func:`project_inputs` for n_sub samples at a time before their loop.
    dev : DeviceArrays
        The devices.
    st : LoopState
        The carried state, updated in place. The loop itself carries only what the device
        forces feed back into.
    rows : BlockRows
        Work and output rows.
    rtol : float
        Newton tolerance relative to the largest device force.
    max_iter : int
        Device evaluations allowed per sample.

    Returns
    -------
    status, index
        ``(STATUS_OK, k_end)``; ``(STATUS_NONFINITE | STATUS_DIVERGED, k)`` with k the
        failing sample; ``(STATUS_UNKNOWN_KIND, d)`` with d a device whose kind code has no
        branch here (the caller names its law; nothing is run in its place).

    Notes
    -----
    Drift prediction: the drift [u; v] = P xi_p,k+1 of the next sample with its device force
    set to zero is ``Q xi_p,k + Ua0 a_k + Ua1 a_k+1 + Hf ft_k`` (expand xi_p,k+1 = Lambda
    xi_k + E0 w_k + E1 g_k+1 with xi_k = xi_p,k + E1 Gf ft_k and w_k = g_k + Gf ft_k). The
    big product ``Q xi_p,k`` does not depend on the device forces of sample k, so it is
    computed before them, off the path from one Newton solve to the next, on which only
    the (2 nf, nf) product ``Hf ft_k`` remains.

    Device forces: Newton on R(ft) = ft - [f(u, v) - Kr u - Cr v] with u, v = uvp + H ft,
    from the linear extrapolation ``2 ft_k - ft_{k-1}``, with the inverse Jacobian
    ``(I - D H)^-1`` (D = block-diagonal device tangents minus Kr, Cr) kept from an earlier
    sample while its first-order residual stays below the tolerance (modified Newton),
    rebuilt otherwise. A sample is accepted when the evaluated residual is below
    ``rtol * max|f|``, or when the Newton correction ``delta`` just computed is itself
    below it: a bound of the residual after the correction is its first-order part
    ``|R + delta - D H delta|`` plus ``(2 |Kt - Kr| + kjump) |H_u delta| + (2 |Ct - Cr| +
    cjump) |H_v delta|``: the linearisation error if the nonlinear part of a tangent changes
    by up to twice itself over the corrected drift (the viscous and K_ref parts are exact),
    or jumps to kjump / cjump (contact, sticking). The
    device states are then committed at the evaluated drift, and the corrected drift and
    force are reported (they are the ones the structure sees). The device coupling through
    H is weak at a building's time step (the force barely moves its own drift within one
    step), so most samples need one law evaluation per device.
    """
    PinT, coef, GfT, Q, HfT, HT = lin.PinT, lin.coef, lin.GfT, lin.Q, lin.HfT, lin.HT
    kinds, bw_idx, params, consts = dev.kinds, dev.bw_idx, dev.params, dev.consts
    Kr, Cr, kjump, cjump = dev.Kr, dev.Cr, dev.kjump, dev.cjump
    Xh, base, ft, ft_old, Jinv = st.Xh, st.base, st.ft, st.ft_old, st.Jinv
    flags, states = st.flags, st.states
    Ain, Z, U, out_it = rows.Ain, rows.Z, rows.U, rows.out_it
    ns = coef.shape[1]
    n2 = 2 * ns
    nf = ft.shape[0]
    nf2 = 2 * nf
    nd = kinds.shape[0]
    S = states.shape[1]
    n_in = ag.shape[0]
    col_f = n2 + n_in
    n_sub = Ain.shape[0]
    o_ua1 = 2 * n2  # offsets in a row of Ain: [E1 g (n2), E0 g (n2), Ua1 a, Ua0 a]
    o_ua0 = o_ua1 + nf2
    fg = np.empty(n2)
    Xp = np.empty(n2)
    uvp = np.empty(nf2)
    uv = np.empty(nf2)
    duv = np.empty(nf2)
    fful = np.empty(nf)
    R = np.empty(nf)
    dft = np.empty(nf)
    DK = np.zeros((nf, 2))
    DC = np.zeros((nf, 2))
    J = np.empty((nf, nf))
    ud = np.empty(2)
    vd = np.empty(2)
    fd = np.empty(2)
    Kt = np.empty((2, 2))
    Ct = np.empty((2, 2))
    s_trial = np.empty((nd, S))
    n_bw = bw_idx.shape[0]
    bw_tan = np.zeros((nd, 4))
    bw_work = np.empty((11, n_bw))
    bw_nsub = np.empty(n_bw, dtype=np.int64)
    lr = coef[0]
    li = coef[1]
    e0r = coef[2]
    e0i = coef[3]
    e1r = coef[4]
    e1i = coef[5]
    for k in range(k_begin, k_end):
        row = k - k_begin
        # everything of this sample that depends on its input alone is computed before the
        # samples' loop, one block product per sub-block of Ain's rows (project_inputs):
        # E1 g_k, E0 g_k, Ua1 a_k, Ua0 a_k
        sub = row % n_sub
        if sub == 0:
            project_inputs(ag, k, min(k_end, k + n_sub), PinT, Ain)
        pin = Ain[sub]
        for c in range(n_in):
            Z[row, n2 + c] = ag[c, k]
        if flags[FLAG_STARTED] == 0:  # rest state at the first sample of a run
            for r in range(n2):  # xi = 0, w = g: Xh = E0 g
                Xh[r] = pin[n2 + r]
                Z[row, r] = 0.0
            for i in range(nf2):  # xi_p = xi = 0: base = Ua0 a_k
                base[i] = pin[o_ua0 + i]
            for i in range(nf):
                ft[i] = 0.0
                ft_old[i] = 0.0
                Z[row, col_f + i] = 0.0
                U[row, i] = 0.0
            out_it[k] = 0
            flags[FLAG_STARTED] = 1
            continue
        # linear part with the new residual force set to zero:
        # xi_p,k = exp(Lambda dt) xi_k-1 + E0 w_k-1 (carried in Xh) + E1 g_k
        for r in range(n2):
            Xp[r] = Xh[r] + pin[r]
        # drift of this sample with its device force set to zero (see docstring):
        # uvp = Q xi_p,k-1 + Ua0 a_k-1 (carried in base) + Ua1 a_k + Hf ft_k-1
        for i in range(nf2):
            uvp[i] = base[i] + pin[o_ua1 + i]
        gemv_t(uvp, HfT, ft)
        bad = 0.0
        for i in range(nf2):
            bad += uvp[i]
        if not np.isfinite(bad):  # a non-finite entry makes the sum non-finite
            return STATUS_NONFINITE, k
        # base of the next sample, Q xi_p,k + Ua0 a_k: independent of this sample's device
        # forces (overlaps with the laws below); dot form four rows at a time (nf2 = 4 n_dev)
        for i in range(nf2):
            base[i] = pin[o_ua0 + i]
        gemv_dot4(base, Q, Xp)
        # force predictor (linear extrapolation) and its drifts u, v = uvp + H ft
        for i in range(nf):
            f0 = ft[i]
            ft[i] = 2.0 * f0 - ft_old[i]
            ft_old[i] = f0
        for i in range(nf2):
            uv[i] = uvp[i]
        gemv_t(uv, HT, ft)
        converged = False
        corrected = False
        fresh = False
        it = 0
        while True:
            scale = 0.0
            if n_bw > 0:
                bw_advance_many(bw_idx, params, states, uv, s_trial, bw_tan, bw_work, bw_nsub)
            for d in range(nd):
                i0 = 2 * d
                ud[0] = uv[i0]
                ud[1] = uv[i0 + 1]
                vd[0] = uv[nf + i0]
                vd[1] = uv[nf + i0 + 1]
                kind = kinds[d]
                pd = params[d]
                sd = states[d]
                sn = s_trial[d]
                # one branch per kind code of the registry (direct calls, see the module
                # docstring); a code without a branch is refused, never run as another law
                if kind == KIND_BW_ESB:
                    bw_esb_force(pd, vd, fd, Kt, Ct, sn, bw_tan[d, 0], bw_tan[d, 1],
                                 bw_tan[d, 2], bw_tan[d, 3], consts[d])
                elif kind == KIND_BW_SDP:
                    bw_sdp_force(pd, ud, vd, fd, Kt, Ct, sn, bw_tan[d, 0], bw_tan[d, 1],
                                 bw_tan[d, 2], bw_tan[d, 3])
                elif kind == KIND_BILINEAR_ELASTIC:
                    law_bilinear_elastic(pd, sd, ud, vd, fd, Kt, Ct, sn)
                elif kind == KIND_LINEAR:
                    law_linear(pd, sd, ud, vd, fd, Kt, Ct, sn)
                elif kind == KIND_BILINEAR_HYSTERETIC:
                    law_bilinear_hysteretic(pd, sd, ud, vd, fd, Kt, Ct, sn)
                elif kind == KIND_PRANDTL:
                    law_prandtl(pd, sd, ud, vd, fd, Kt, Ct, sn)
                elif kind == KIND_CUBIC:
                    law_cubic(pd, sd, ud, vd, fd, Kt, Ct, sn)
                elif kind == KIND_COULOMB:
                    law_coulomb(pd, sd, ud, vd, fd, Kt, Ct, sn)
                elif kind == KIND_GAP:
                    law_gap(pd, sd, ud, vd, fd, Kt, Ct, sn)
                elif kind == KIND_MAXWELL:
                    law_maxwell(pd, sd, ud, vd, fd, Kt, Ct, sn)
                elif kind == KIND_SMOOTH_BILINEAR:
                    law_smooth_bilinear(pd, sd, ud, vd, fd, Kt, Ct, sn)
                elif kind == KIND_IWAN:
                    law_iwan(pd, sd, ud, vd, fd, Kt, Ct, sn)
                else:
                    return STATUS_UNKNOWN_KIND, d
                for a in range(2):
                    lin_f = (Kr[d, a, 0] * ud[0] + Kr[d, a, 1] * ud[1]
                             + Cr[d, a, 0] * vd[0] + Cr[d, a, 1] * vd[1])
                    for b in range(2):
                        DK[i0 + a, b] = Kt[a, b] - Kr[d, a, b]
                        DC[i0 + a, b] = Ct[a, b] - Cr[d, a, b]
                    fful[i0 + a] = fd[a]
                    R[i0 + a] = ft[i0 + a] - (fd[a] - lin_f)
                    scale = max(scale, abs(fd[a]))
            rmax = 0.0
            rsum = 0.0  # propagates a NaN that max() would drop
            for i in range(nf):
                rmax = max(rmax, abs(R[i]))
                rsum += R[i]
            if not np.isfinite(rsum):
                return STATUS_NONFINITE, k
            it += 1
            tol = rtol * scale
            if rmax <= tol or rmax == 0.0:
                converged = True
                break
            # Newton correction with the kept inverse; rebuilt when its first-order
            # residual |R + delta - D H delta| is not small against the tolerance
            for attempt in range(2):
                if flags[FLAG_JINV] == 0 or attempt == 1:
                    # Jacobian of R w.r.t. ft: I - DK Hu - DC Hv (DK, DC block diagonal)
                    for d in range(nd):
                        for a in range(2):
                            i = 2 * d + a
                            for j in range(nf):
                                J[i, j] = -(
                                    DK[i, 0] * HT[j, 2 * d]
                                    + DK[i, 1] * HT[j, 2 * d + 1]
                                    + DC[i, 0] * HT[j, nf + 2 * d]
                                    + DC[i, 1] * HT[j, nf + 2 * d + 1]
                                )
                            J[i, i] += 1.0
                    invert_inplace(J, Jinv)
                    flags[FLAG_JINV] = 1
                    flags[FLAG_REFRESH] += 1
                    fresh = True
                for i in range(nf):
                    acc = 0.0
                    for j in range(nf):
                        acc += Jinv[i, j] * R[j]
                    dft[i] = -acc
                for i in range(nf2):
                    duv[i] = 0.0
                gemv_t(duv, HT, dft)
                # bound of the residual after the correction (see docstring)
                emax = 0.0
                lmax = 0.0
                for d in range(nd):
                    i0 = 2 * d
                    for a in range(2):
                        i = i0 + a
                        lin1 = R[i] + dft[i]
                        e = kjump[d] * abs(duv[i]) + cjump[d] * abs(duv[nf + i])
                        for b in range(2):
                            du = duv[i0 + b]
                            dv = duv[nf + i0 + b]
                            lin1 -= DK[i, b] * du + DC[i, b] * dv
                            e += 2.0 * (abs(DK[i, b]) * abs(du) + abs(DC[i, b]) * abs(dv))
                        lmax = max(lmax, abs(lin1))
                        emax = max(emax, abs(lin1) + e)
                if fresh or lmax <= 0.25 * tol:
                    break
            for i in range(nf):
                ft[i] += dft[i]
            for i in range(nf2):
                uv[i] += duv[i]
            if emax <= tol:
                converged = True
                corrected = True
                break
            if it >= max_iter:
                break
        if not converged:
            return STATUS_DIVERGED, k
        if corrected:  # force the structure sees: ft + Kr u + Cr v at the corrected drift
            for d in range(nd):
                i0 = 2 * d
                for a in range(2):
                    fful[i0 + a] = ft[i0 + a] + (
                        Kr[d, a, 0] * uv[i0] + Kr[d, a, 1] * uv[i0 + 1]
                        + Cr[d, a, 0] * uv[nf + i0] + Cr[d, a, 1] * uv[nf + i0 + 1]
                    )
        # commit: device states, modal state, carried input term
        for d in range(nd):
            for c in range(S):
                states[d, c] = s_trial[d, c]
        for r in range(n2):  # fg = Gf ft
            fg[r] = 0.0
        gemv_t(fg, GfT, ft)
        # xi_k = xi_p,k + E1 Gf ft_k and the next Xh = exp(Lambda dt) xi_k + E0 Gf ft_k
        # + E0 g_k (the last term from before the loop) in one pass
        for r in range(ns):
            fr = fg[r]
            fi = fg[ns + r]
            xr = Xp[r] + e1r[r] * fr - e1i[r] * fi
            xi = Xp[ns + r] + e1r[r] * fi + e1i[r] * fr
            Z[row, r] = xr
            Z[row, ns + r] = xi
            Xh[r] = lr[r] * xr - li[r] * xi + e0r[r] * fr - e0i[r] * fi + pin[n2 + r]
            Xh[ns + r] = lr[r] * xi + li[r] * xr + e0r[r] * fi + e0i[r] * fr + pin[n2 + ns + r]
        for i in range(nf):
            U[row, i] = uv[i]
            Z[row, col_f + i] = fful[i]
        out_it[k] = it
    return STATUS_OK, k_end
