"""Single-DOF identification by simulation-error least squares: linear and Bouc-Wen.

Model (the Bouc-Wen benchmark of Noel and Schoukens; the uniaxial, general-exponent form
of the hysteretic variable whose bidirectional nu = 2 form is Eq. (10) of [004])::

    m y'' + c y' + k y + z = f                                        (1)
    z' = alpha y' - a |y'| |z|^(nu - 1) z - b y' |z|^nu                (2)

``a = beta gamma`` and ``b = beta delta`` in the benchmark's notation; ``alpha = a = b = 0``
is the linear m-c-k model. Eq. (1)-(2) are integrated by classical RK4 on a grid
``oversample`` times finer than the record, the force being interpolated band-limited
(FFT) for a periodic record or by a cubic spline otherwise. A periodic record (whole
periods of a steady state) is simulated after one warm-up period; any other from rest.

Parameters are fitted by simulation-error least squares
(``scipy.optimize.least_squares``, trust-region reflective) on normalised parameters.
For the Bouc-Wen model the initial guess comes from the restoring-force loop
(:mod:`modal_twin.diagnosis.restoring_force`): with ``z = alpha w``, Eq. (2) for ``w``
depends on (a, b) only, so Eq. (1) is linear in (m, c, k, alpha) given (a, b); a grid
over (a, b) scaled by the displacement amplitude, each with one linear least-squares fit
of the measured force (equation error), gives the starts of the simulation-error fit.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, replace

import numpy as np
from numba import njit
from scipy.interpolate import CubicSpline
from scipy.optimize import least_squares
from scipy.signal import resample

from modal_twin._types import FloatArray
from modal_twin.diagnosis.restoring_force import (
    bouc_wen_state,
    check_record,
    state_derivatives,
)
from modal_twin.errors import ModelError, OptionError
from modal_twin.models.devices.bouc_wen import bw_rate_uniaxial

__all__ = [
    "BoucWenSDOF",
    "SDOFFit",
    "bouc_wen_initial_guesses",
    "fit_bouc_wen_sdof",
    "fit_linear_sdof",
    "simulate_sdof",
]

_log = logging.getLogger(__name__)
_MIN_SAMPLES = 64


@dataclass(frozen=True, slots=True)
class BoucWenSDOF:
    """Parameters of Eqs. (1)-(2); ``alpha = a = b = 0`` is the linear model.

    Attributes
    ----------
    m : float
        Mass, kg.
    c : float
        Viscous damping, N s/m.
    k : float
        Linear stiffness, N/m.
    alpha : float
        Initial stiffness of the hysteretic force z, N/m.
    a, b : float
        Shape parameters ``beta gamma`` and ``beta delta``, 1/m (nu = 1).
    nu : float
        Exponent (>= 1), not fitted.
    """

    m: float
    c: float
    k: float
    alpha: float = 0.0
    a: float = 0.0
    b: float = 0.0
    nu: float = 1.0

    def __post_init__(self) -> None:
        """Check m > 0, c >= 0, k >= 0, alpha >= 0, nu >= 1."""
        if not (self.m > 0 and self.c >= 0 and self.k >= 0 and self.alpha >= 0):
            msg = (
                f"m, c, k, alpha: expected m > 0 and c, k, alpha >= 0, got m={self.m}, "
                f"c={self.c}, k={self.k}, alpha={self.alpha}"
            )
            raise ModelError(msg)
        if not self.nu >= 1.0:
            msg = f"nu: expected nu >= 1, got {self.nu}"
            raise ModelError(msg)

    @property
    def is_linear(self) -> bool:
        """True when the hysteretic force is absent."""
        return self.alpha == 0.0

    @property
    def f_n_hz(self) -> float:
        """Natural frequency of the initial (small-amplitude) stiffness k + alpha, Hz."""
        return float(np.sqrt((self.k + self.alpha) / self.m) / (2 * np.pi))

    @property
    def zeta(self) -> float:
        """Viscous damping ratio at the initial stiffness (fraction)."""
        return float(self.c / (2 * np.sqrt((self.k + self.alpha) * self.m)))

    def vector(self) -> FloatArray:
        """Return [m, c, k, alpha, a, b]."""
        return np.array([self.m, self.c, self.k, self.alpha, self.a, self.b])


@dataclass(frozen=True, slots=True)
class SDOFFit:
    """Result of a simulation-error fit.

    Attributes
    ----------
    model : BoucWenSDOF
        Fitted parameters.
    std : FloatArray
        Standard deviations of the fitted entries of ``model.vector()`` from the Jacobian
        at the optimum (Gauss-Newton covariance, white-noise assumption), shape (n_fit,).
    names : tuple of str
        Names of the fitted entries.
    rmse_m : float
        RMS error of the simulated displacement on the training record, m.
    nrmse : float
        ``rmse_m / std(y)``.
    n_fev : int
        Simulations run (all starts).
    converged : bool
        ``least_squares`` status > 0 for the retained start.
    fit_time_s : float
        Wall time of the fit, s.
    """

    model: BoucWenSDOF
    std: FloatArray
    names: tuple[str, ...]
    rmse_m: float
    nrmse: float
    n_fev: int
    converged: bool
    fit_time_s: float


@njit(cache=True)
def _rhs(y, v, z, u, m, c, k, al, a, b, nu):  # pragma: no cover - jitted
    acc = (u - c * v - k * y - z) / m  # Eq. (1)
    return acc, bw_rate_uniaxial(al, a, b, nu, z, v)  # Eq. (2)


@njit(cache=True)
def _simulate(uf, h, nsub, m, c, k, al, a, b, nu, y_limit):  # pragma: no cover - jitted
    n = (uf.shape[0] - 1) // nsub + 1
    out = np.empty(n)
    y = 0.0
    v = 0.0
    z = 0.0
    out[0] = 0.0
    ok = True
    for i in range(uf.shape[0] - 1):
        u0 = uf[i]
        u1 = uf[i + 1]
        um = 0.5 * (u0 + u1)
        a1, z1 = _rhs(y, v, z, u0, m, c, k, al, a, b, nu)
        v2 = v + 0.5 * h * a1
        a2, z2 = _rhs(y + 0.5 * h * v, v2, z + 0.5 * h * z1, um, m, c, k, al, a, b, nu)
        v3 = v + 0.5 * h * a2
        a3, z3 = _rhs(y + 0.5 * h * v2, v3, z + 0.5 * h * z2, um, m, c, k, al, a, b, nu)
        v4 = v + h * a3
        a4, z4 = _rhs(y + h * v3, v4, z + h * z3, u1, m, c, k, al, a, b, nu)
        y += h / 6.0 * (v + 2.0 * v2 + 2.0 * v3 + v4)
        v += h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        z += h / 6.0 * (z1 + 2.0 * z2 + 2.0 * z3 + z4)
        if not abs(y) < y_limit:  # also catches NaN
            ok = False
            for j in range(i // nsub + 1, n):
                out[j] = y_limit
            break
        if (i + 1) % nsub == 0:
            out[(i + 1) // nsub] = y
    return out, ok


def _fine_force(u: FloatArray, n_sub: int, periodic: bool) -> FloatArray:
    """Force on the fine grid, length (nt - 1) n_sub + 1 (periodic: nt n_sub + 1)."""
    if periodic:
        uf = resample(u, u.size * n_sub)
        return np.append(uf, uf[0])
    t = np.arange(u.size, dtype=float)
    tf = np.arange((u.size - 1) * n_sub + 1) / n_sub
    return CubicSpline(t, u)(tf)


def _check_options(oversample: int, period: int | None, n: int) -> None:
    if not (isinstance(oversample, int | np.integer) and oversample >= 1):
        msg = f"oversample: expected an integer >= 1, got {oversample!r}"
        raise OptionError(msg)
    if period is not None and not (0 < period <= n and n % period == 0):
        msg = f"period: expected a divisor of the record length {n}, got {period!r}"
        raise OptionError(msg)


def simulate_sdof(
    model: BoucWenSDOF,
    u: FloatArray,
    fs_hz: float,
    *,
    oversample: int = 10,
    period: int | None = None,
    y_limit: float = np.inf,
) -> FloatArray:
    """Simulate the displacement of Eqs. (1)-(2) driven by a sampled force.

    Parameters
    ----------
    model : BoucWenSDOF
        Parameters.
    u : FloatArray
        Force, shape (nt,), N.
    fs_hz : float
        Sample rate, Hz.
    oversample : int
        RK4 steps per sample.
    period : int, optional
        Samples per period when the record holds whole periods of a periodic steady
        state: one period of warm-up is simulated first. None: from rest.
    y_limit : float
        Displacement beyond which the simulation stops (unstable parameters) and the
        remaining samples are set to ``y_limit``, m.

    Returns
    -------
    FloatArray
        Displacement, shape (nt,), m.

    Raises
    ------
    ShapeError, SignalError
        For a malformed force record.
    OptionError
        For a bad ``oversample`` or ``period``.
    """
    u, _ = check_record(u, np.zeros(np.size(u)), fs_hz, min_samples=2)
    _check_options(oversample, period, u.size)
    return _sim(model.vector(), model.nu, u, fs_hz, oversample, period, y_limit)[0]


def _sim(
    p: FloatArray, nu: float, u: FloatArray, fs_hz: float, n_sub: int,
    period: int | None, y_limit: float,
) -> tuple[FloatArray, bool]:
    if period is not None:
        ue = np.concatenate([u[-period:], u])
        uf = _fine_force(ue, n_sub, periodic=True)
    else:
        uf = _fine_force(u, n_sub, periodic=False)
    # numba Dispatcher.__call__ is typed with fixed arity; the jitted signature is hidden
    y, ok = _simulate(uf, 1.0 / (fs_hz * n_sub), n_sub, *p, nu, y_limit)  # type: ignore[call-arg]
    if period is not None:
        y = y[period: period + u.size]
    return y, bool(ok)


def _fit(
    u: FloatArray, y: FloatArray, fs_hz: float, starts: list[FloatArray], free: list[int],
    nu: float, oversample: int, period: int | None, max_nfev: int,
) -> tuple[FloatArray, FloatArray, bool, int, float]:
    """Simulation-error least squares over the ``free`` entries of [m, c, k, alpha, a, b]."""
    sy = float(np.std(y))
    y_limit = 1e3 * float(np.max(np.abs(y)))
    best: tuple[float, FloatArray, FloatArray, bool] | None = None
    n_fev = 0
    lo_all = np.array([1e-12, 0.0, 0.0, 0.0, -np.inf, -np.inf])
    for p0 in starts:
        scale = np.abs(p0).copy()
        scale[4:] = np.maximum(scale[4:], 1.0 / float(np.max(np.abs(y))))
        scale[scale == 0] = 1.0

        def resid(x: FloatArray, p0: FloatArray = p0, scale: FloatArray = scale) -> FloatArray:
            p = p0.copy()
            p[free] = x * scale[free]
            ys, _ = _sim(p, nu, u, fs_hz, oversample, period, y_limit)
            return (ys - y) / sy

        sol = least_squares(
            resid, p0[free] / scale[free], bounds=(lo_all[free] / scale[free], np.inf),
            x_scale="jac", max_nfev=max_nfev, method="trf",
        )
        n_fev += int(sol.nfev) + int(sol.njev or 0) * len(free)
        p = p0.copy()
        p[free] = sol.x * scale[free]
        cost = float(sol.cost)
        if best is None or cost < best[0]:
            J = sol.jac / scale[free][None, :] * sy
            dof = max(y.size - len(free), 1)
            s2 = 2.0 * cost * sy**2 / dof
            try:
                cov = s2 * np.linalg.inv(J.T @ J)
                std = np.sqrt(np.abs(np.diag(cov)))
            except np.linalg.LinAlgError:
                std = np.full(len(free), np.nan)
            best = (cost, p, std, sol.status > 0)
    assert best is not None
    return best[1], best[2], best[3], n_fev, float(np.sqrt(2.0 * best[0] / y.size) * sy)


def fit_linear_sdof(
    u: FloatArray,
    y: FloatArray,
    fs_hz: float,
    *,
    period: int | None = None,
    oversample: int = 10,
    max_nfev: int = 200,
) -> SDOFFit:
    """Fit a linear m-c-k model to force -> displacement by simulation-error least squares.

    The start comes from an equation-error fit ``f = m a + c v + k y`` on the
    differentiated record (:func:`~modal_twin.diagnosis.restoring_force.state_derivatives`).

    Parameters
    ----------
    u, y : FloatArray
        Force (N) and displacement (m), shape (nt,).
    fs_hz : float
        Sample rate, Hz.
    period : int, optional
        Samples per period for a periodic steady-state record (see :func:`simulate_sdof`).
    oversample : int
        RK4 steps per sample.
    max_nfev : int
        Simulation budget of ``least_squares``.

    Returns
    -------
    SDOFFit

    Raises
    ------
    ShapeError, SignalError
        For different lengths, non-finite samples or fewer than 64 samples.
    ModelError
        If the equation-error start has a non-positive mass or stiffness.
    OptionError
        For a bad ``oversample`` or ``period``.
    """
    t0 = time.perf_counter()
    u, y = check_record(u, y, fs_hz, min_samples=_MIN_SAMPLES)
    _check_options(oversample, period, u.size)
    periodic = period is not None
    y_f, v, a = state_derivatives(y, fs_hz, periodic=periodic)
    u_f = state_derivatives(u, fs_hz, periodic=periodic)[0]
    (m0, c0, k0), *_ = np.linalg.lstsq(np.column_stack([a, v, y_f]), u_f, rcond=None)
    if not (m0 > 0 and k0 > 0):
        msg = f"u, y: equation-error start has m={m0:.3g}, k={k0:.3g}; expected both > 0"
        raise ModelError(msg)
    p0 = np.array([m0, max(c0, 1e-3 * 2 * np.sqrt(k0 * m0)), k0, 0.0, 0.0, 0.0])
    p, std, ok, n_fev, rmse = _fit(u, y, fs_hz, [p0], [0, 1, 2], 1.0, oversample, period,
                                   max_nfev)
    model = BoucWenSDOF(m=p[0], c=p[1], k=p[2])
    return SDOFFit(model, std, ("m", "c", "k"), rmse, rmse / float(np.std(y)), n_fev, ok,
                   time.perf_counter() - t0)


def bouc_wen_initial_guesses(
    u: FloatArray,
    y: FloatArray,
    fs_hz: float,
    *,
    period: int | None = None,
    f_max_hz: float | None = None,
    nu: float = 1.0,
    n_best: int = 3,
) -> list[BoucWenSDOF]:
    """Return starts for the Bouc-Wen fit from the restoring-force loop (equation error).

    With ``z = alpha w`` Eq. (2) reads ``w' = y' - a|y'||w|^(nu-1) w - b y'|w|^nu``:
    ``w`` follows from the measured displacement and (a, b) alone, and Eq. (1) becomes
    linear, ``f = m a + c v + k y + alpha w``. For each (a, b) of a grid
    ``{0, +-0.5, +-1, +-2, +-4} / max|y|`` (``a + b > -4 / max|y|``) the linear least-squares
    fit of the measured force gives (m, c, k, alpha); the ``n_best`` grid points with the
    smallest force residual (and physical signs) are returned. ``alpha`` is the slope
    of the loop just after a reversal minus ``k``; ``1 / (a + b)`` the yield displacement
    that sets the loop width.

    Parameters
    ----------
    u, y : FloatArray
        Force (N) and displacement (m), shape (nt,).
    fs_hz : float
        Sample rate, Hz.
    period : int, optional
        Samples per period for a periodic record.
    f_max_hz : float, optional
        Pass band of the differentiation.
    nu : float
        Exponent of Eq. (2).
    n_best : int
        Number of starts returned.

    Returns
    -------
    list of BoucWenSDOF
        Best first.

    Raises
    ------
    ModelError
        If no grid point gives positive m, k and alpha.
    """
    u, y = check_record(u, y, fs_hz, min_samples=_MIN_SAMPLES)
    periodic = period is not None
    y_f, v, acc = state_derivatives(y, fs_hz, f_max_hz=f_max_hz, periodic=periodic)
    u_f = state_derivatives(u, fs_hz, f_max_hz=f_max_hz, periodic=periodic)[0]
    # a periodic record runs the state over one extra period so that it starts in steady state
    y_run = np.concatenate([y_f[-period:], y_f]) if period is not None else y_f
    ymax = float(np.max(np.abs(y_f)))
    grid = np.array([0.0, 0.5, 1.0, 2.0, 4.0, -0.5, -1.0, -2.0, -4.0]) / ymax
    cands: list[tuple[float, FloatArray]] = []
    for ga in grid:
        for gb in grid:
            if ga + gb <= -4.0 / ymax or (ga == 0 and gb == 0):
                continue
            w = bouc_wen_state(y_run, ga, gb, nu=nu)
            if periodic:
                w = w[period:]
            if not np.all(np.isfinite(w)) or np.max(np.abs(w)) > 50 * ymax:
                continue
            A = np.column_stack([acc, v, y_f, w])
            sol, *_ = np.linalg.lstsq(A, u_f, rcond=None)
            m, c, k, al = sol
            if m <= 0 or al <= 0 or k + al <= 0:
                continue
            res = u_f - A @ sol
            cands.append((float(res @ res), np.array([m, max(c, 0.0), max(k, 0.0), al, ga, gb])))
    if not cands:
        msg = "u, y: no Bouc-Wen start with m, alpha > 0 found on the (a, b) grid"
        raise ModelError(msg)
    cands.sort(key=lambda t: t[0])
    return [replace(BoucWenSDOF(*p), nu=nu) for _, p in cands[:n_best]]  # p: m, c, k, alpha, a, b


def fit_bouc_wen_sdof(
    u: FloatArray,
    y: FloatArray,
    fs_hz: float,
    *,
    period: int | None = None,
    nu: float = 1.0,
    starts: list[BoucWenSDOF] | None = None,
    f_max_hz: float | None = None,
    oversample: int = 10,
    max_nfev: int = 100,
) -> SDOFFit:
    """Fit Eqs. (1)-(2) (m, c, k, alpha, a, b) by simulation-error least squares.

    Parameters
    ----------
    u, y : FloatArray
        Force (N) and displacement (m) of the training record, shape (nt,).
    fs_hz : float
        Sample rate, Hz.
    period : int, optional
        Samples per period for a periodic steady-state record.
    nu : float
        Exponent of Eq. (2) (held fixed).
    starts : list of BoucWenSDOF, optional
        Initial guesses; default :func:`bouc_wen_initial_guesses`.
    f_max_hz : float, optional
        Pass band of the differentiation used for the default starts.
    oversample : int
        RK4 steps per sample.
    max_nfev : int
        Simulation budget of ``least_squares`` per start.

    Returns
    -------
    SDOFFit
        The start with the smallest training error.

    Raises
    ------
    ShapeError, SignalError
        For different lengths, non-finite samples or fewer than 64 samples.
    ModelError
        If no start can be found.
    OptionError
        For a bad ``oversample`` or ``period``.
    """
    t0 = time.perf_counter()
    u, y = check_record(u, y, fs_hz, min_samples=_MIN_SAMPLES)
    _check_options(oversample, period, u.size)
    if starts is None:
        starts = bouc_wen_initial_guesses(u, y, fs_hz, period=period, f_max_hz=f_max_hz,
                                          nu=nu)
    p0s = [replace(s, nu=nu).vector() for s in starts]
    p, std, ok, n_fev, rmse = _fit(u, y, fs_hz, p0s, [0, 1, 2, 3, 4, 5], nu, oversample,
                                   period, max_nfev)
    model = replace(BoucWenSDOF(*p), nu=nu)  # p: m, c, k, alpha, a, b
    _log.info("Bouc-Wen SDOF fit: %s, rmse %.3g m", model, rmse)
    return SDOFFit(model, std, ("m", "c", "k", "alpha", "a", "b"), rmse,
                   rmse / float(np.std(y)), n_fev, ok, time.perf_counter() - t0)
