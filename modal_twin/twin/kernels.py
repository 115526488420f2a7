"""Jitted time-stepping loop of the modal twin (see :mod:`modal_twin.twin.simulator`).

One call of :func:`run_block` advances a run of samples with everything in one compiled
loop: the first-order-hold propagation of the diagonal modal state, the implicit solve for
the device forces and the state commit. All work arrays are allocated once per call; the
loop itself allocates nothing. Complex modal quantities are carried as [real; imaginary]
float vectors. Small matrix products are written as fixed loops (axpy form where the
inner dimension is short) so that the compiler vectorises them without BLAS call overhead.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from modal_twin.models.devices._dispatch import evaluate_law

__all__ = [
    "FLAG_JINV",
    "FLAG_STARTED",
    "STATUS_DIVERGED",
    "STATUS_NONFINITE",
    "STATUS_OK",
    "invert_inplace",
    "run_block",
]

STATUS_OK = 0
STATUS_NONFINITE = 1
STATUS_DIVERGED = 2

FLAG_STARTED = 0  # flags[0]: a previous sample exists (else the next one is the rest state)
FLAG_JINV = 1  # flags[1]: Jinv holds the inverse of a device Jacobian (possibly stale)
FLAG_REFRESH = 2  # flags[2]: number of Jacobian refreshes (diagnostic counter)


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
            for j in range(n):
                tmp = J[k, j]
                J[k, j] = J[piv, j]
                J[piv, j] = tmp
                tmp = Jinv[k, j]
                Jinv[k, j] = Jinv[piv, j]
                Jinv[piv, j] = tmp
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


@njit(cache=True, fastmath={"reassoc", "contract"})
def run_block(
    ag, k_begin, k_end, lr, li, e0r, e0i, e1r, e1i, GaT, GfT, P, HT,
    kinds, params, Kr, Cr, kjump, cjump, X, w_prev, ft, ft_old, Jinv, flags, states,
    Z, out_u, out_f, out_it, rtol, max_iter,
):  # pragma: no cover - jitted
    """Advance the modal state over samples ``k_begin <= k < k_end`` of ``ag``.

    Parameters (all float64 C-contiguous unless said otherwise; ns complex modes, nf = 2
    n_dev device rows, n_in inputs):

    - ``ag`` (n_in, nb) input; ``lr, li, e0r, e0i, e1r, e1i`` (ns,) exp(lambda dt) and the
      first-order-hold weights E0, E1; ``GaT`` (n_in, 2 ns) and ``GfT`` (nf, 2 ns) the
      transposed input projections [Re; Im] V^-1 B_w; ``P`` (2 nf, 2 ns) modal state ->
      [u; v]; ``HT`` (nf, 2 nf) the transposed map ft -> [u; v] of the implicit step.
    - ``kinds`` (n_dev,) int64, ``params``, ``states`` (n_dev, N_PARAM / N_STATE), ``Kr``,
      ``Cr`` (n_dev, 2, 2) reference stiffness and damping moved into the linear part;
      ``kjump``, ``cjump`` (n_dev,) stiffness and damping a law may switch to that neither
      its tangent nor Kr shows (contact, sticking), for the error bound below.
    - State, updated in place: ``X``, ``w_prev`` (2 ns) modal state and carried projected
      input; ``ft``, ``ft_old`` (nf) residual device force ``f - Kr u - Cr v`` of the last
      two samples; ``Jinv`` (nf, nf) inverse device Jacobian kept between samples;
      ``flags`` int64 (see FLAG_*).
    - Outputs: ``Z`` (k_end - k_begin, 2 ns + n_in + nf) rows [X; a_g; f] for the output
      products; ``out_u``, ``out_f`` (nf, nb) drift and force; ``out_it`` (nb,) int64
      device evaluations per sample.

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

    Returns (status, k) with k the failing sample (k_end when all went well).
    """
    ns = lr.shape[0]
    n2 = 2 * ns
    n_in = ag.shape[0]
    nf = ft.shape[0]
    nf2 = 2 * nf
    nd = kinds.shape[0]
    S = states.shape[1]
    col_f = n2 + n_in
    g = np.empty(n2)
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
    for k in range(k_begin, k_end):
        row = k - k_begin
        # input projection of this sample, g = Ga a_k (axpy over the n_in inputs)
        for r in range(n2):
            g[r] = 0.0
        for c in range(n_in):
            a = ag[c, k]
            Z[row, n2 + c] = a
            for r in range(n2):
                g[r] += GaT[c, r] * a
        if flags[FLAG_STARTED] == 0:  # rest state at the first sample of a run
            for r in range(n2):
                w_prev[r] = g[r]
                X[r] = 0.0
                Z[row, r] = 0.0
            for i in range(nf):
                ft[i] = 0.0
                ft_old[i] = 0.0
                Z[row, col_f + i] = 0.0
                out_u[i, k] = 0.0
                out_f[i, k] = 0.0
            out_it[k] = 0
            flags[FLAG_STARTED] = 1
            continue
        # linear part with the new residual force set to zero (complex products, split)
        for r in range(ns):
            xr = X[r]
            xi = X[ns + r]
            wr = w_prev[r]
            wi = w_prev[ns + r]
            Xp[r] = (lr[r] * xr - li[r] * xi + e0r[r] * wr - e0i[r] * wi
                     + e1r[r] * g[r] - e1i[r] * g[ns + r])
            Xp[ns + r] = (lr[r] * xi + li[r] * xr + e0r[r] * wi + e0i[r] * wr
                          + e1r[r] * g[ns + r] + e1i[r] * g[r])
        bad = False
        for i in range(nf2):
            acc = 0.0
            for r in range(n2):
                acc += P[i, r] * Xp[r]
            uvp[i] = acc
            if not np.isfinite(acc):
                bad = True
        if bad:
            return STATUS_NONFINITE, k
        # force predictor (linear extrapolation) and its drifts u, v = uvp + H ft
        for i in range(nf):
            f0 = ft[i]
            ft[i] = 2.0 * f0 - ft_old[i]
            ft_old[i] = f0
        for i in range(nf2):
            uv[i] = uvp[i]
        for j in range(nf):
            fj = ft[j]
            for i in range(nf2):
                uv[i] += HT[j, i] * fj
        converged = False
        corrected = False
        fresh = False
        it = 0
        while True:
            scale = 0.0
            for d in range(nd):
                i0 = 2 * d
                ud[0] = uv[i0]
                ud[1] = uv[i0 + 1]
                vd[0] = uv[nf + i0]
                vd[1] = uv[nf + i0 + 1]
                evaluate_law(kinds[d], params[d], states[d], ud, vd, fd, Kt, Ct, s_trial[d])
                for a in range(2):
                    lin = (Kr[d, a, 0] * ud[0] + Kr[d, a, 1] * ud[1]
                           + Cr[d, a, 0] * vd[0] + Cr[d, a, 1] * vd[1])
                    for b in range(2):
                        DK[i0 + a, b] = Kt[a, b] - Kr[d, a, b]
                        DC[i0 + a, b] = Ct[a, b] - Cr[d, a, b]
                    fful[i0 + a] = fd[a]
                    R[i0 + a] = ft[i0 + a] - (fd[a] - lin)
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
                for j in range(nf):
                    dj = dft[j]
                    for i in range(nf2):
                        duv[i] += HT[j, i] * dj
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
        for r in range(n2):
            fg[r] = 0.0
        for j in range(nf):
            fj = ft[j]
            for r in range(n2):
                fg[r] += GfT[j, r] * fj
        for r in range(ns):
            xr = Xp[r] + e1r[r] * fg[r] - e1i[r] * fg[ns + r]
            xi = Xp[ns + r] + e1r[r] * fg[ns + r] + e1i[r] * fg[r]
            X[r] = xr
            X[ns + r] = xi
            Z[row, r] = xr
            Z[row, ns + r] = xi
        for r in range(n2):
            w_prev[r] = g[r] + fg[r]
        for i in range(nf):
            out_u[i, k] = uv[i]
            out_f[i, k] = fful[i]
            Z[row, col_f + i] = fful[i]
        out_it[k] = it
    return STATUS_OK, k_end
