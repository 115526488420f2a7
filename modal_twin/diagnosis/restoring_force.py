"""Restoring-force map of a single-DOF record and a classifier of the missing effect.

A single-DOF structure loaded by a measured force ``f`` obeys ``m y'' + r(state) = f``. With
the mass (and, for the residual, the linear model) known, the restoring force is read from
the data (force-state mapping, section "General Force-State Model" of [003])::

    r = f - m a                                  (total restoring force)
    e = f - m a - c v - k y                      (residual of the linear model)
    e_n = e / (k max|y|)                         Eq. (20) of [003] (error surface)

Plotted against displacement ``y`` and velocity ``v`` the residual shows what the linear
model lacks. The classifier screens the residual on a named library of effect classes in
ONE joint least-squares problem with the linear terms (y, v, a, 1) always present, so that
a mass or stiffness error is not mistaken for a nonlinearity (issue 6, item 3):

===================  ============================================  ===================
class                regressors (beside y, v, a, 1)                shape in the map
===================  ============================================  ===================
``hysteresis``       best single internal-state variable driven    loop enclosing area
                     by y: stop (Prandtl) operators at a few       (memory)
                     yields, Bouc-Wen states on an (a, b) grid
``cubic_stiffness``  y**3, y|y|                                    odd in displacement
``friction``         sign(v)                                       jump at v reversal
===================  ============================================  ===================

Classes are ranked by the Bayesian information criterion of their fit (a grid-selected
candidate pays for its two hyper-parameters). Each class gets a numeric score: the
fraction of the linear-model residual variance it explains on its own (``explained``) and
the part only it explains when fitted jointly with the others (``unique``). When no class
explains at least ``min_score`` the verdict is ``"nothing significant"`` (the residual is
at the noise level). Descriptive numbers of the
map go with it: the loop energy ratio (work of ``e`` over the record divided by the work of
the linear damping), the odd-in-y and the velocity-reversal jump indices.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from numba import njit

from modal_twin._types import FloatArray
from modal_twin.errors import ModelError, OptionError, ShapeError, SignalError
from modal_twin.models.devices.bouc_wen import bouc_wen_history

__all__ = [
    "CLASSES",
    "ResidualDiagnosis",
    "RestoringForceMap",
    "bouc_wen_state",
    "check_record",
    "classify_residual",
    "restoring_force_map",
    "state_derivatives",
    "stop_operator",
]

_log = logging.getLogger(__name__)

#: Effect classes the classifier scores, in the order of :attr:`ResidualDiagnosis.scores`.
CLASSES = ("hysteresis", "cubic_stiffness", "friction")
NOTHING = "nothing significant"
_STOP_LEVELS = (0.1, 0.2, 0.4, 0.8)  # yield displacements of the stop operators / std(y)
# (a, b) max|y| of the Bouc-Wen states screened as hysteresis candidates
_BW_GRID = tuple(
    (ga, gb)
    for ga in (0.0, 0.5, 1.0, 2.0, 4.0)
    for gb in (-3.0, -1.5, -0.5, 0.0, 0.5, 1.5, 3.0)
    if ga + gb > -2.0 and (ga, gb) != (0.0, 0.0)
)


def check_record(
    u: FloatArray, y: FloatArray, fs_hz: float, *, min_samples: int = 64
) -> tuple[FloatArray, FloatArray]:
    """Validate a force / displacement record and return both as 1-D float arrays.

    Parameters
    ----------
    u, y : FloatArray
        Force (N) and displacement (m), shape (nt,) or (1, nt).
    fs_hz : float
        Sample rate, Hz.
    min_samples : int
        Fewest samples accepted.

    Returns
    -------
    u, y : FloatArray
        Shape (nt,).

    Raises
    ------
    ShapeError
        If the lengths differ, an array has more than one channel or is too short.
    SignalError
        If a sample is not finite or ``fs_hz`` is not a positive finite number.
    """
    out = []
    for name, x in (("u", u), ("y", y)):
        a = np.asarray(x, dtype=float)
        if a.ndim == 2 and 1 in a.shape:
            a = a.ravel()
        if a.ndim != 1:
            msg = f"{name}: expected one channel, shape (nt,), got {np.shape(x)}"
            raise ShapeError(msg)
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            msg = f"{name}: expected finite samples, got {a[bad[0]]} at index {bad[0]}"
            raise SignalError(msg)
        out.append(a)
    if out[0].size != out[1].size:
        msg = f"u, y: expected equal lengths, got {out[0].size} and {out[1].size}"
        raise ShapeError(msg)
    if out[0].size < min_samples:
        msg = f"u, y: expected at least {min_samples} samples, got {out[0].size}"
        raise ShapeError(msg)
    if not (np.isfinite(fs_hz) and fs_hz > 0):
        msg = f"fs_hz: expected a positive finite sample rate, got {fs_hz!r}"
        raise SignalError(msg)
    return out[0], out[1]


def state_derivatives(
    x: FloatArray, fs_hz: float, *, f_max_hz: float | None = None, periodic: bool = False
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Low-pass a record and differentiate it twice in the frequency domain.

    ``X(f) -> X, j w X, -w^2 X`` for ``f <= f_max_hz`` and zero above (a brick-wall window,
    the same for the three outputs, so that ``f - m a`` stays consistent when the force is
    passed through the same call). A record that is not one or more whole periods is
    mirrored (even extension) first, which removes the jump at the wrap-around.

    Parameters
    ----------
    x : FloatArray
        Record, shape (nt,).
    fs_hz : float
        Sample rate, Hz.
    f_max_hz : float, optional
        Upper edge of the pass band, Hz; default ``0.4 fs_hz``.
    periodic : bool
        True when the record holds whole periods of a periodic steady state.

    Returns
    -------
    x_f, v, a : FloatArray
        Filtered record, its first and second time derivatives, shape (nt,).

    Raises
    ------
    OptionError
        If ``f_max_hz`` is not in (0, fs_hz / 2].
    """
    f_max = 0.4 * fs_hz if f_max_hz is None else float(f_max_hz)
    if not 0.0 < f_max <= 0.5 * fs_hz:
        msg = f"f_max_hz: expected 0 < f_max_hz <= fs_hz / 2 = {0.5 * fs_hz}, got {f_max}"
        raise OptionError(msg)
    x = np.asarray(x, dtype=float)
    n = x.size
    xe = x if periodic else np.concatenate([x, x[::-1]])
    X = np.fft.rfft(xe)
    f = np.fft.rfftfreq(xe.size, 1.0 / fs_hz)
    X[f > f_max] = 0.0
    jw = 2j * np.pi * f
    x_f = np.fft.irfft(X, xe.size)[:n]
    v = np.fft.irfft(jw * X, xe.size)[:n]
    a = np.fft.irfft(jw * jw * X, xe.size)[:n]
    return x_f, v, a


