"""Fixed-step classical Runge-Kutta (RK4) integration of a second-order system with
nonlinear laws, sub-stepped within each sample (not the library's exact modal first-order
hold with Newton coupling).

    M x'' + C x' + K x = -G w(t) - sum_d L_d' f_d(u_d, u_d', z_d),   z_d' = g_d(...)
    u_d = L_d x + E_d w(t),   u_d' = L_d x' + Ed_d w(t)

(``E_d``, ``Ed_d``: the part of a law's drift and drift rate the input itself carries,
e.g. a primary suspension's stroke ``z_bogie - z_track``; zero for most laws.)

``w`` is interpolated linearly between samples (first-order hold). Rate-independent law
memory is committed after every sub-step (:mod:`.laws`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .laws import Law

FloatArray = np.ndarray


@dataclass
class Attached:
    """A law acting on the drift ``L x + E w`` and rate ``L x' + Ed w`` (L: (2, n); E,
    Ed: (2, n_in) or None for none)."""

    name: str
    law: Law
    L: FloatArray
    E: FloatArray | None = None
    Ed: FloatArray | None = None

    def drift(self, x: FloatArray, xd: FloatArray, w: FloatArray
              ) -> tuple[FloatArray, FloatArray]:
        """Drift and its rate at state ``x``, ``xd`` and input ``w``."""
        u = self.L @ x + (0.0 if self.E is None else self.E @ w)
        return u, self.L @ xd + (0.0 if self.Ed is None else self.Ed @ w)


@dataclass
class RunResult:
    """Samples of the run: coordinates, velocities, accelerations (n, nt) and the law
    forces (n_law, 2, nt)."""

    x: FloatArray
    xd: FloatArray
    xdd: FloatArray
    f: FloatArray


def run_rk4(M: FloatArray, C: FloatArray, K: FloatArray, G: FloatArray,
            laws: list[Attached], w: FloatArray, fs_hz: float, n_sub: int) -> RunResult:
    """Integrate from rest; ``w`` (n_in, nt) sampled at ``fs_hz``, ``n_sub`` RK4 steps per
    sample."""
    n = M.shape[0]
    Minv = np.linalg.inv(M)
    A_K, A_C, A_G = Minv @ K, Minv @ C, Minv @ G
    A_L = [Minv @ a.L.T for a in laws]
    offs = np.cumsum([0] + [a.law.n_ode for a in laws])
    for a in laws:
        a.law.reset()
    nz = int(offs[-1])
    nt = w.shape[1]
    h = 1.0 / (fs_hz * n_sub)

    def law_forces(x: FloatArray, xd: FloatArray, z: FloatArray, wt: FloatArray
                   ) -> tuple[list[FloatArray], FloatArray]:
        fs, zd = [], np.empty(nz)
        for i, a in enumerate(laws):
            u, ud = a.drift(x, xd, wt)
            f, dz = a.law.force(u, ud, z[offs[i]:offs[i + 1]])
            fs.append(f)
            zd[offs[i]:offs[i + 1]] = dz
        return fs, zd

    def rhs(y: FloatArray, wt: FloatArray) -> FloatArray:
        x, xd, z = y[:n], y[n:2 * n], y[2 * n:]
        fs, zd = law_forces(x, xd, z, wt)
        xdd = -A_K @ x - A_C @ xd - A_G @ wt
        for AL, f in zip(A_L, fs, strict=True):
            xdd -= AL @ f
        return np.concatenate([xd, xdd, zd])

    y = np.zeros(2 * n + nz)
    X, XD, XDD = np.zeros((n, nt)), np.zeros((n, nt)), np.zeros((n, nt))
    F = np.zeros((len(laws), 2, nt))

    def store(k: int, y: FloatArray) -> None:
        d = rhs(y, w[:, k])
        X[:, k], XD[:, k], XDD[:, k] = y[:n], y[n:2 * n], d[n:2 * n]
        fs, _ = law_forces(y[:n], y[n:2 * n], y[2 * n:], w[:, k])
        for i, f in enumerate(fs):
            F[i, :, k] = f

    store(0, y)
    for k in range(nt - 1):
        w0, w1 = w[:, k], w[:, k + 1]
        for j in range(n_sub):
            a0, a1 = j / n_sub, (j + 1) / n_sub
            wa = w0 + a0 * (w1 - w0)
            wm = w0 + 0.5 * (a0 + a1) * (w1 - w0)
            wb = w0 + a1 * (w1 - w0)
            k1 = rhs(y, wa)
            k2 = rhs(y + 0.5 * h * k1, wm)
            k3 = rhs(y + 0.5 * h * k2, wm)
            k4 = rhs(y + h * k3, wb)
            y = y + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            for a in laws:
                a.law.commit(a.L @ y[:n] + (0.0 if a.E is None else a.E @ wb))
        store(k + 1, y)
    return RunResult(X, XD, XDD, F)
