"""Zone updating of the 3D shell carbody from a modal test, as [002] Sec. 3-4.

The parameters are factors ``x_j`` on the zone moduli and densities of
:mod:`modal_twin.models.carbody3d` (``E_<zone>``, ``rho_<zone>``: the twelve parameters of
[002] Table 1 with the window belt and door zones in place of the Poisson ratios, which are
not linear parameters here). Both enter the shell matrices exactly linearly (Sec. 4 of
[004]), so ``K(x) = K0 + sum_j (x_j - 1) E_j0 dK_j`` and likewise ``M``: the zone matrices
are assembled once.

Each candidate is solved on a **Ritz basis** ``V`` (the lowest modes at the nominal point
and at a few Latin-hypercube points of the bounds, :class:`ZoneModel`): an ``r x r`` dense
eigen-solution instead of a sparse one of a few thousand DOFs, so 500 screening samples and
a differential-evolution search take seconds; the reported figures come from the full
sparse model (:meth:`ZoneModel.modes`).

Steps, all on the test modes (identified frequencies and complex shapes at the sensors):

* mode pairing by MAC, not by order (:func:`~modal_twin.updating.matching.match_modes`,
  Hungarian assignment on ``|df| + (1 - MAC)``): survives mode swaps;
* screening: Latin hypercube and Spearman correlation (Eq. (10) of [002],
  :func:`~modal_twin.updating.screening.lhs_spearman`) of the paired frequencies and MACs
  with the factors, samples with a MAC below 0.5 dropped, parameters with ``|r| >= 0.5``
  kept ([002] Sec. 4.1);
* global search: differential evolution on Eq. (11) of [002]
  (:func:`~modal_twin.updating.objectives.weighted_frequency_mac_cost`, ``alpha = 1``,
  ``beta = 0.25``) over the kept factors, evaluated through an executor
  (:mod:`modal_twin.executors`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.optimize as so
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.stats import qmc, spearmanr

from modal_twin._types import ComplexArray, FloatArray, IntArray
from modal_twin.errors import OptionError, ShapeError
from modal_twin.executors import ExecutorSpec, make_executor, mapper
from modal_twin.identification.modal_model import ModalModel
from modal_twin.identification.polymax import polymax
from modal_twin.identification.stabilization import select_modes, stabilization_diagram
from modal_twin.models.carbody3d import CarbodyFE
from modal_twin.models.fe import NodeId
from modal_twin.models.fe.parametric import ParametricMatrices
from modal_twin.updating.matching import ModePairing, match_modes
from modal_twin.updating.objectives import weighted_frequency_mac_cost
from modal_twin.updating.screening import lhs_spearman

__all__ = [
    "N_RIGID",
    "CarbodyScreening",
    "CarbodyUpdate",
    "ZoneModel",
    "driving_points",
    "identify_test_modes",
    "pair_test_modes",
    "reciprocity",
    "screen_zones",
    "sensor_layout",
    "update_zones",
]

N_RIGID = 6
"""Rigid-body modes of the free-free carbody (six: it has no support)."""

_SIGMA = -(2.0 * math.pi * 1.0) ** 2  # shift below the rigid modes, rad^2/s^2
_PENALTY = 1e3  # Eq. (11) value of a candidate that leaves a test mode unpaired


def _ring_node(car: CarbodyFE, x: float, y: float, z: float) -> NodeId:
    i = int(np.argmin(np.abs(car.stations - x)))
    k = int(np.argmin(np.hypot(car.ring_yz[:, 0] - y, car.ring_yz[:, 1] - z)))
    node: NodeId = car.ring[i, k]
    return node


def sensor_layout(car: CarbodyFE, stations: Sequence[float] | None = None
                  ) -> list[tuple[NodeId, str]]:
    """Accelerometers like [002] Fig. 6b: floor, side walls and roof corners of sections.

    At each station: floor ``uz`` at the left seat line, the centre line and the right seat
    line; side walls ``uy`` at the window-belt bottom (both sides); roof corners ``uz`` and
    ``uy`` (both sides): nine channels per section.

    Parameters
    ----------
    car : CarbodyFE
    stations : sequence of float, optional
        ``x`` of the sections, m; default nine from end to end through the pivots.

    Returns
    -------
    list of (node, dof name)
    """
    p = car.params
    half, xp = p.length / 2, p.pivot_spacing / 2
    xs = ([-half, -xp, -0.45 * half, -0.2 * half, 0.0, 0.2 * half, 0.45 * half, xp, half]
          if stations is None else list(stations))
    W, H, b = p.width / 2, p.height, p.seat_half_spacing
    out: list[tuple[NodeId, str]] = []
    for x in xs:
        out += [(_ring_node(car, x, y, 0.0), "uz") for y in (b, 0.0, -b)]
        out += [(_ring_node(car, x, y, p.belt[0]), "uy") for y in (W, -W)]
        for y in (W, -W):
            out += [(_ring_node(car, x, y, H), "uz"), (_ring_node(car, x, y, H), "uy")]
    return out


def driving_points(car: CarbodyFE) -> list[tuple[NodeId, str]]:
    """Two floor shakers off the nodal lines ([002] Sec. 3.1) and one lateral, on a wall.

    Floor ``uz`` at ``(0.3 L, +b)`` and ``(-0.15 L, -b)`` (``b`` the seat half spacing;
    the reciprocity pair), side wall ``uy`` at ``(0.1 L, +W/2)`` on the window-belt bottom.
    """
    p = car.params
    b = p.seat_half_spacing
    return [(_ring_node(car, 0.3 * p.length, b, 0.0), "uz"),
            (_ring_node(car, -0.15 * p.length, -b, 0.0), "uz"),
            (_ring_node(car, 0.1 * p.length, p.width / 2, p.belt[0]), "uy")]


def _dofs(car: CarbodyFE, points: Sequence[tuple[NodeId, str]]) -> IntArray:
    return np.array([car.asm.dof_index(n, d) for n, d in points], dtype=np.int64)


@dataclass(frozen=True, slots=True)
class ZoneModel:
    """The carbody with zone factors as parameters, full and on a Ritz basis.

    Attributes
    ----------
    car : CarbodyFE
    names : tuple of str
        Parameter names (``E_<zone>``, ``rho_<zone>``).
    sensors : (n_ch,) int array
        Free DOF index of each sensor channel.
    V : (n, r) float array
        Ritz basis (module docstring).
    K0r, M0r : (r, r) float arrays
        Nominal reduced matrices.
    dk_r, dm_r : (n_theta, r, r) float arrays
        Reduced ``theta0_j dK_j`` and ``theta0_j dM_j`` (zero for the other kind).
    Vs : (n_ch, r) float array
        Sensor rows of ``V``.
    """

    car: CarbodyFE
    names: tuple[str, ...]
    sensors: IntArray
    V: FloatArray
    K0r: FloatArray
    M0r: FloatArray
    dk_r: FloatArray
    dm_r: FloatArray
    Vs: FloatArray

    @classmethod
    def build(cls, car: CarbodyFE, sensors: Sequence[tuple[NodeId, str]], *,
              names: Sequence[str] | None = None, lower: float = 0.6, upper: float = 1.5,
              n_points: int = 8, n_modes: int = 20, seed: int = 0) -> ZoneModel:
        """Assemble the zone matrices once and build the Ritz basis.

        Parameters
        ----------
        car : CarbodyFE
        sensors : list of (node, dof name)
        names : sequence of str, optional
            Default every ``E_`` / ``rho_`` parameter of the carbody.
        lower, upper : float
            Factor bounds the basis must cover.
        n_points : int
            Latin-hypercube points whose modes join the nominal ones in the basis.
        n_modes : int
            Modes per point (rigid ones included).
        seed : int
        """
        par = car.asm.parametric
        nm = tuple(n for n in par.names if n.startswith(("E_", "rho_"))) if names is None \
            else tuple(names)
        _check_bounds(lower, upper)
        idx = [par.index(n) for n in nm]
        scaled = [par.theta0[i] * par.derivatives[i] for i in idx]
        kinds = [par.kinds[i] for i in idx]
        dK = [s if k == "K" else None for s, k in zip(scaled, kinds, strict=True)]
        dM = [s if k == "M" else None for s, k in zip(scaled, kinds, strict=True)]
        pts = [np.ones(len(nm))]
        if n_points > 0:
            pts += list(qmc.scale(qmc.LatinHypercube(d=len(nm), seed=seed).random(n_points),
                                  lower, upper))
        cols = []
        rng = np.random.default_rng(seed)  # ARPACK start vectors: the same basis every run
        for x in pts:
            th = _theta(par, nm, x)
            K, M = par.K(th), par.M(th)
            _, Phi = spla.eigsh(sp.csc_array(K), k=n_modes, M=sp.csc_array(M), sigma=_SIGMA,
                                which="LM", v0=rng.standard_normal(K.shape[0]))
            cols.append(Phi)
        U, s, _ = np.linalg.svd(np.hstack(cols), full_matrices=False)
        V = U[:, s > 1e-10 * s[0]]

        def red(A: sp.csr_array | None) -> FloatArray:
            if A is None:
                return np.zeros((V.shape[1], V.shape[1]))
            out = V.T @ np.asarray(A @ V)
            return np.asarray(0.5 * (out + out.T))

        sens = _dofs(car, sensors)
        return cls(car=car, names=nm, sensors=sens, V=V, K0r=red(par.K0), M0r=red(par.M0),
                   dk_r=np.array([red(a) for a in dK]), dm_r=np.array([red(a) for a in dM]),
                   Vs=V[sens])

    def _check(self, x: FloatArray) -> FloatArray:
        arr = np.asarray(x, dtype=float)
        if arr.shape != (len(self.names),) or not np.all(np.isfinite(arr) & (arr > 0)):
            msg = f"factors: expected ({len(self.names)},) finite values > 0, got {arr!r}"
            raise ShapeError(msg)
        return arr

    def reduced_modes(self, x: FloatArray, n_modes: int = 14) -> tuple[FloatArray, FloatArray]:
        """Flexible frequencies (Hz) and shapes at the sensors on the Ritz basis.

        The ``N_RIGID`` lowest eigenpairs (the rigid modes) are dropped.
        """
        d = self._check(x) - 1.0
        K = self.K0r + np.tensordot(d, self.dk_r, axes=1)
        M = self.M0r + np.tensordot(d, self.dm_r, axes=1)
        lam, Q = sla.eigh(K, M, subset_by_index=[N_RIGID, N_RIGID + n_modes - 1])
        return np.sqrt(np.abs(lam)) / (2.0 * math.pi), self.Vs @ Q

    def modes(self, x: FloatArray, n_modes: int = 14) -> tuple[FloatArray, FloatArray]:
        """Flexible frequencies (Hz) and shapes at the sensors, full sparse model."""
        par = self.car.asm.parametric
        full = _theta(par, self.names, self._check(x))
        K, M = par.K(full), par.M(full)
        lam, Phi = spla.eigsh(sp.csc_array(K), k=N_RIGID + n_modes, M=sp.csc_array(M),
                              sigma=_SIGMA, which="LM",
                              v0=np.random.default_rng(0).standard_normal(K.shape[0]))
        o = np.argsort(lam)[N_RIGID:]
        return np.sqrt(np.abs(lam[o])) / (2.0 * math.pi), Phi[:, o][self.sensors]


def _theta(par: ParametricMatrices, names: Sequence[str], x: FloatArray) -> FloatArray:
    """Full parameter vector with ``names`` at ``x`` times their nominal values."""
    out = par.theta0.copy()
    for n, v in zip(names, x, strict=True):
        out[par.index(n)] *= v
    return out


def _check_bounds(lower: float, upper: float) -> None:
    if not (math.isfinite(lower) and math.isfinite(upper) and 0.0 < lower < 1.0 < upper):
        msg = f"lower, upper: expected 0 < lower < 1 < upper, got {lower!r}, {upper!r}"
        raise OptionError(msg)


def pair_test_modes(f_test: FloatArray, phi_test: ComplexArray, f_fem: FloatArray,
                    phi_fem: FloatArray) -> ModePairing:
    """Pair each test mode with a model mode by MAC and frequency, not by order.

    Hungarian assignment (:func:`~modal_twin.updating.matching.match_modes`) on
    ``|f_fem / f_test - 1| + (1 - MAC)`` inside wide windows (35 % in frequency,
    ``1 - MAC < 0.9``): a mode swap between candidates keeps each test mode with its shape.
    """
    return match_modes(f_test, phi_test, f_fem, phi_fem, r_f=0.35, r_mac=0.9)


@dataclass(frozen=True, slots=True)
class _Features:
    """Picklable ``x -> [paired f (n), paired MAC (n)]`` on the Ritz model."""

    model: ZoneModel
    f_test: FloatArray
    phi_test: ComplexArray
    index: IntArray  # positions of the varied factors in the model's names
    base: FloatArray

    def full(self, xs: FloatArray) -> FloatArray:
        x = self.base.copy()
        x[self.index] = xs
        return x

    def __call__(self, xs: FloatArray) -> FloatArray:
        fp, mac_p, _ = _paired(self.f_test, self.phi_test,
                               *self.model.reduced_modes(self.full(xs)))
        return np.concatenate([fp, mac_p])


@dataclass(frozen=True, slots=True)
class _Cost:
    """Picklable Eq. (11) of [002] on the Ritz model."""

    features: _Features
    gamma: FloatArray

    def __call__(self, xs: FloatArray) -> float:
        m = self.features
        f, phi = m.model.reduced_modes(m.full(np.asarray(xs, dtype=float)))
        p = pair_test_modes(m.f_test, m.phi_test, f, phi)
        c = weighted_frequency_mac_cost(p, alpha=1.0, beta=0.25, gamma=self.gamma)
        return c if math.isfinite(c) else _PENALTY  # Eq. (11) of [002]


@dataclass(frozen=True, slots=True)
class CarbodyScreening:
    """Spearman screening of the zone factors ([002] Sec. 4.1, Eq. (10)).

    Attributes
    ----------
    names : tuple of str
    samples : (n_samples, n_theta) float array
        Latin-hypercube factors.
    features : (n_samples, 2 n_modes) float array
        Paired frequencies (Hz) then MACs of the test modes.
    kept : (n_samples,) bool array
        Samples with every MAC >= ``mac_min`` and every mode paired.
    r : (2 n_modes, n_theta) float array
        Spearman correlation over the kept samples (rows f_1..f_n, MAC_1..MAC_n).
    selected : tuple of str
        Parameters with ``|r| >= r_min`` for at least one row.
    """

    names: tuple[str, ...]
    samples: FloatArray
    features: FloatArray
    kept: np.ndarray
    r: FloatArray
    selected: tuple[str, ...]


def screen_zones(model: ZoneModel, f_test: FloatArray, phi_test: ComplexArray, *,
                 lower: float = 0.6, upper: float = 1.5, n_samples: int = 500,
                 mac_min: float = 0.5, r_min: float = 0.5, seed: int = 0,
                 executor: ExecutorSpec = 1) -> CarbodyScreening:
    """Latin hypercube + Spearman screening of the zone factors ([002] Sec. 4.1).

    Each sample's model modes are paired with the test modes by MAC; samples with a MAC
    below ``mac_min`` (or an unpaired mode) are dropped; Eq. (10) of [002] is evaluated on
    the rest; parameters with ``|r| >= r_min`` for some frequency or MAC are selected.
    """
    _check_bounds(lower, upper)
    if n_samples < 10:
        msg = f"n_samples: expected >= 10, got {n_samples}"
        raise OptionError(msg)
    n = len(model.names)
    feat = _Features(model, np.asarray(f_test, float), np.asarray(phi_test),
                     np.arange(n), np.ones(n))
    with make_executor(executor) as ex:
        res = lhs_spearman(feat, model.names, np.full(n, lower), np.full(n, upper),
                           n_samples=n_samples, seed=seed, executor_map=mapper(ex))
    F = res.f_hz
    m = f_test.size
    kept = np.all(np.isfinite(F), axis=1) & np.all(F[:, m:] >= mac_min, axis=1)
    r = np.full((F.shape[1], n), np.nan)
    if np.count_nonzero(kept) >= 4:
        for i in range(F.shape[1]):
            for j in range(n):
                r[i, j] = spearmanr(res.samples[kept, j], F[kept, i]).statistic  # Eq. (10)
    big = np.nanmax(np.abs(np.nan_to_num(r, nan=0.0)), axis=0) >= r_min
    sel = tuple(nm for nm, k in zip(model.names, big, strict=True) if k)
    return CarbodyScreening(model.names, res.samples, F, kept, r, sel)


@dataclass(frozen=True, slots=True)
class CarbodyUpdate:
    """Result of :func:`update_zones`.

    Attributes
    ----------
    names : tuple of str
        Updated parameters.
    factors : (n_theta,) float array
        Factors of every model parameter after updating (1 for those not updated).
    cost : float
        Eq. (11) of [002] at the optimum (Ritz model).
    nfev : int
    f_before, f_after : (n_modes,) float arrays
        Paired model frequencies, Hz, nominal and updated (full model).
    mac_before, mac_after : (n_modes,) float arrays
    pairing_after : ModePairing
    """

    names: tuple[str, ...]
    factors: FloatArray
    cost: float
    nfev: int
    f_before: FloatArray
    f_after: FloatArray
    mac_before: FloatArray
    mac_after: FloatArray
    pairing_after: ModePairing


def _paired(f_test: FloatArray, phi_test: ComplexArray, f: FloatArray, phi: FloatArray
            ) -> tuple[FloatArray, FloatArray, ModePairing]:
    """Paired model frequencies (NaN where unpaired), MACs and the pairing."""
    p = pair_test_modes(f_test, phi_test, f, phi)
    fp = np.full(f_test.size, np.nan)
    ok = p.fem_index >= 0
    fp[ok] = f[p.fem_index[ok]]
    return fp, p.mac, p


def update_zones(model: ZoneModel, f_test: FloatArray, phi_test: ComplexArray,
                 names: Sequence[str], *, lower: float = 0.6, upper: float = 1.5,
                 gamma: FloatArray | float = 1.0, maxiter: int = 40, popsize: int = 10,
                 seed: int = 0, executor: ExecutorSpec = 1) -> CarbodyUpdate:
    """Differential evolution on Eq. (11) of [002] over the factors ``names`` ([002] Sec. 4.2).

    Parameters
    ----------
    model : ZoneModel
    f_test : (n_modes,) float array
        Test frequencies, Hz.
    phi_test : (n_ch, n_modes) complex array
        Test shapes at the model's sensors.
    names : sequence of str
        Factors to update (e.g. :attr:`CarbodyScreening.selected`); the others stay 1.
    lower, upper : float
        Factor bounds.
    gamma : float or (n_modes,) array
        Mode weights of Eq. (11).
    maxiter, popsize, seed : int
        ``scipy.optimize.differential_evolution`` controls (``polish=False``).
    executor : ExecutorSpec
        Where the population is evaluated (:func:`modal_twin.executors.make_executor`).
    """
    _check_bounds(lower, upper)
    if not names:
        msg = "names: expected at least one parameter to update, got none"
        raise OptionError(msg)
    unknown = [n for n in names if n not in model.names]
    if unknown:
        msg = f"names: expected parameters of the model {list(model.names)}, got {unknown}"
        raise OptionError(msg)
    idx = np.array([model.names.index(n) for n in names], dtype=np.int64)
    f_t = np.asarray(f_test, dtype=float)
    feat = _Features(model, f_t, np.asarray(phi_test), idx, np.ones(len(model.names)))
    g = np.broadcast_to(np.asarray(gamma, dtype=float), f_t.shape).copy()
    cost = _Cost(feat, g)
    with make_executor(executor) as ex:
        res = so.differential_evolution(
            cost, [(lower, upper)] * idx.size, maxiter=maxiter, popsize=popsize, seed=seed,
            workers=mapper(ex), updating="deferred", polish=False, tol=1e-8,
            init="latinhypercube", x0=np.ones(idx.size))
    x = feat.full(np.asarray(res.x))
    f0, m0, _ = _paired(f_t, phi_test, *model.modes(np.ones(len(model.names))))
    f1, m1, p1 = _paired(f_t, phi_test, *model.modes(x))
    return CarbodyUpdate(tuple(names), x, float(res.fun), int(res.nfev), f0, f1, m0, m1, p1)


def identify_test_modes(H: ComplexArray, f_hz: FloatArray,
                        bands_hz: Sequence[tuple[float, float]], *,
                        max_order: int = 32, min_support: int = 4) -> ModalModel:
    """PolyMAX poles, stabilization, then LSFD shapes (Eqs. (1)-(5) of [002]), band by band.

    Each band is analysed on its own (poles, then LSFD with lower and upper residuals, as
    [002] Sec. 3.2 sets the estimation band's ends); the modes of all bands are returned
    in ascending frequency.

    Parameters
    ----------
    H : (n_out, n_in, n_f) complex array
        Measured FRFs.
    f_hz : (n_f,) float array
    bands_hz : sequence of (float, float)
        Analysis bands.
    max_order : int
        Highest polynomial order (``max_order * n_in`` poles; lower in a band with fewer
        than ``2 max_order + 2`` lines).
    min_support : int
        Stable poles a mode needs in the diagram (stability: 1 % in frequency, 10 % in
        damping, MAC 0.9 between consecutive orders; a weakly excited lateral mode is
        stable over fewer orders than the default rule asks).
    """
    parts: list[ModalModel] = []
    for band in bands_hz:
        n_lines = int(np.count_nonzero((f_hz >= band[0]) & (f_hz <= band[1]) & (f_hz > 0)))
        top = min(max_order, (n_lines - 2) // 2)  # PolyMAX needs 2 p + 2 lines
        if top < 6:
            msg = f"bands_hz: band {band} has {n_lines} lines, expected at least 14"
            raise OptionError(msg)
        sweep = polymax(H, f_hz, orders=list(range(4, top + 1)), band_hz=band)
        diagram = stabilization_diagram(sweep, rel_tol_zeta=0.1, mac_min=0.9)
        parts.append(select_modes(diagram, f_range_hz=band, min_support=min_support))
    o = np.argsort(np.concatenate([p.f_hz for p in parts]))

    def cat(name: str) -> np.ndarray:
        return np.concatenate([getattr(p, name) for p in parts], axis=-1)[..., o]

    return ModalModel(f_hz=cat("f_hz"), zeta=cat("zeta"), shapes=cat("shapes"),
                      std_f_hz=cat("std_f_hz"), std_zeta=cat("std_zeta"), method="polymax",
                      order=max(p.order for p in parts), mode_orders=cat("mode_orders"),
                      n_support=cat("n_support"))


def reciprocity(H_ij: ComplexArray, H_ji: ComplexArray) -> tuple[float, float]:
    """Reciprocity of two driving points ([002] Sec. 3.2, Fig. 7c).

    Returns
    -------
    rel_diff : float
        ``||H_ij - H_ji|| / ||H_ij||`` over the lines given.
    frac : float
        Frequency response assurance criterion ``|H_ij^H H_ji|^2 / (|H_ij|^2 |H_ji|^2)``
        (1 for identical shapes of the two FRFs).
    """
    a = np.asarray(H_ij, dtype=complex).ravel()
    b = np.asarray(H_ji, dtype=complex).ravel()
    if a.shape != b.shape or a.size == 0:
        msg = f"H_ij, H_ji: expected the same non-empty shape, got {a.shape} and {b.shape}"
        raise ShapeError(msg)
    na, nb = float(np.vdot(a, a).real), float(np.vdot(b, b).real)
    if na == 0.0 or nb == 0.0:
        msg = "H_ij, H_ji: expected non-zero FRFs"
        raise ShapeError(msg)
    frac = abs(np.vdot(a, b)) ** 2 / (na * nb)
    return float(np.linalg.norm(a - b) / math.sqrt(na)), float(frac)