def bouc_wen_state(
    y: FloatArray, a: float, b: float, *, nu: float = 1.0, n_sub: int = 4
) -> FloatArray:
    """Return the Bouc-Wen state ``w`` driven along a displacement history (w_0 = 0).

    ``w' = y' - a |y'| |w|^(nu - 1) w - b y' |w|^nu``: the hysteretic variable of Eq. (10)
    of [004] in its uniaxial form with unit initial slope (the force is ``z = alpha w``).
    Rate independent, so it is integrated along the displacement path (RK4, ``n_sub``
    sub-steps per sample) by the one Bouc-Wen integrator,
    :func:`modal_twin.models.devices.bouc_wen.bouc_wen_history` (A = 1, beta = a,
    gamma = b).

    Parameters
    ----------
    y : FloatArray
        Displacement, shape (nt,), m.
    a, b : float
        Shape parameters, 1/m (for nu = 1).
    nu : float
        Exponent, >= 1.
    n_sub : int
        RK4 sub-steps per sample.

    Returns
    -------
    FloatArray
        Shape (nt,), m.
    """
    return bouc_wen_history(y, beta=a, gamma=b, A=1.0, nu=nu, n_sub=n_sub)


@njit(cache=True)
def _stop(y, r):  # pragma: no cover - jitted
    s = np.empty_like(y)
    acc = 0.0
    s[0] = 0.0
    for i in range(1, y.size):
        acc += y[i] - y[i - 1]
        acc = min(max(acc, -r), r)
        s[i] = acc
    return s


