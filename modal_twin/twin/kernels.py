"""Jitted time-stepping loop of the modal twin (see :mod:`modal_twin.twin.simulator`)."""

from __future__ import annotations

import numpy as np
from numba import njit

from modal_twin.models.devices._dispatch import evaluate_law

__all__ = ["STATUS_DIVERGED", "STATUS_NONFINITE", "STATUS_OK", "run_block"]

STATUS_OK = 0
STATUS_NONFINITE = 1
STATUS_DIVERGED = 2


@njit(cache=True)
def _solve_inplace(J, r, n):  # pragma: no cover - jitted
    """Solve J x = r by Gaussian elimination with partial pivoting; x returned in r."""
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
            tmp = r[k]
            r[k] = r[piv]
            r[piv] = tmp
        inv = 1.0 / J[k, k]
        for i in range(k + 1, n):
            m = J[i, k] * inv
            if m != 0.0:
                for j in range(k + 1, n):
                    J[i, j] -= m * J[k, j]
                r[i] -= m * r[k]
    for k in range(n - 1, -1, -1):
        acc = r[k]
        for j in range(k + 1, n):
            acc -= J[k, j] * r[j]
        r[k] = acc / J[k, k]


@njit(cache=True, fastmath={"reassoc", "contract"})
def _matvec(A, x, out):  # pragma: no cover - jitted
    """out = A @ x for a C-contiguous A (reduction loop the compiler can vectorise)."""
    m, n = A.shape
    for i in range(m):
        acc = 0.0
        for j in range(n):
            acc += A[i, j] * x[j]
        out[i] = acc


