"""Partially nonlinear modal time integration, Eq. (12) of [004].

Equation of motion in n reduced (e.g. modal) coordinates q::

    M q'' + C q' + K q = -Gamma a_g(t) - sum_d B_d^T f_d(B_d q, B_d q')        (12)

(Eq. (12) of [004] after the modal transformation, with the nominal linear isolation
stiffness already removed from K, i.e. K = Phi^T (K - K_iso^nom) Phi.) Each device d sees the
local drift u_d = B_d q (1 or 2 components; ``+ E_d a_g``, ``u_d' = B_d q' + Ed_d a_g`` where
the input carries part of it, a vehicle's primary suspension) and returns the force f_d (see
:mod:`modal_twin.models.devices`). Outputs: y = C_out [q; q'; q''] + D_out a_g.

Integration scheme ("modal-foh")
--------------------------------
1. Exact linear part. Each device's initial stiffness and its viscous damping are moved
   into the linear operator, ``K_l = K + sum B^T K_ref B``, ``C_l = C + sum B^T C_ref B``,
   and subtracted from the device force, ``ft = f - K_ref u - C_ref u'`` (an identity that
   makes K_l non-singular for an isolated building and the nonlinear residual small).
   The first-order system x' = A x + B_w w, x = [q; q'], is diagonalised once,
   A = V Lambda V^-1, and propagated exactly for inputs w = [a_g; ft] varying linearly over
   a step (first-order hold, the discretisation of ``scipy.signal.lsim``)::

       xi_{k+1} = exp(Lambda dt) xi_k + E0 V^-1 B_w w_k + E1 V^-1 B_w w_{k+1}

   Conjugate eigenpairs are carried once (x = Re(sum w_r V_r xi_r), w_r in {1, 2}), so a
   step of the linear part costs O(n) plus the input and device projections.
2. Implicit device coupling. w_{k+1} contains the unknown device forces; the drifts are
   affine in them, u = u_pred + H_u ft, u' = v_pred + H_v ft, and the (2 n_dev) residual
   equations R(ft) = ft - [f(u, u') - K_ref u - C_ref u'] = 0 are solved by Newton from the
   linear extrapolation of the last two forces, with an inverse Jacobian (I - D H)^-1 kept
   between samples and rebuilt only when its first-order residual is not small (modified
   Newton). A sample is accepted when max|R| <= ``rtol`` max|f|, or when the bound of the
   residual left after the Newton correction just computed is (see
   :func:`modal_twin.twin.kernels.run_block`); the device states are then committed at the
   evaluated drift. At a building's time step the force hardly moves its own drift within
   one step (|H| ~ 1e-12 m/N), so one law evaluation per device and sample is the rule.
3. Block products around the loop. Only what the device forces feed back into stays in
   the per-sample loop. Before it, one block product per chunk of samples computes
   everything of a sample that depends on its input alone (E1 Ga a_k, E0 Ga a_k of the
   modal state and Ua1 a_k, Ua0 a_k of the drift prediction;
   :func:`modal_twin.twin.kernels.project_inputs`). The loop stores z_k = [xi_k; a_g,k;
   f_k] and the drifts per sample, and after it y = C_out [q; q'; q''] + D_out a_g (q''
   from Eq. (12) of [004]) is one BLAS product per chunk, y = W z.

Cost of a step (benchmark building: 36 modes, 6 bidirectional devices, 42 outputs): the
serial chain of the loop is ~8.6 kflop of linear algebra per sample -- the drift prediction
``Q xi_p`` (24 x 72) and the force projection Gf ft (72 x 12) are 60 % of it, the short
products Hf ft, H ft, Jinv R, H dft (24 x 12, 12 x 12) and the diagonal commit the rest --
plus the six device laws (four Bouc-Wen RK4 chains advanced together, see
:func:`modal_twin.models.devices.bouc_wen.bw_advance_many`, the ESB pow, two bilinear),
which cost more than the linear algebra. The input products (1.15 kflop per sample) and
the output product (7.6 kflop) run as block products at BLAS-like rates. The drift of the
next sample is predicted as ``Q xi_p,k + Ua0 a_k + Ua1 a_k+1 + Hf ft_k`` (the same number
as P xi_p,k+1 to rounding; see :func:`modal_twin.twin.kernels.run_block`), so that only a
(24 x 12) product lies between two Newton solves. test/benchmarks/bench_twin.py prints the
figures of the machine it runs on.

Why not fewer states in the loop: the map from the 12 device forces to the 24 drifts and
velocities is a 72-state system (every mode is reached by the forces and seen by the
drifts), so an exact loop cannot carry fewer numbers per sample; lifting it over L samples
(device-coordinate Markov parameters inside a window, the modal state once per window)
keeps the 24 x 72 and 72 x 12 products per sample and adds 144 (L - 1) multiply-adds.

Tolerance: ``rtol`` = 1e-6 of the largest device force. On the benchmark building
(test/benchmarks/bench_twin.py, 20 s) the drifts then differ from a solve with rtol = 1e-12
by 4.5e-9 (relative RMS) while the time discretisation itself (dt against dt / 4) accounts
for 1.0e-5: the tolerance is 2000 times below the scheme's own error.

Sub-steps (:func:`substeps_for`, :attr:`Simulator.substeps`)
-------------------------------------------------------------
The first-order hold of step 1 holds each device force linearly over a step. A Coulomb
law's force is discontinuous in the velocity: when the stroke turns back it switches by
up to 2 Fk within a fraction of a step, and the hold spreads that switch over the whole
step. The modes whose period spans few steps take the error of that spread as a response
of their own: with modes above a quarter of the sample rate it is of the order of their
response (the trailer car at 200 Hz, 165 Hz top mode, a friction damper: stroke and force
channels 2-3x their noise floor at the truth's own law and parameters, 0.05-0.35x with
four steps per sample). So a plant with such a law and a top natural frequency f_max of
its linear part (device reference stiffness included) above ``HOLD_FRACTION`` fs is
stepped ``ceil(f_max / (HOLD_FRACTION fs))`` times per sample, every mode's period then
spanning at least ``1 / HOLD_FRACTION`` = 4 steps: a switch placed anywhere within a
step moves the impulse a mode receives by up to a step, an error of relative order
omega h in that mode's response, and the scheme (exact in its linear part, second order
in the device coupling) converges from there (the car: stroke and force channels within
0.1 % of the same plant at 16 steps per sample; tests in test/twin/test_substeps.py). The
rule is a rate, not a stability limit: the scheme is unconditionally stable at any step,
so a plant stepped once per sample does not blow up, it misplaces its friction forces.
Every other plant is stepped
once per sample, bit for bit as before. The inputs are interpolated linearly between
samples (the hold the scheme already assumes), so the linear part's response at the
samples is the same to round-off however many sub-steps are taken; only the device
forces are resolved more finely. Outputs, drifts and forces are returned at the samples.
Every path that integrates a plant (the diagnosis's fits, the live twin, the residual
and report, a scenario's truth rig) uses this class, so all integrate alike.

Why this and not Newmark: the linear part is exact at any step (no period elongation;
Newmark's average acceleration errs by (w dt)^2 / 12, 0.4 % at 35 Hz and 1 kHz), it is
unconditionally stable, and the per-step cost is O(n n_dev) plus one evaluation of each
device law. Accuracy of the coupling is second order in dt.
The eigenvector matrix must be well conditioned (its condition number is reported;
above 1e10 a ModelError is raised: a defective A, e.g. rigid-body modes without any
device stiffness).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from contextlib import nullcontext
from typing import Literal

import numpy as np
import scipy.linalg

from modal_twin._types import ComplexArray, FloatArray
from modal_twin.errors import ConvergenceError, ModelError, OptionError, ShapeError, SignalError
from modal_twin.models.devices.base import (
    KIND_BW_ESB,
    KIND_BW_SDP,
    KIND_COULOMB,
    KIND_GAP,
    KIND_PRANDTL,
    N_PARAM,
)
from modal_twin.models.devices.bouc_wen import esb_pressure_factor
from modal_twin.models.devices.registry import KINDS
from modal_twin.models.reduced import ReducedSystem, SimResult
from modal_twin.progress import Progress
from modal_twin.twin.kernels import (
    STATUS_DIVERGED,
    STATUS_NONFINITE,
    STATUS_UNKNOWN_KIND,
    BlockRows,
    DeviceArrays,
    LoopMatrices,
    LoopState,
    run_block,
)

__all__ = ["HOLD_FRACTION", "Simulator", "simulate", "substeps_for"]

_log = logging.getLogger(__name__)
_METHODS = ("modal-foh",)

_CHUNK = 1024  # samples per kernel call (one output product per chunk)
_SUB = 64  # samples per input block product inside the kernel (98 kB: stays in L2)
_SHOW_PROGRESS = 64 * _CHUNK  # blocks from this length on report progress (not live frames)
# stiffness / damping a law can switch to that neither its tangent nor K_ref shows
# (parameter index, -1 for none): Coulomb sticking (kt), gap contact (k, c), Prandtl Kb
_JUMPS = {KIND_COULOMB: (2, -1), KIND_GAP: (0, 2), KIND_PRANDTL: (5, -1)}
# laws whose force is discontinuous in the velocity (Coulomb sticking and sliding); the
# others (gap, Prandtl, bilinear ...) are continuous, only their stiffness switches
_SUBSTEP_KINDS = (KIND_COULOMB,)
HOLD_FRACTION = 0.25  # highest mode frequency per step rate with a discontinuous law


def substeps_for(system: ReducedSystem, dt: float) -> int:
    """Return the integration steps per sample interval ``dt`` of ``system``.

    One, unless a law of discontinuous force (Coulomb friction,
    :class:`~modal_twin.models.devices.coulomb.CoulombFriction`) is attached and the top
    undamped natural frequency ``f_max`` of ``M q'' + (K + sum B^T K_ref B) q`` is above
    :data:`HOLD_FRACTION` / dt: then ``ceil(f_max dt / HOLD_FRACTION)`` (the module
    docstring, "Sub-steps").

    Parameters
    ----------
    system : ReducedSystem
        The model.
    dt : float
        Sample interval, s.

    Returns
    -------
    int
        Steps per sample, >= 1.
    """
    return _substeps(system, lambda: _linear_stiffness(system, *_reference_parts(system)), dt)


def _reference_parts(system: ReducedSystem) -> tuple[FloatArray, FloatArray]:
    """Return ``B_s`` (2 rows per device) and the devices' reference stiffness (2 x 2 each).

    Each device's rows and matrix padded with zeros to two directions, as
    :class:`Simulator` gathers them.
    """
    nd = len(system.devices)
    Bs = np.zeros((2 * nd, system.n))
    Kr = np.zeros((nd, 2, 2))
    for d, att in enumerate(system.devices):
        nd_ = att.device.n_dir
        Bs[2 * d : 2 * d + nd_] = att.B
        Kr[d, :nd_, :nd_] = att.device.reference_stiffness()[:nd_, :nd_]
    return Bs, Kr


def _linear_stiffness(system: ReducedSystem, Bs: FloatArray, Kr: FloatArray) -> FloatArray:
    """Return ``K + sum B^T K_ref B``: the stiffness of the linear part (module docstring)."""
    n, nd = system.n, len(system.devices)
    return np.asarray(system.K + sum(
        (Bs[2 * d : 2 * d + 2].T @ Kr[d] @ Bs[2 * d : 2 * d + 2] for d in range(nd)),
        np.zeros((n, n))), dtype=float)


def _substeps(system: ReducedSystem, stiffness: Callable[[], FloatArray], dt: float) -> int:
    """Return the steps per sample of :func:`substeps_for`, from the linear stiffness."""
    if not any(a.device.kind in _SUBSTEP_KINDS for a in system.devices):
        return 1
    lam = np.linalg.eigvals(np.linalg.solve(np.asarray(system.M, dtype=float),
                                            stiffness())).real
    f_max = float(np.sqrt(max(float(lam.max(initial=0.0)), 0.0))) / (2.0 * np.pi)
    return max(1, int(np.ceil(f_max * dt / HOLD_FRACTION - 1e-9)))


def held_between_samples(ag: FloatArray, k: int) -> FloatArray:
    """Return the samples ``ag`` (n_in, nt) interpolated linearly, ``k`` steps per sample.

    Shape (n_in, (nt - 1) k + 1); every ``k``-th column is a sample itself.
    """
    if k == 1 or ag.shape[1] < 2:
        return ag
    frac = np.arange(k) / k
    inner = ag[:, :-1, None] + np.diff(ag, axis=1)[:, :, None] * frac
    return np.concatenate([inner.reshape(ag.shape[0], -1), ag[:, -1:]], axis=1)


def _discretise(lam: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return exp(lam dt), E0, E1 of the first-order hold (as in scipy.signal.lsim)."""
    lam = np.asarray(lam, dtype=complex)
    Phi = np.empty(lam.shape, dtype=complex)
    E0 = np.empty(lam.shape, dtype=complex)
    E1 = np.empty(lam.shape, dtype=complex)
    for i, li in enumerate(lam):
        Mx = np.array([[li * dt, dt, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]], dtype=complex)
        F = scipy.linalg.expm(Mx)
        Phi[i] = F[0, 0]
        E1[i] = F[0, 2]
        E0[i] = F[0, 1] - F[0, 2]
    return Phi, E0, E1