def stop_operator(y: FloatArray, r: float) -> FloatArray:
    """Return the stop (elastic-perfectly-plastic) operator of ``y`` with yield ``r``.

    ``s_i = clip(s_{i-1} + y_i - y_{i-1}, -r, r)``, ``s_0 = 0``: the internal variable of a
    Prandtl element (a spring of unit stiffness in series with a slider), the building
    block of the slip hysteresis of Eqs. (6)-(12) of [003] and of Prandtl-Ishlinskii models.

    Parameters
    ----------
    y : FloatArray
        Displacement, shape (nt,), m.
    r : float
        Yield displacement, m (> 0).

    Returns
    -------
    FloatArray
        Shape (nt,), m.
    """
    if not r > 0:
        msg = f"r: expected a positive yield displacement, got {r!r}"
        raise OptionError(msg)
    return _stop(np.ascontiguousarray(y, dtype=float), float(r))


@dataclass(frozen=True, slots=True)
class RestoringForceMap:
    """Restoring force of a single-DOF record against displacement and velocity.

    Attributes
    ----------
    y, v, a : FloatArray
        Filtered displacement (m), velocity (m/s), acceleration (m/s^2), shape (nt,).
    f : FloatArray
        Filtered force, shape (nt,), N.
    r : FloatArray
        Total restoring force ``f - m a``, shape (nt,), N.
    e : FloatArray
        Residual of the linear model ``f - m a - c v - k y``, shape (nt,), N.
    e_norm : FloatArray
        ``e / (k max|y|)``, Eq. (20) of [003], shape (nt,).
    surface : FloatArray
        Mean of ``e_norm`` in (y, v) bins, shape (n_bins, n_bins) (NaN for empty bins).
    y_edges, v_edges : FloatArray
        Bin edges, shape (n_bins + 1,).
    m, c, k : float
        Linear model used (kg, N s/m, N/m).
    """

    y: FloatArray
    v: FloatArray
    a: FloatArray
    f: FloatArray
    r: FloatArray
    e: FloatArray
    e_norm: FloatArray
    surface: FloatArray
    y_edges: FloatArray
    v_edges: FloatArray
    m: float
    c: float
    k: float


def restoring_force_map(
    u: FloatArray,
    y: FloatArray,
    fs_hz: float,
    *,
    m: float,
    c: float,
    k: float,
    f_max_hz: float | None = None,
    period: int | None = None,
    n_bins: int = 21,
    trim: float = 0.02,
) -> RestoringForceMap:
    """Restoring force and error surface of the linear model, Eq. (20) of [003].

    Parameters
    ----------
    u, y : FloatArray
        Measured force (N) and displacement (m), shape (nt,).
    fs_hz : float
        Sample rate, Hz.
    m, c, k : float
        Mass (kg), viscous damping (N s/m) and stiffness (N/m) of the linear model.
    f_max_hz : float, optional
        Pass band of the differentiation, see :func:`state_derivatives`.
    period : int, optional
        Samples per period when the record holds whole periods of a periodic steady
        state: the periods are averaged (noise / sqrt(n_periods)) and differentiated as
        periodic. None: a transient record, mirrored and trimmed at the ends.
    n_bins : int
        Bins per axis of the error surface.
    trim : float
        Fraction of samples dropped at each end of a non-periodic record (filter edges).

    Returns
    -------
    RestoringForceMap

    Raises
    ------
    ShapeError, SignalError
        From :func:`check_record`.
    ModelError
        If ``m`` or ``k`` is not positive.
    OptionError
        If ``period`` does not divide the record length.
    """
    u, y = check_record(u, y, fs_hz)
    if not (m > 0 and k > 0):
        msg = f"m, k: expected positive mass and stiffness, got m={m}, k={k}"
        raise ModelError(msg)
    periodic = period is not None
    if period is not None:
        if not (0 < period <= y.size and y.size % period == 0):
            msg = f"period: expected a divisor of the record length {y.size}, got {period!r}"
            raise OptionError(msg)
        u = u.reshape(-1, period).mean(axis=0)
        y = y.reshape(-1, period).mean(axis=0)
    y_f, v, a = state_derivatives(y, fs_hz, f_max_hz=f_max_hz, periodic=periodic)
    f_f = state_derivatives(u, fs_hz, f_max_hz=f_max_hz, periodic=periodic)[0]
    if not periodic:
        n0 = int(trim * y.size)
        sl = slice(n0, y.size - n0)
        y_f, v, a, f_f = y_f[sl], v[sl], a[sl], f_f[sl]
    r = f_f - m * a
    e = r - c * v - k * y_f
    e_norm = e / (k * np.max(np.abs(y_f)))  # Eq. (20) of [003]
    y_edges = np.linspace(y_f.min(), y_f.max(), n_bins + 1)
    v_edges = np.linspace(v.min(), v.max(), n_bins + 1)
    s, _, _ = np.histogram2d(y_f, v, bins=(y_edges, v_edges), weights=e_norm)
    cnt, _, _ = np.histogram2d(y_f, v, bins=(y_edges, v_edges))
    with np.errstate(invalid="ignore", divide="ignore"):
        surface = np.where(cnt > 0, s / np.maximum(cnt, 1), np.nan)
    return RestoringForceMap(
        y=y_f, v=v, a=a, f=f_f, r=r, e=e, e_norm=e_norm, surface=surface,
        y_edges=y_edges, v_edges=v_edges, m=float(m), c=float(c), k=float(k),
    )