@njit(cache=True)
def run_block(
    ag, started, lr, li, e0r, e0i, e1r, e1i, GaR, GaI, GfR, GfI, P, H,
    kinds, params, Kr, Cr, X, w_prev, ft, states,
    out_X, out_u, out_f, out_it, rtol, max_iter,
):  # pragma: no cover - jitted
    """Advance the modal state over one block of input samples.

    Diagonal exponential (first-order-hold) update of the linear modal part, implicit in
    the device forces, Newton on the residual device forces ``ft = f - Kr u - Cr v``.
    Complex modal quantities are carried as [real; imaginary] float vectors: ``X`` (2 ns)
    the modal state, ``w_prev`` (2 ns) the projected input of the previous sample; ``P``
    (2 nf, 2 ns) maps the modal state to [u; v], ``H`` (2 nf, nf) maps ft to [u; v].
    Returns (status, sample index); ``X``, ``w_prev``, ``ft``, ``states`` updated in place;
    ``started`` tells whether a previous sample exists (else sample 0 is the rest state).
    """
    ns = lr.shape[0]
    nb = ag.shape[1]
    nf = ft.shape[0]
    nd = kinds.shape[0]
    S = states.shape[1]
    a_k = np.empty(ag.shape[0])
    gr = np.empty(ns)
    gi = np.empty(ns)
    fr = np.empty(ns)
    fi = np.empty(ns)
    Xp = np.empty(2 * ns)
    uvp = np.empty(2 * nf)
    duv = np.empty(2 * nf)
    u = np.empty(nf)
    v = np.empty(nf)
    fful = np.empty(nf)
    R = np.empty(nf)
    DK = np.zeros((nf, 2))
    DC = np.zeros((nf, 2))
    J = np.empty((nf, nf))
    ud = np.empty(2)
    vd = np.empty(2)
    fd = np.empty(2)
    Kt = np.empty((2, 2))
    Ct = np.empty((2, 2))
    s_trial = np.empty((nd, S))
    for k in range(nb):
        for c in range(a_k.shape[0]):
            a_k[c] = ag[c, k]
        _matvec(GaR, a_k, gr)  # input projection of this sample: Ga a_k
        _matvec(GaI, a_k, gi)
        if not started:
            for r in range(ns):
                w_prev[r] = gr[r]
                w_prev[ns + r] = gi[r]
            for r in range(2 * ns):
                X[r] = 0.0
                out_X[r, k] = 0.0
            for i in range(nf):
                ft[i] = 0.0
                out_u[i, k] = 0.0
                out_f[i, k] = 0.0
            out_it[k] = 0
            started = True
            continue
        # predictor with the new residual force set to zero (complex products, split)
        for r in range(ns):
            xr = X[r]
            xi = X[ns + r]
            wr = w_prev[r]
            wi = w_prev[ns + r]
            Xp[r] = (lr[r] * xr - li[r] * xi + e0r[r] * wr - e0i[r] * wi
                     + e1r[r] * gr[r] - e1i[r] * gi[r])
            Xp[ns + r] = (lr[r] * xi + li[r] * xr + e0r[r] * wi + e0i[r] * wr
                          + e1r[r] * gi[r] + e1i[r] * gr[r])
        _matvec(P, Xp, uvp)
        bad = False
        for i in range(2 * nf):
            if not np.isfinite(uvp[i]):
                bad = True
        if bad:
            return STATUS_NONFINITE, k
        converged = False
        it = 0
        while it < max_iter:
            _matvec(H, ft, duv)
            for i in range(nf):
                u[i] = uvp[i] + duv[i]
                v[i] = uvp[nf + i] + duv[nf + i]
            scale = 0.0
            for d in range(nd):
                ud[0] = u[2 * d]
                ud[1] = u[2 * d + 1]
                vd[0] = v[2 * d]
                vd[1] = v[2 * d + 1]
                evaluate_law(kinds[d], params[d], states[d], ud, vd, fd, Kt, Ct, s_trial[d])
                for a in range(2):
                    lin = 0.0
                    for b in range(2):
                        lin += Kr[d, a, b] * ud[b] + Cr[d, a, b] * vd[b]
                        DK[2 * d + a, b] = Kt[a, b] - Kr[d, a, b]
                        DC[2 * d + a, b] = Ct[a, b] - Cr[d, a, b]
                    fful[2 * d + a] = fd[a]
                    R[2 * d + a] = ft[2 * d + a] - (fd[a] - lin)
                    if abs(fd[a]) > scale:
                        scale = abs(fd[a])
            rmax = 0.0
            for i in range(nf):
                if abs(R[i]) > rmax:
                    rmax = abs(R[i])
            if not np.isfinite(rmax):
                return STATUS_NONFINITE, k
            it += 1
            if rmax <= rtol * scale or rmax == 0.0:
                converged = True
                break
            # Jacobian of R w.r.t. ft: I - DK Hu - DC Hv (DK, DC block diagonal per device)
            for d in range(nd):
                for a in range(2):
                    i = 2 * d + a
                    for j in range(nf):
                        J[i, j] = -(
                            DK[i, 0] * H[2 * d, j]
                            + DK[i, 1] * H[2 * d + 1, j]
                            + DC[i, 0] * H[nf + 2 * d, j]
                            + DC[i, 1] * H[nf + 2 * d + 1, j]
                        )
                    J[i, i] += 1.0
            for i in range(nf):
                R[i] = -R[i]
            _solve_inplace(J, R, nf)
            for i in range(nf):
                ft[i] += R[i]
        if not converged:
            return STATUS_DIVERGED, k
        # commit: device states, modal state, carried input term
        for d in range(nd):
            for c in range(S):
                states[d, c] = s_trial[d, c]
        _matvec(GfR, ft, fr)
        _matvec(GfI, ft, fi)
        for r in range(ns):
            X[r] = Xp[r] + e1r[r] * fr[r] - e1i[r] * fi[r]
            X[ns + r] = Xp[ns + r] + e1r[r] * fi[r] + e1i[r] * fr[r]
            w_prev[r] = gr[r] + fr[r]
            w_prev[ns + r] = gi[r] + fi[r]
        for r in range(2 * ns):
            out_X[r, k] = X[r]
        for i in range(nf):
            out_u[i, k] = u[i]
            out_f[i, k] = fful[i]
        out_it[k] = it
    return STATUS_OK, nb
