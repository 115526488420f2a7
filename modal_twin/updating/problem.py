"""The updating problem: parametric model, measured DOFs, identified modes, bounds, weights.

``K(theta) = K0 + sum_i K_i (theta_i - theta0_i)`` and likewise ``M`` (Sec. 4 of [004]).
At a trial ``theta`` the problem solves the lowest FEM modes, matches them to the
identified ones (:func:`~modal_twin.updating.matching.match_modes`) and returns

* :meth:`UpdatingProblem.cost` -- Eq. (3) of [004] (penalised, never ``inf``: the global
  search needs a finite value), and
* :meth:`UpdatingProblem.residual` / :meth:`UpdatingProblem.jacobian` -- the least-squares
  form used by the gradient refinement::

      r_f,i   = (f_l / f_i - 1) / s_f,i
      r_phi,i = sqrt(w_mac) (a_i - m_i b_l) / ||a_i||,   m_i = a_i' b_l / b_l' b_l

  where ``a_i`` is the identified shape, ``b_l = S phi_l`` the FEM shape at the measured
  DOFs and ``m_i`` the modal scale factor. ``||r_phi,i||^2 = w_mac (1 - MAC)``, so the sum
  of squares is Eq. (3) of [004] with squared frequency errors (Eq. (1) of [000]).

With ``prior_weight = w > 0`` the residual gains one row per parameter,
``sqrt(w) (theta_i - theta0_i) / s_i`` with ``s_i = (upper_i - lower_i) / sqrt(12)`` (the
spread of a uniform prior over the bounds): a Tikhonov pull towards the nominal model that
keeps the directions the modes do not inform at plausible values instead of letting them
drift to a bound (the pedestrian bridge: 1 parameter at a bound instead of 13 of 17).

Bad trial points (``K(theta)`` not positive definite, solver failure) give a penalty, so an
optimizer steps back instead of crashing (item 9 of issue 5).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.optimize as so
import scipy.sparse as sp
from numpy.typing import NDArray

from modal_twin._types import ComplexArray, FloatArray, IntArray, Matrix
from modal_twin.errors import ConvergenceError, ModelError, OptionError, ShapeError
from modal_twin.identification.modal_model import ModalModel
from modal_twin.models.fe import ParametricMatrices, solve_modes
from modal_twin.updating.matching import ModePairing, match_modes, pair_costs
from modal_twin.updating.sensitivity import eigen_derivatives

__all__ = ["ModeTargets", "UpdatingProblem", "real_shapes"]

_log = logging.getLogger(__name__)
PENALTY = 10.0
"""Cost (per identified mode) and residual value returned at an infeasible trial point."""


def real_shapes(shapes: NDArray[np.inexact]) -> FloatArray:
    """Return real shapes: each column rotated by its mean phase, then its real part."""
    s = np.asarray(shapes)
    if not np.iscomplexobj(s):
        return np.asarray(s, dtype=float)
    ang = 0.5 * np.angle(np.sum(s * s, axis=0))
    return np.asarray((s * np.exp(-1j * ang)).real, dtype=float)


@dataclass(frozen=True, slots=True)
class ModeTargets:
    """Identified modes the model is updated to.

    Attributes
    ----------
    f_hz : (m,) float array
        Natural frequencies, Hz (> 0).
    shapes : (n_ch, m) float array
        Real mode shapes at the measured DOFs.
    zeta : (m,) float array
        Damping ratios (NaN when unknown).
    std_f_hz : (m,) float array
        Standard deviation of each frequency (NaN when unknown).
    std_shapes : (n_ch, m) float array
        Standard deviation of each shape entry, same scale as ``shapes`` (NaN: unknown).
    """

    f_hz: FloatArray
    shapes: FloatArray
    zeta: FloatArray
    std_f_hz: FloatArray
    std_shapes: FloatArray

    def __post_init__(self) -> None:
        f = np.asarray(self.f_hz, dtype=float)
        if f.ndim != 1 or f.size == 0:
            msg = f"f_hz: expected at least one identified mode, got shape {f.shape}"
            raise ShapeError(msg)
        if np.any(~np.isfinite(f)) or np.any(f <= 0.0):
            msg = f"f_hz: expected finite frequencies > 0, got {f.tolist()}"
            raise ShapeError(msg)
        if self.shapes.ndim != 2 or self.shapes.shape[1] != f.size:
            msg = f"shapes: expected (n_ch, {f.size}), got {self.shapes.shape}"
            raise ShapeError(msg)
        for name in ("zeta", "std_f_hz"):
            if getattr(self, name).shape != f.shape:
                msg = f"{name}: expected shape {f.shape}, got {getattr(self, name).shape}"
                raise ShapeError(msg)
        if self.std_shapes.shape != self.shapes.shape:
            msg = f"std_shapes: expected {self.shapes.shape}, got {self.std_shapes.shape}"
            raise ShapeError(msg)

    @property
    def n_modes(self) -> int:
        """Number of identified modes."""
        return int(self.f_hz.size)

    @classmethod
    def create(cls, f_hz: Sequence[float] | FloatArray, shapes: FloatArray | ComplexArray, *,
               zeta: Sequence[float] | FloatArray | None = None,
               std_f_hz: Sequence[float] | FloatArray | None = None,
               std_shapes: FloatArray | None = None) -> ModeTargets:
        """Build targets; missing damping / standard deviations become NaN."""
        f = np.atleast_1d(np.asarray(f_hz, dtype=float))
        S = real_shapes(np.asarray(shapes))
        if S.ndim == 1:
            S = S[:, None]
        nan = np.full(f.shape, np.nan)
        return cls(
            f_hz=f, shapes=S,
            zeta=nan.copy() if zeta is None else np.asarray(zeta, dtype=float),
            std_f_hz=nan.copy() if std_f_hz is None else np.asarray(std_f_hz, dtype=float),
            std_shapes=np.full(S.shape, np.nan) if std_shapes is None
            else np.asarray(std_shapes, dtype=float))

    @classmethod
    def from_modal_model(cls, mm: ModalModel, modes: Sequence[int] | None = None
                         ) -> ModeTargets:
        """Targets from an identification result (all modes, or those indexed by ``modes``)."""
        if mm.f_hz.size == 0:
            msg = "mm: expected at least one identified mode, got an empty ModalModel"
            raise ShapeError(msg)
        k = np.arange(mm.f_hz.size) if modes is None else np.asarray(modes, dtype=np.int64)
        return cls.create(mm.f_hz[k], mm.shapes[:, k], zeta=mm.zeta[k],
                          std_f_hz=mm.std_f_hz[k])

    def subset(self, modes: Sequence[int]) -> ModeTargets:
        """Targets restricted to the modes indexed by ``modes``."""
        k = np.asarray(modes, dtype=np.int64)
        return ModeTargets(self.f_hz[k], self.shapes[:, k], self.zeta[k], self.std_f_hz[k],
                           self.std_shapes[:, k])


@dataclass(frozen=True, slots=True)
class _Modes:
    theta: FloatArray
    lam: FloatArray
    f_hz: FloatArray
    Phi: FloatArray
    Phi_s: FloatArray
    K: Matrix
    M: Matrix


def _check_bounds(names: tuple[str, ...], lower: FloatArray, upper: FloatArray) -> None:
    for nm, lo, hi in zip(names, lower, upper, strict=True):
        if not (math.isfinite(lo) and math.isfinite(hi)):
            msg = f"bounds of {nm!r}: expected finite (lower, upper), got ({lo}, {hi})"
            raise OptionError(msg)
        if not lo < hi:
            msg = f"bounds of {nm!r}: expected lower < upper, got ({lo}, {hi})"
            raise OptionError(msg)


class UpdatingProblem:
    """Parametric model + targets + bounds: cost, residuals and their analytic Jacobian.

    Parameters
    ----------
    K0, M0 : (n, n) sparse or dense arrays
        Stiffness and mass at ``theta0``.
    dK, dM : sequence of (n, n) matrices or None
        ``dK/dtheta_i``, ``dM/dtheta_i`` (None: the parameter does not enter).
    theta0 : (p,) array_like
        Parameter values of ``K0``, ``M0``.
    names : sequence of str
    lower, upper : (p,) array_like
        Bounds (finite, ``lower < upper``).
    S : (n_ch, n) matrix or (n_ch,) int array
        Measured DOFs (rows of a selection matrix, or DOF indices).
    targets : ModeTargets
    n_modes : int, optional
        FEM modes computed (default ``max(2 m, m + 6)``, at most ``n - 2``).
    w_mac : float
        Weight of the shape term (``lambda^MAC`` of Eq. (3b) of [004]; 0 drops shapes).
    f_scale : (m,) array_like or float
        ``s_f`` of the frequency residual (1: relative error).
    r_f, r_mac : float
        Matching windows of Eq. (4) of [004].
    prior_weight : float
        Weight ``w`` of the pull towards ``theta0`` (module docstring; 0: none).

    Raises
    ------
    ShapeError, OptionError
        Inconsistent sizes, missing or inverted bounds.
    """

    def __init__(
        self, K0: Matrix, M0: Matrix, dK: Sequence[Matrix | None],
        dM: Sequence[Matrix | None] | None, theta0: Sequence[float] | FloatArray,
        names: Sequence[str], lower: Sequence[float] | FloatArray,
        upper: Sequence[float] | FloatArray, S: Matrix | IntArray, targets: ModeTargets, *,
        n_modes: int | None = None, w_mac: float = 1.0,
        f_scale: float | Sequence[float] | FloatArray = 1.0, r_f: float = 0.10,
        r_mac: float = 0.15, prior_weight: float = 0.0,
    ) -> None:
        n = K0.shape[0]
        self.K0, self.M0 = K0, M0
        self.names = tuple(names)
        p = len(self.names)
        self.theta0 = np.asarray(theta0, dtype=float).ravel()
        lo = np.asarray(lower, dtype=float).ravel()
        hi = np.asarray(upper, dtype=float).ravel()
        if p == 0:
            msg = "names: expected at least one parameter to update, got none"
            raise OptionError(msg)
        for nm, arr in (("theta0", self.theta0), ("lower", lo), ("upper", hi)):
            if arr.shape != (p,):
                msg = f"{nm}: expected shape ({p},) for {p} parameters, got {arr.shape}"
                raise ShapeError(msg)
        _check_bounds(self.names, lo, hi)
        self.lower, self.upper = lo, hi
        if len(dK) != p or (dM is not None and len(dM) != p):
            msg = f"dK / dM: expected {p} matrices each, got {len(dK)} / {len(dM or [])}"
            raise ShapeError(msg)
        self.dK = tuple(dK)
        self.dM = tuple(dM) if dM is not None else (None,) * p
        if isinstance(S, np.ndarray) and S.ndim == 1:
            idx = np.asarray(S, dtype=np.int64)
            if idx.size and (idx.min() < 0 or idx.max() >= n):
                msg = f"S: expected DOF indices in [0, {n}), got range [{idx.min()}, {idx.max()}]"
                raise ShapeError(msg)
            S = sp.csr_array((np.ones(idx.size), (np.arange(idx.size), idx)),
                             shape=(idx.size, n))
        if S.shape[1] != n or S.shape[0] != targets.shapes.shape[0]:
            msg = (f"S: expected ({targets.shapes.shape[0]}, {n}) (channels x DOFs), "
                   f"got {S.shape}")
            raise ShapeError(msg)
        self.S = sp.csr_array(S)
        self.targets = targets
        m = targets.n_modes
        default = max(2 * m, m + 6)
        self.n_modes = int(min(default if n_modes is None else n_modes, n if n <= 400 else n - 2))
        if self.n_modes < m:
            msg = f"n_modes: expected >= {m} (identified modes), got {self.n_modes}"
            raise OptionError(msg)
        self.w_mac = float(w_mac)
        self.f_scale = np.broadcast_to(np.asarray(f_scale, dtype=float), (m,)).copy()
        self.r_f, self.r_mac = float(r_f), float(r_mac)
        if not (math.isfinite(prior_weight) and prior_weight >= 0.0):
            msg = f"prior_weight: expected a finite value >= 0, got {prior_weight!r}"
            raise OptionError(msg)
        self.prior_weight = float(prior_weight)
        self._prior_scale = (hi - lo) / math.sqrt(12.0)
        self.n_eigen_solves = 0
        self._cache: _Modes | None = None

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_parametric(
        cls, par: ParametricMatrices, S: Matrix | IntArray, targets: ModeTargets, *,
        names: Sequence[str], bounds: Mapping[str, tuple[float, float]] | None = None,
        rel_bounds: float | None = None, theta: Mapping[str, float] | FloatArray | None = None,
        **options: object,
    ) -> UpdatingProblem:
        """Problem over the parameters ``names`` of an assembly, the others held at ``theta``.

        Bounds come from ``bounds[name]`` or, failing that, ``theta_i (1 -/+ rel_bounds)``.

        Raises
        ------
        OptionError
            A parameter without bounds, or an unknown name.
        """
        th = par.theta_vector(theta)
        idx = [par.index(nm) for nm in names]
        lo, hi = [], []
        for nm, i in zip(names, idx, strict=True):
            if bounds is not None and nm in bounds:
                a, b = bounds[nm]
            elif rel_bounds is not None:
                a, b = sorted((th[i] * (1.0 - rel_bounds), th[i] * (1.0 + rel_bounds)))
            else:
                msg = f"bounds: parameter {nm!r} has none; give bounds[{nm!r}] or rel_bounds"
                raise OptionError(msg)
            lo.append(a)
            hi.append(b)
        return cls(par.K(th), par.M(th), [par.dK(i) for i in idx], [par.dM(i) for i in idx],
                   th[idx], list(names), lo, hi, S, targets, **options)  # type: ignore[arg-type]

    def with_targets(self, targets: ModeTargets, **options: object) -> UpdatingProblem:
        """Return the same model and parameters with other targets (a stage using other modes)."""
        kw: dict[str, object] = {"n_modes": self.n_modes, "w_mac": self.w_mac,
                                 "r_f": self.r_f, "r_mac": self.r_mac,
                                 "prior_weight": self.prior_weight}
        kw.update(options)
        return UpdatingProblem(self.K0, self.M0, self.dK, self.dM, self.theta0, self.names,
                               self.lower, self.upper, self.S, targets, **kw)  # type: ignore[arg-type]

    # ------------------------------------------------------------------ model
    def matrices(self, theta: FloatArray) -> tuple[Matrix, Matrix]:
        """Return ``K(theta)``, ``M(theta)`` (Sec. 4 of [004])."""
        d = np.asarray(theta, dtype=float) - self.theta0
        K, M = self.K0, self.M0
        for i, di in enumerate(d):
            if di != 0.0:
                if self.dK[i] is not None:
                    K = K + di * self.dK[i]  # Sec. 4 of [004]
                if self.dM[i] is not None:
                    M = M + di * self.dM[i]
        return K, M

    def modes(self, theta: FloatArray) -> _Modes:
        """Lowest ``n_modes`` modes at ``theta`` (cached for the last point).

        Raises
        ------
        ModelError
            ``K(theta)`` not positive definite or ``M(theta)`` with negative mass.
        ConvergenceError
            The eigen-solver failed.
        """
        th = np.asarray(theta, dtype=float).ravel()
        if th.shape != self.theta0.shape:
            msg = f"theta: expected shape {self.theta0.shape}, got {th.shape}"
            raise ShapeError(msg)
        if self._cache is not None and np.array_equal(self._cache.theta, th):
            return self._cache
        K, M = self.matrices(th)
        self.n_eigen_solves += 1
        sol = solve_modes(K, M, self.n_modes)
        lam = sol.eigenvalues
        scale = float(np.max(np.abs(lam))) if lam.size else 1.0
        if lam[0] <= 1e-9 * scale:
            msg = (f"theta: K(theta) is not positive definite (lowest eigenvalue "
                   f"{lam[0]:.3g} rad^2/s^2) at {dict(zip(self.names, th.tolist(), strict=True))}")
            raise ModelError(msg)
        out = _Modes(th.copy(), lam, sol.f_hz, sol.Phi, np.asarray(self.S @ sol.Phi), K, M)
        self._cache = out
        return out

    def pairing(self, theta: FloatArray, *, method: str = "assignment") -> ModePairing:
        """Match the targets to the FEM modes at ``theta`` (Eqs. (4)-(5) of [004])."""
        md = self.modes(theta)
        t = self.targets
        return match_modes(t.f_hz, t.shapes, md.f_hz, md.Phi_s, w_mac=max(self.w_mac, 1e-12),
                           r_f=self.r_f, r_mac=self.r_mac, method=method)  # type: ignore[arg-type]

    def _full_index(self, md: _Modes, pairing: ModePairing) -> IntArray:
        """FEM mode of every target: the match, or the cheapest unused mode if unmatched."""
        idx = pairing.fem_index.copy()
        miss = np.flatnonzero(idx < 0)
        if miss.size:
            t = self.targets
            free = np.array(pairing.unused_fem, dtype=np.int64)
            cost, *_ = pair_costs(t.f_hz[miss], t.shapes[:, miss], md.f_hz[free],
                                  md.Phi_s[:, free], w_mac=self.w_mac)
            r, c = so.linear_sum_assignment(cost)
            idx[miss[r]] = free[c]
        return idx

    # ------------------------------------------------------------------ objectives
    def cost(self, theta: FloatArray) -> float:
        """Eq. (3) of [004] at ``theta``; unmatched modes and bad points are penalised.

        An unmatched mode costs ``1 +`` its error against the cheapest free FEM mode (a
        finite stand-in for the ``inf`` of Sec. 5.1 of [004] that keeps a slope); a point
        where the model is invalid costs ``PENALTY`` per mode.
        """
        try:
            md = self.modes(theta)
            pr = self.pairing(theta)
        except (ModelError, ConvergenceError) as err:
            _log.debug("cost: penalty at an invalid point: %s", err)
            return PENALTY * self.targets.n_modes
        idx = self._full_index(md, pr)
        cost, *_ = pair_costs(self.targets.f_hz, self.targets.shapes, md.f_hz[idx],
                              md.Phi_s[:, idx], w_mac=self.w_mac)
        J = np.diag(cost)  # Eq. (3b) of [004]
        out = J.sum() + (pr.fem_index < 0).sum()  # Eq. (3a) of [004] + penalty
        if self.prior_weight > 0.0:  # the prior in the units of |df|: w (z' z) mean(s_f)^2
            z = self._prior_residual(np.asarray(theta, dtype=float))
            out += float(z @ z) * float(np.mean(self.f_scale)) ** 2
        return float(out)

    def objective(self, theta: FloatArray) -> float:
        """Sum of squared residuals (what :func:`~.optimize.refine` minimises)."""
        r = self.residual(theta)
        return float(r @ r)

    def _prior_residual(self, theta: FloatArray) -> FloatArray:
        return math.sqrt(self.prior_weight) * (theta - self.theta0) / self._prior_scale

    __call__ = cost

    def residual_size(self) -> int:
        """Length of the residual vector."""
        m = self.targets.n_modes
        n_prior = self.theta0.size if self.prior_weight > 0.0 else 0
        return m + (m * self.S.shape[0] if self.w_mac > 0 else 0) + n_prior

    def residual(self, theta: FloatArray) -> FloatArray:
        """Least-squares residual (module docstring); ``PENALTY`` entries at a bad point."""
        try:
            md = self.modes(theta)
            pr = self.pairing(theta)
        except (ModelError, ConvergenceError):
            return np.full(self.residual_size(), PENALTY)
        r = self._residual(md, self._full_index(md, pr))
        if self.prior_weight > 0.0:
            r = np.concatenate([r, self._prior_residual(md.theta)])
        return r

    def _residual(self, md: _Modes, idx: IntArray) -> FloatArray:
        t = self.targets
        rf = (md.f_hz[idx] / t.f_hz - 1.0) / self.f_scale
        if self.w_mac <= 0:
            return rf
        a = t.shapes
        b = md.Phi_s[:, idx]
        na = np.linalg.norm(a, axis=0)
        m = np.sum(a * b, axis=0) / np.sum(b * b, axis=0)  # modal scale factor
        rp = np.sqrt(self.w_mac) * (a - m * b) / na
        return np.concatenate([rf, rp.T.ravel()])

    def residual_sigma(self) -> FloatArray:
        """Return the identification's standard deviation of each residual (inf: unknown)."""
        t = self.targets
        sf = t.std_f_hz / t.f_hz / self.f_scale
        sf = np.where(np.isfinite(sf) & (sf > 0), sf, np.inf)
        # the prior rows carry no measurement information (parameter_covariance adds the
        # bounds' prior itself)
        tail = [np.full(self.theta0.size, np.inf)] if self.prior_weight > 0.0 else []
        if self.w_mac <= 0:
            return np.concatenate([sf, *tail])
        na = np.linalg.norm(t.shapes, axis=0)
        sp_ = np.sqrt(self.w_mac) * t.std_shapes / na
        # a round-off std (the normalising entry of a shape: 1e-17 in the bridge data) is
        # no information, not infinite information
        sp_ = np.where(np.isfinite(sp_) & (sp_ > 1e-9 * np.sqrt(self.w_mac)), sp_, np.inf)
        return np.concatenate([sf, sp_.T.ravel(), *tail])

    def jacobian(self, theta: FloatArray) -> FloatArray:
        """Analytic ``d residual / d theta`` (Fox-Kapoor eigenvalues, Nelson vectors)."""
        try:
            md = self.modes(theta)
            pr = self.pairing(theta)
        except (ModelError, ConvergenceError):
            return np.zeros((self.residual_size(), self.theta0.size))
        idx = self._full_index(md, pr)
        t = self.targets
        der = eigen_derivatives(md.K, md.M, md.lam[idx], md.Phi[:, idx], self.dK, self.dM,
                                method="nelson")
        Jf = der.df_hz / t.f_hz[:, None] / self.f_scale[:, None]
        tail = ([np.diag(math.sqrt(self.prior_weight) / self._prior_scale)]
                if self.prior_weight > 0.0 else [])
        if self.w_mac <= 0:
            return np.vstack([Jf, *tail])
        a = t.shapes
        b = md.Phi_s[:, idx]
        na = np.linalg.norm(a, axis=0)
        bb = np.sum(b * b, axis=0)
        ab = np.sum(a * b, axis=0)
        m = ab / bb
        db = _project(self.S, der.dPhi)  # d(S phi) / d theta
        dab = np.einsum("cj,cjp->jp", a, db)
        dbb = 2.0 * np.einsum("cj,cjp->jp", b, db)
        dm = dab / bb[:, None] - (ab / bb**2)[:, None] * dbb
        dr = -(b[:, :, None] * dm[None] + m[None, :, None] * db) / na[None, :, None]
        Jp = np.sqrt(self.w_mac) * dr.transpose(1, 0, 2).reshape(-1, self.theta0.size)
        return np.vstack([Jf, Jp, *tail])


def _project(S: sp.csr_array, dPhi: FloatArray) -> FloatArray:
    n, m, p = dPhi.shape
    return np.asarray(S @ dPhi.reshape(n, m * p)).reshape(S.shape[0], m, p)