@dataclass(frozen=True, slots=True)
class ResidualDiagnosis:
    """Verdict of :func:`classify_residual`.

    Attributes
    ----------
    top : str
        Most likely missing effect (one of :data:`CLASSES`) or ``"nothing significant"``.
    ranking : tuple of str
        Classes by decreasing ``explained`` score.
    explained : dict
        Class -> fraction of the linear-model residual variance the class explains on its
        own (with the linear terms refitted jointly), in [0, 1].
    unique : dict
        Class -> fraction only that class explains when all classes are fitted jointly.
    unexplained : float
        Residual variance left by the joint fit over that of the linear terms alone
        (near 1: nothing but noise; near 0: the library explains the residual).
    loop_energy_ratio : float
        ``sum(e v) / sum(c v^2)``: energy dissipated by the residual force over that of
        the linear damping (0 for a memoryless odd residual; > 0 for missing dissipation).
    odd_index : float
        Variance fraction of ``e`` that is odd in y and even in v (stiffness-like).
    jump_index : float
        Mean jump of ``e`` across velocity reversals over ``std(e)``.
    min_score : float
        Threshold used for the verdict.
    """

    top: str
    ranking: tuple[str, ...]
    explained: dict[str, float]
    unique: dict[str, float]
    unexplained: float
    loop_energy_ratio: float
    odd_index: float
    jump_index: float
    min_score: float

    @property
    def significant(self) -> bool:
        """True when an effect explains at least ``min_score`` of the residual."""
        return self.top != NOTHING


def _unit(col: FloatArray) -> FloatArray:
    s = float(np.std(col))
    return col / s if s > 0 else col


def _library(rf: RestoringForceMap) -> tuple[FloatArray, dict[str, list[FloatArray]]]:
    """Return the linear columns and, per class, its candidate regressor sets (unit rms).

    Hysteresis candidates are internal-state variables driven by the measured
    displacement: stop operators (Prandtl elements, Eqs. (6)-(12) of [003]) at a few
    yield displacements and the Bouc-Wen state w of ``w' = y' - a|y'|w - b y'|w|``
    (Eq. (10) of [004] in its uniaxial nu = 1 form) on a grid of (a, b) that holds
    softening (a + b > 0) and hardening (a + b < 0) loops.
    """
    y, v = rf.y, rf.v
    sy = float(np.std(y))
    yc = y - np.mean(y)
    ymax = float(np.max(np.abs(yc)))
    lin = np.column_stack([_unit(y), _unit(v), _unit(rf.a), np.ones_like(y)])
    hyst = [_unit(stop_operator(yc, q * sy))[:, None] for q in _STOP_LEVELS]
    for ga, gb in _BW_GRID:
        w = bouc_wen_history(yc, beta=ga / ymax, gamma=gb / ymax, A=1.0, nu=1.0, n_sub=2)
        if np.all(np.isfinite(w)) and np.max(np.abs(w)) < 50 * ymax:
            hyst.append(_unit(w)[:, None])
    groups = {
        "hysteresis": hyst,
        "cubic_stiffness": [np.column_stack([_unit(yc**3), _unit(yc * np.abs(yc))])],
        "friction": [_unit(np.sign(v))[:, None]],
    }
    return lin, groups