def _split(Z: ComplexArray) -> FloatArray:
    """Real matrix acting on [Re xi; Im xi] that returns Re(Z xi)."""
    return np.ascontiguousarray(np.hstack([Z.real, -Z.imag]))


class Simulator:
    """Streaming integrator of a :class:`ReducedSystem` (state kept between blocks).

    Parameters
    ----------
    system : ReducedSystem
        The model.
    dt : float
        Sample interval, s.
    rtol : float
        Newton tolerance on the device residual, relative to the largest device force
        (default 1e-6, see the module docstring for why this is not loose).
    max_iter : int
        Device-law evaluations allowed per sample.
    modal_histories : bool
        Return q, q', q'' (False: only y, drifts and forces, which is faster).
    substeps : int, optional
        Integration steps per sample; default :func:`substeps_for` (the module docstring,
        "Sub-steps"). Outputs are always at the samples.

    Attributes
    ----------
    substeps : int
        Integration steps per sample interval ``dt``.
    h : float
        Integration step, ``dt / substeps``, s.

    Raises
    ------
    ModelError
        If M is singular or the state matrix is (numerically) defective.
    OptionError
        If dt, rtol or max_iter are not positive.
    """

    def __init__(
        self,
        system: ReducedSystem,
        dt: float,
        *,
        rtol: float = 1e-6,
        max_iter: int = 50,
        modal_histories: bool = True,
        substeps: int | None = None,
    ) -> None:
        self.modal_histories = bool(modal_histories)
        if not (np.isfinite(dt) and dt > 0):
            msg = f"dt: expected a positive finite sample interval, got {dt!r}"
            raise OptionError(msg)
        if substeps is not None and not (int(substeps) == substeps and substeps >= 1):
            msg = f"substeps: expected a positive integer, got {substeps!r}"
            raise OptionError(msg)
        if not (rtol > 0 and max_iter >= 1):
            msg = f"rtol, max_iter: expected positive, got {rtol!r}, {max_iter!r}"
            raise OptionError(msg)
        self.system = system
        self.dt = float(dt)
        self.rtol = float(rtol)
        self.max_iter = int(max_iter)
        M = np.asarray(system.M, float)
        cM = np.linalg.cond(M)
        if not np.isfinite(cM) or cM > 1e12:
            msg = f"M: expected a well-conditioned mass matrix, cond(M) = {cM:.3e}"
            raise ModelError(msg)
        Bs = self._gather_devices(system)
        Kl = _linear_stiffness(system, Bs, self.Kr)
        self.substeps = (_substeps(system, lambda: Kl, self.dt) if substeps is None
                         else int(substeps))
        self.h = self.dt / self.substeps
        for d, att in enumerate(system.devices):  # a rate law integrates over this step
            if att.device.time_step_index >= 0:
                self.params[d, att.device.time_step_index] = self.h
        self._Minv = np.linalg.inv(M)
        lam, Vw, G = self._modal_basis(system, Bs, Kl)
        lam_d, e0, e1 = _discretise(lam, self.h)
        self._kernel_matrices(system, Bs, Vw, G, lam_d, e0, e1)
        self._output_matrices(system, Bs, Vw)
        self.reset()

    def _gather_devices(self, system: ReducedSystem) -> FloatArray:
        """Device kinds, parameters, reference (linear) parts and rows; return ``B_s``."""
        nd = len(system.devices)
        Bs = np.zeros((2 * nd, system.n))
        # input share of each drift and rate, u = B q + E a, u' = B q' + Ed a
        self._Es = np.zeros((2 * nd, system.n_in))
        self._Eds = np.zeros((2 * nd, system.n_in))
        self.kinds = np.zeros(nd, dtype=np.int64)
        self.params = np.zeros((nd, N_PARAM))
        self.Kr = np.zeros((nd, 2, 2))
        self.Cr = np.zeros((nd, 2, 2))
        self._kjump = np.zeros(nd)
        self._cjump = np.zeros(nd)
        self._consts = np.zeros(nd)  # per-device law constant (ESB pressure factor)
        rows: list[str] = []
        self._row_index: list[int] = []
        for d, att in enumerate(system.devices):
            dev = att.device
            nd_ = dev.n_dir
            if dev.kind not in KINDS:
                msg = (
                    f"devices[{d}] ({dev.name}, {type(dev).__name__}): expected a law kind of "
                    f"the device registry {sorted(KINDS)}, got {dev.kind}"
                )
                raise ModelError(msg)
            Bs[2 * d : 2 * d + nd_] = att.B
            if att.E is not None:
                self._Es[2 * d : 2 * d + nd_] = att.E
            if att.Ed is not None:
                self._Eds[2 * d : 2 * d + nd_] = att.Ed
            self.kinds[d] = dev.kind
            self.params[d] = dev.params  # a rate law's step: written in by __init__
            if dev.kind == KIND_BW_ESB:
                self._consts[d] = esb_pressure_factor(self.params[d])
            self.Kr[d, :nd_, :nd_] = dev.reference_stiffness()[:nd_, :nd_]
            self.Cr[d, :nd_, :nd_] = dev.reference_damping()[:nd_, :nd_]
            ik, ic = _JUMPS.get(dev.kind, (-1, -1))
            self._kjump[d] = abs(dev.params[ik]) if ik >= 0 else 0.0
            self._cjump[d] = abs(dev.params[ic]) if ic >= 0 else 0.0
            for a in range(nd_):
                rows.append(f"{dev.name}.{'xy'[a]}")
                self._row_index.append(2 * d + a)
        self.rows = tuple(rows)
        bw_idx = np.flatnonzero(np.isin(self.kinds, (KIND_BW_ESB, KIND_BW_SDP))).astype(np.int64)
        self._dev = DeviceArrays(self.kinds, bw_idx, self.params, self._consts, self.Kr,
                                 self.Cr, self._kjump, self._cjump)
        self._Bs = Bs
        return Bs

    def _modal_basis(self, system: ReducedSystem, Bs: FloatArray, Kl: FloatArray
                     ) -> tuple[ComplexArray, ComplexArray, ComplexArray]:
        """Eigenvalues kept (one per conjugate pair), weighted modes ``V w`` and ``V^-1 B_w``.

        Of the state matrix with the devices' reference parts (the module docstring);
        ``Kl`` its stiffness, :func:`_linear_stiffness`.
        """
        n, n_in, nd = system.n, system.n_in, len(system.devices)
        Cl = system.C + sum(
            (Bs[2 * d : 2 * d + 2].T @ self.Cr[d] @ Bs[2 * d : 2 * d + 2] for d in range(nd)),
            np.zeros((n, n)),
        )
        Minv = self._Minv
        A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ Kl, -Minv @ Cl]])
        # the reference parts of the input's own share of a drift (E, Ed) act as an input
        Gl = system.Gamma + sum(
            (Bs[2 * d : 2 * d + 2].T @ (self.Kr[d] @ self._Es[2 * d : 2 * d + 2]
                                        + self.Cr[d] @ self._Eds[2 * d : 2 * d + 2])
             for d in range(nd)), np.zeros((n, n_in)))
        Bw = np.vstack([np.zeros((n, n_in + 2 * nd)),
                        -Minv @ np.hstack([Gl, Bs.T])])
        lam, V = np.linalg.eig(A)
        self.cond_V = float(np.linalg.cond(V))
        if not np.isfinite(self.cond_V) or self.cond_V > 1e10:
            msg = (
                f"A: modal eigenvector matrix is ill-conditioned, cond(V) = {self.cond_V:.3e} "
                "(defective state matrix: rigid-body or critically damped modes?)"
            )
            raise ModelError(msg)
        Vinv = np.linalg.inv(V)
        scale = np.abs(lam).max() if lam.size else 1.0
        tol = 1e-9 * max(scale, 1e-300)
        keep = np.flatnonzero((lam.imag > tol) | (np.abs(lam.imag) <= tol))
        n_pair = int(np.count_nonzero(lam.imag > tol))
        if 2 * n_pair + int(np.count_nonzero(np.abs(lam.imag) <= tol)) != 2 * n:
            msg = f"A: eigenvalues not in conjugate pairs ({lam.size} found)"
            raise ModelError(msg)
        w = np.where(lam[keep].imag > tol, 2.0, 1.0)
        return lam[keep], V[:, keep] * w, Vinv[keep] @ Bw

    def _kernel_matrices(self, system: ReducedSystem, Bs: FloatArray, Vw: ComplexArray,
                         G: ComplexArray, lam_d: ComplexArray, e0: ComplexArray,
                         e1: ComplexArray) -> None:
        """Build the real matrices the per-sample kernel multiplies (module docstring)."""
        n, n_in = system.n, system.n_in
        self._ns = lam_d.size
        c = np.ascontiguousarray
        # rows Re / Im of exp(lambda dt), E0, E1 (one array: few pointers for the compiler)
        self._coef = c(np.vstack([lam_d.real, lam_d.imag, e0.real, e0.imag, e1.real, e1.imag]))
        Ga, Gf = G[:, :n_in], G[:, n_in:]
        self._GaT = c(np.vstack([Ga.real, Ga.imag]).T)  # (n_in, 2 ns)
        self._GfT = c(np.vstack([Gf.real, Gf.imag]).T)  # (nf, 2 ns)
        Pu, Pv = Bs @ Vw[:n], Bs @ Vw[n:]
        self._P = c(np.vstack([_split(Pu), _split(Pv)]))
        e1G = e1[:, None] * Gf
        self._HT = c(np.vstack([(Pu @ e1G).real, (Pv @ e1G).real]).T)  # (nf, 2 nf)
        # the drift prediction of the next sample split into a part known before this
        # sample's device forces and a short product of them (see the kernel):
        # P xi_p,k+1 = Q xi_p,k + Ua0 a_k + Ua1 a_k+1 + Hf ft_k
        Pc = np.vstack([Pu, Pv])
        self._Q = c(_split(Pc * lam_d[None, :]))  # (2 nf, 2 ns)
        self._Ua0T = c((Pc @ (e0[:, None] * Ga)).real.T)  # (n_in, 2 nf)
        # the input's own share of the drift of the next sample, [E; Ed] a_k+1
        self._Ua1T = c((Pc @ (e1[:, None] * Ga)).real.T + np.hstack([self._Es.T, self._Eds.T]))
        self._HfT = c((Pc @ ((lam_d * e1 + e0)[:, None] * Gf)).real.T)  # (nf, 2 nf)
        # everything of a sample that depends on its input alone, computed for a whole chunk
        # before the per-sample loop: [E1 Ga; E0 Ga] a_k (split) and Ua1 a_k, Ua0 a_k
        e1Ga, e0Ga = e1[:, None] * Ga, e0[:, None] * Ga
        self._PinT = c(np.vstack([e1Ga.real, e1Ga.imag, e0Ga.real, e0Ga.imag,
                                  self._Ua1T.T, self._Ua0T.T]).T)  # (n_in, 4 ns + 4 nf)
        self._lin = LoopMatrices(self._PinT, self._coef, self._GfT, self._Q, self._HfT,
                                 self._HT)

    def _output_matrices(self, system: ReducedSystem, Bs: FloatArray, Vw: ComplexArray) -> None:
        """Build the outputs from the kernel rows ``z = [xi; a_g; f]``.

        q, q' from the modal state, q'' from Eq. (12) of [004]; y = C_out [q; q'; q''] +
        D_out a_g.
        """
        n, n_in, nf = system.n, system.n_in, Bs.shape[0]
        Lq, Lv = _split(Vw[:n]), _split(Vw[n:])
        Co = np.asarray(system.C_out, float)
        Cq, Cv, Ca = Co[:, :n], Co[:, n : 2 * n], Co[:, 2 * n :]
        Wa = -self._Minv @ np.hstack([system.C @ Lv + system.K @ Lq, system.Gamma, Bs.T])
        Wy = np.hstack([Cq @ Lq + Cv @ Lv, system.D_out, np.zeros((Co.shape[0], nf))])
        Wy += Ca @ Wa
        zero = np.zeros((n, n_in + nf))
        self._Wy = np.ascontiguousarray(Wy)
        self._Wall = np.ascontiguousarray(
            np.vstack([Wy, np.hstack([Lq, zero]), np.hstack([Lv, zero]), Wa]))

    def reset(self) -> None:
        """Return to rest (virgin device states, zero motion, time 0)."""
        ns = self._ns
        nd = len(self.system.devices)
        # the state slots of the plant's laws, not N_STATE (the loop copies them per sample)
        n_state = max((att.device.n_state for att in self.system.devices), default=1)
        states = np.zeros((nd, n_state))
        for d, att in enumerate(self.system.devices):
            states[d] = att.device.initial_state()[:n_state]
        self._state = LoopState(
            Xh=np.zeros(2 * ns),  # exp(Lambda dt) xi_k + E0 w_k of the last sample
            base=np.zeros(4 * nd),  # Q xi_p,k + Ua0 a_k of the last sample
            ft=np.zeros(2 * nd), ft_old=np.zeros(2 * nd), Jinv=np.zeros((2 * nd, 2 * nd)),
            flags=np.zeros(3, dtype=np.int64),  # started, Jinv valid, refreshes
            states=states)
        self._k0 = 0
        self._last_in: FloatArray | None = None  # last input sample (sub-steps continue it)

    def warm_up(self) -> float:
        """Compile the kernels for this model's arrays now; return the seconds it took.

        Numba compiles :func:`~modal_twin.twin.kernels.run_block` and the device laws at
        their first call (tens of seconds on a cold cache, then loaded from its disk cache):
        a node calls this while it configures, so that its first block is not held up. Two
        samples at rest are stepped, then the simulator is :meth:`reset`.
        """
        t0 = time.perf_counter()
        self.step_block(np.zeros((self.system.n_in, 2)))
        self.reset()
        return time.perf_counter() - t0

    def _unknown_kind(self, d: int) -> str:
        """Message for a device whose kind code the kernel has no branch for."""
        dev = self.system.devices[d].device
        kind = int(self.kinds[d])
        laws = KINDS.get(kind)
        what = f"law {' / '.join(laws)}" if laws else f"{type(dev).__name__}"
        return (f"devices[{d}] ({dev.name}): {what} (kind code {kind}) has no branch in the "
                "twin kernel (modal_twin/twin/kernels.py:run_block); it was not run")

    def step_block(self, ag: FloatArray) -> SimResult:
        """Integrate one block of base-acceleration samples, continuing the stored state.

        Parameters
        ----------
        ag : FloatArray
            (n_in, nb) base acceleration samples, m/s^2 (rad/s^2 for rotations). The very
            first sample of a run is the rest state.

        Returns
        -------
        SimResult
            The block's samples (t continues from the previous block).

        Raises
        ------
        ShapeError
            If ag does not have n_in rows.
        SignalError
            If ag holds a non-finite sample (message names sample index and channel), or
            the state becomes non-finite.
        ConvergenceError
            If the device-force Newton iteration fails.
        ModelError
            If a device's law has no branch in the kernel (named; nothing is run for it).
        """
        sysm = self.system
        ag = np.asarray(ag, dtype=float)
        if ag.ndim != 2 or ag.shape[0] != sysm.n_in:
            msg = f"ag: expected shape (n_in, nb) = ({sysm.n_in}, nb), got {ag.shape}"
            raise ShapeError(msg)
        bad = np.zeros((0, 2), dtype=np.int64)
        if not np.isfinite(np.sum(ag)):  # cheap test first; locate only when it fails
            bad = np.argwhere(~np.isfinite(ag))
        if bad.size:
            ch, k = int(bad[0, 0]), int(bad[0, 1])
            msg = (
                f"ag: non-finite value {ag[ch, k]} at sample {self._k0 + k} "
                f"(block index {k}), channel {ch}"
            )
            raise SignalError(msg)
        nb = ag.shape[1]
        K = self.substeps
        pad = K - 1 if self._last_in is None else 0  # fine steps before the first sample
        if K == 1 or nb == 0:
            fine = np.ascontiguousarray(ag)
        else:  # inputs interpolated linearly between samples (module docstring, "Sub-steps")
            prev = [] if self._last_in is None else [self._last_in[:, None]]
            fine = held_between_samples(np.hstack([*prev, ag]), K)[:, len(prev):]
            fine = np.ascontiguousarray(fine)
        if nb:
            self._last_in = ag[:, -1].copy()
        Y, out_u, out_f, its = self._integrate(fine, nb, pad)
        n, n_out = sysm.n, self._Wy.shape[0]
        y = Y[:n_out]
        q = qd = qdd = None
        if self.modal_histories:
            q, qd, qdd = Y[n_out : n_out + n], Y[n_out + n : n_out + 2 * n], Y[n_out + 2 * n :]
        t = np.asarray((self._k0 + np.arange(nb)) * self.dt, dtype=np.float64)
        self._k0 += nb
        ri = self._row_index
        return SimResult(
            t=t, y=y, q=q, qd=qd, qdd=qdd, drift=out_u[ri], force=out_f[ri], rows=self.rows,
            newton_iterations=its, cond_V=self.cond_V, method="modal-foh",
        )  # fmt: skip

    def _integrate(self, fine: FloatArray, nb: int, pad: int
                   ) -> tuple[FloatArray, FloatArray, FloatArray, np.ndarray]:
        """Step the kernel over the inputs ``fine``; return outputs at the ``nb`` samples.

        Step ``j`` of ``fine`` ends at sample ``(j + pad) // K`` of the block, which it is
        when ``(j + pad) % K == K - 1``; ``pad`` is ``K - 1`` on a run's first block (its
        first step is the rest sample) and 0 after. Returns y (and q, q', q'' rows), the
        device drifts and forces at the samples, and the law evaluations per sample summed
        over the steps that led to it.
        """
        K = self.substeps
        nfine = fine.shape[1]
        nf = 2 * len(self.system.devices)
        out_u = np.empty((nf, nb))
        out_f = np.empty((nf, nb))
        W = self._Wall if self.modal_histories else self._Wy
        rows = BlockRows(Ain=np.empty((_SUB, self._PinT.shape[1])),
                         Z=np.empty((min(nfine, _CHUNK), W.shape[1])),
                         U=np.empty((min(nfine, _CHUNK), nf)),
                         out_it=np.empty(nfine, dtype=np.int64))
        col_f = W.shape[1] - nf  # Z rows: [xi; a_g; f]
        Y = np.empty((W.shape[0], nb))  # rows: y, then q, q', q'' if requested
        bar = Progress("simulation", nb, unit="sample") if nb >= _SHOW_PROGRESS else None
        with bar or nullcontext():
            for k0 in range(0, nfine, _CHUNK):
                k1 = min(nfine, k0 + _CHUNK)
                status, idx = run_block(fine, k0, k1, self._lin, self._dev, self._state, rows,
                                        self.rtol, self.max_iter)
                self._raise_on(status, idx if status == STATUS_UNKNOWN_KIND
                               else self._k0 + (idx + pad) // K)
                first = (K - 1 - (k0 + pad) % K) % K  # first row of the chunk at a sample
                at = slice(first, k1 - k0, K)
                s0 = (k0 + first + pad) // K  # its sample
                s1 = s0 + len(range(first, k1 - k0, K))
                # one BLAS product per chunk
                np.matmul(W, rows.Z[at].T, out=Y[:, s0:s1])
                out_u[:, s0:s1] = rows.U[at].T
                out_f[:, s0:s1] = rows.Z[at, col_f:].T
                if bar is not None:
                    bar.update(s1 - s0)
        its = rows.out_it
        if K > 1 and nb:
            its = np.concatenate([np.zeros(pad, dtype=np.int64), its]).reshape(nb, K).sum(1)
        return Y, out_u, out_f, its

    def _raise_on(self, status: int, where: int) -> None:
        """Raise the error a kernel ``status`` says (``where``: a sample or a device)."""
        if status == STATUS_UNKNOWN_KIND:
            raise ModelError(self._unknown_kind(where))
        if status == STATUS_NONFINITE:
            msg = (
                f"state became non-finite at sample {where} "
                "(unstable device law or step too large)"
            )
            raise SignalError(msg)
        if status == STATUS_DIVERGED:
            msg = (
                f"device-force Newton did not converge in {self.max_iter} iterations at "
                f"sample {where} (rtol = {self.rtol:g})"
            )
            raise ConvergenceError(msg)


def simulate(
    system: ReducedSystem,
    ag: FloatArray,
    dt: float,
    *,
    method: Literal["modal-foh"] = "modal-foh",
    rtol: float = 1e-6,
    max_iter: int = 50,
) -> SimResult:
    """Simulate Eq. (12) of [004] from rest for a base-acceleration record.

    Parameters
    ----------
    system : ReducedSystem
        Linear reduced structure and its devices.
    ag : FloatArray
        (n_in, nt) base acceleration, sample 0 at t = 0 (rest state), SI.
    dt : float
        Sample interval, s.
    method : {"modal-foh"}
        Integration scheme (see module docstring).
    rtol, max_iter : float, int
        Newton controls on the device forces.

    Returns
    -------
    SimResult

    Raises
    ------
    OptionError
        For an unknown method.
    SignalError, ConvergenceError, ShapeError, ModelError
        As :class:`Simulator`.

    Examples
    --------
    >>> import numpy as np
    >>> from modal_twin.models.reduced import ReducedSystem
    >>> from modal_twin.twin.simulator import simulate
    >>> w = 2 * np.pi
    >>> s = ReducedSystem(M=np.eye(1), C=np.array([[0.1 * w]]), K=np.array([[w * w]]),
    ...                   Gamma=np.eye(1), devices=(), C_out=np.array([[1.0, 0, 0]]),
    ...                   D_out=np.zeros((1, 1)))
    >>> r = simulate(s, np.ones((1, 60001)), 1e-3)
    >>> print(round(r.q[0, -1] * w * w, 4))
    -1.0
    """
    if method not in _METHODS:
        msg = f"method: expected one of {list(_METHODS)}, got {method!r}"
        raise OptionError(msg)
    return Simulator(system, dt, rtol=rtol, max_iter=max_iter).step_block(ag)