def _rss(A: FloatArray, b: FloatArray) -> float:
    sol, *_ = np.linalg.lstsq(A, b, rcond=None)
    res = b - A @ sol
    return float(res @ res)


def classify_residual(rf: RestoringForceMap, *, min_score: float = 0.1) -> ResidualDiagnosis:
    """Name the effect class the linear model most likely lacks, with numeric scores.

    One joint least-squares fit of the residual ``e`` on the linear terms and the library
    of :data:`CLASSES` (section 3 of issue 6); scores are variance fractions of the
    residual left by the linear terms alone (see :class:`ResidualDiagnosis`).

    Parameters
    ----------
    rf : RestoringForceMap
        Map of the linear model, from :func:`restoring_force_map`.
    min_score : float
        Smallest ``explained`` fraction that counts as significant, in (0, 1).

    Returns
    -------
    ResidualDiagnosis

    Raises
    ------
    OptionError
        If ``min_score`` is not in (0, 1).
    """
    if not 0.0 < min_score < 1.0:
        msg = f"min_score: expected a fraction in (0, 1), got {min_score!r}"
        raise OptionError(msg)
    lin, groups = _library(rf)
    e = rf.e
    n = e.size
    tiny = float(np.finfo(float).tiny)
    rss0 = max(_rss(lin, e), tiny)
    best: dict[str, FloatArray] = {}
    rss: dict[str, float] = {}
    for g, cands in groups.items():
        r = [_rss(np.hstack([lin, X]), e) for X in cands]
        i = int(np.argmin(r))
        best[g] = cands[i]
        rss[g] = max(r[i], tiny)
    explained = {g: max(0.0, 1.0 - rss[g] / rss0) for g in groups}
    # Bayesian information criterion; a grid-selected candidate pays for its 2 hyper-parameters
    n_par = {g: best[g].shape[1] + (2 if len(groups[g]) > 1 else 0) for g in groups}
    bic = {g: n * np.log(rss[g] / n) + n_par[g] * np.log(n) for g in groups}
    rss_full = _rss(np.hstack([lin, *best.values()]), e)
    unique = {}
    for g in groups:
        others = np.hstack([lin, *(X for h, X in best.items() if h != g)])
        unique[g] = max(0.0, (_rss(others, e) - rss_full) / rss0)
    ranking = tuple(sorted(CLASSES, key=lambda g: bic[g]))
    top = ranking[0] if explained[ranking[0]] >= min_score else NOTHING
    # descriptive indices of the map
    v = rf.v
    loop = float(np.sum(e * v)) / max(float(rf.c * np.sum(v * v)), np.finfo(float).tiny)
    yc = rf.y - np.mean(rf.y)
    Xo = np.column_stack([yc, yc**3, yc * np.abs(yc)])
    odd = 1.0 - _rss(np.column_stack([Xo, np.ones_like(yc)]), e) / max(
        float(np.sum((e - e.mean()) ** 2)), np.finfo(float).tiny
    )
    rev = np.flatnonzero(np.sign(v[1:]) != np.sign(v[:-1]))
    rev = rev[(rev >= 2) & (rev < v.size - 3)]
    if rev.size:
        jumps = (e[rev + 2] - e[rev - 1]) * np.sign(v[rev + 2])
        jump = float(np.mean(jumps) / max(float(np.std(e)), np.finfo(float).tiny))
    else:
        jump = 0.0
    _log.debug("residual scores: explained %s, unique %s", explained, unique)
    return ResidualDiagnosis(
        top=top, ranking=ranking, explained=explained, unique=unique,
        unexplained=rss_full / rss0, loop_energy_ratio=loop, odd_index=float(odd),
        jump_index=jump, min_score=float(min_score),
    )
