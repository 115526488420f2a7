"""Mode matching: each identified mode to one FEM mode within frequency and MAC windows.

For identified mode ``i`` and FEM mode ``l`` the pair cost is Eq. (3b) of [004]::

    J_li = |f_l / f_i - 1| + w_mac (1 - MAC(phi_l, phi_i)) + w_zeta |zeta_l / zeta_i - 1|

and ``l`` is a candidate of ``i`` only inside the windows of Eq. (4) of [004]
(``|f_l / f_i - 1| < r_f``, ``w_mac (1 - MAC) < r_mac``, ``w_zeta |zeta_l / zeta_i - 1| <
r_zeta``). Three searches:

* ``"greedy"``: the flowchart of Fig. 12 of [004] -- identified modes in ascending order,
  each takes its cheapest unused candidate (Eq. (5)); ``monotonic=True`` adds the shortcut
  of Sec. 5.1 (only FEM modes above those already matched).
* ``"exhaustive"``: every permutation (Fig. 11 of [004]); for small sets only.
* ``"assignment"`` (default): the same optimum as ``"exhaustive"`` -- most pairs matched,
  then least total cost -- by the Hungarian algorithm (``scipy.optimize.linear_sum_assignment``)
  in polynomial time. Unlike the greedy pass it is not fooled by the order of the modes,
  which matters when FEM modes swap ("dislocation", Table 6 of [000]).

Identified modes without a candidate stay unmatched (``fem_index = -1``); FEM modes never
matched are listed, and so are spurious identified modes (those the windows reject).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.optimize as so
from numpy.typing import ArrayLike

from modal_twin._types import FloatArray, IntArray
from modal_twin.errors import OptionError, ShapeError
from modal_twin.identification.metrics import mac

__all__ = ["ModePairing", "match_modes", "nearest_partners", "pair_costs"]

Method = Literal["assignment", "greedy", "exhaustive"]
_BIG = 1e6  # cost of a pair outside the windows (any matched pair costs far less)


@dataclass(frozen=True, slots=True)
class ModePairing:
    """Identified-to-FEM mode pairs.

    Attributes
    ----------
    fem_index : (n_id,) int array
        FEM mode matched to each identified mode (``-1``: no candidate, Eq. (4) of [004]).
    df_rel : (n_id,) float array
        ``f_fem / f_id - 1`` of each pair (NaN when unmatched).
    mac : (n_id,) float array
        MAC of each pair (NaN when unmatched).
    dzeta_rel : (n_id,) float array
        ``zeta_fem / zeta_id - 1`` (NaN when unmatched or no damping given).
    cost : (n_id,) float array
        Eq. (3b) of [004] per pair (``inf`` when unmatched, as in Sec. 5.1 of [004]).
    unmatched_id : tuple of int
        Identified modes without a candidate (spurious, or missing from the model).
    unused_fem : tuple of int
        FEM modes matched to no identified mode.
    method : str
        Search used.
    """

    fem_index: IntArray
    df_rel: FloatArray
    mac: FloatArray
    dzeta_rel: FloatArray
    cost: FloatArray
    unmatched_id: tuple[int, ...]
    unused_fem: tuple[int, ...]
    method: str

    @property
    def n_matched(self) -> int:
        """Number of matched identified modes."""
        return int(np.count_nonzero(self.fem_index >= 0))

    @property
    def total_cost(self) -> float:
        """Eq. (3a) of [004]: sum of the pair costs (``inf`` if any mode is unmatched)."""
        return float(np.sum(self.cost))


def _vec(x: ArrayLike | None, n: int, name: str) -> FloatArray | None:
    if x is None:
        return None
    arr = np.asarray(x, dtype=float).ravel()
    if arr.shape != (n,):
        msg = f"{name}: expected shape ({n},), got {arr.shape}"
        raise ShapeError(msg)
    return arr


def pair_costs(
    f_id: ArrayLike, phi_id: ArrayLike, f_fem: ArrayLike, phi_fem: ArrayLike, *,
    zeta_id: ArrayLike | None = None, zeta_fem: ArrayLike | None = None,
    w_mac: float = 1.0, w_zeta: float = 0.0, r_f: float = 0.10, r_mac: float = 0.15,
    r_zeta: float = math.inf,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Return the pair costs (Eq. (3b) of [004]) and the window mask (Eq. (4) of [004]).

    Returns
    -------
    cost, df_rel, mac, dzeta_rel : (n_id, n_fem) float arrays
        ``dzeta_rel`` is NaN without damping.
    inside : (n_id, n_fem) float array
        1.0 where the pair is a candidate, else 0.0.
    """
    fi = np.asarray(f_id, dtype=float).ravel()
    ff = np.asarray(f_fem, dtype=float).ravel()
    if np.any(~np.isfinite(fi)) or np.any(fi <= 0.0):
        msg = f"f_id: expected finite positive frequencies, got {fi.tolist()}"
        raise ShapeError(msg)
    pa = np.asarray(phi_id)
    pb = np.asarray(phi_fem)
    pa = pa.reshape(-1, 1) if pa.ndim == 1 else pa
    pb = pb.reshape(-1, 1) if pb.ndim == 1 else pb
    if pa.shape[1] != fi.size or pb.shape[1] != ff.size:
        msg = (f"phi_id / phi_fem: expected {fi.size} and {ff.size} columns, got "
               f"{pa.shape} and {pb.shape}")
        raise ShapeError(msg)
    M = mac(pa, pb)
    df = ff[None, :] / fi[:, None] - 1.0  # Eq. (3b) of [004], frequency term
    cost = np.abs(df) + w_mac * (1.0 - M)  # Eq. (3b) of [004], MAC term
    inside = (np.abs(df) < r_f) & (w_mac * (1.0 - M) < r_mac)  # Eq. (4) of [004]
    zi = _vec(zeta_id, fi.size, "zeta_id")
    zf = _vec(zeta_fem, ff.size, "zeta_fem")
    if zi is not None and zf is not None:
        dz = zf[None, :] / zi[:, None] - 1.0
        if w_zeta > 0.0:
            cost = cost + w_zeta * np.abs(dz)  # Eq. (3b) of [004], damping term
            inside &= w_zeta * np.abs(dz) < r_zeta
    else:
        dz = np.full_like(df, np.nan)
    return cost, df, M, dz, inside.astype(float)


def _greedy(C: FloatArray, inside: FloatArray, f_id: ArrayLike, f_fem: ArrayLike,
            monotonic: bool) -> IntArray:
    """Pair modes one by one, lowest identified frequency first (Sec. 5.1 of [004])."""
    n_id, n_fem = C.shape
    idx = np.full(n_id, -1, dtype=np.int64)
    used: set[int] = set()
    f_max = -math.inf
    ff = np.asarray(f_fem, dtype=float).ravel()
    for i in np.argsort(np.asarray(f_id, dtype=float).ravel()):
        cand = [l for l in range(n_fem) if inside[i, l] > 0 and l not in used
                and (not monotonic or ff[l] > f_max)]  # Eq. (4) of [004]
        if cand:
            best = min(cand, key=lambda l: C[i, l])  # Eq. (5) of [004]
            idx[i] = best
            used.add(best)
            f_max = max(f_max, ff[best])
    return idx


def _exhaustive(C: FloatArray, max_permutations: int) -> IntArray:
    """Pair modes by the cheapest of every ordered choice (Fig. 11 of [004])."""
    n_id, n_fem = C.shape
    idx = np.full(n_id, -1, dtype=np.int64)
    n_perm = math.perm(n_fem, min(n_id, n_fem))
    if n_perm > max_permutations:
        msg = (f"method 'exhaustive': expected at most {max_permutations} permutations, "
               f"got {n_perm} ({n_id} identified, {n_fem} FEM modes); use 'assignment'")
        raise OptionError(msg)
    best_cost = math.inf
    best_perm: tuple[int, ...] = ()
    if n_id <= n_fem:  # Fig. 11 of [004]: every ordered choice of FEM modes
        for perm in itertools.permutations(range(n_fem), n_id):
            c = float(C[np.arange(n_id), perm].sum())
            if c < best_cost:
                best_cost, best_perm = c, perm
        idx[:] = best_perm
    else:
        for perm in itertools.permutations(range(n_id), n_fem):
            c = float(C[perm, np.arange(n_fem)].sum())
            if c < best_cost:
                best_cost, best_perm = c, perm
        idx[list(best_perm)] = np.arange(n_fem)
    idx[(idx >= 0) & (C[np.arange(n_id), np.maximum(idx, 0)] >= _BIG)] = -1
    return idx


def match_modes(
    f_id: ArrayLike, phi_id: ArrayLike, f_fem: ArrayLike, phi_fem: ArrayLike, *,
    zeta_id: ArrayLike | None = None, zeta_fem: ArrayLike | None = None,
    w_mac: float = 1.0, w_zeta: float = 0.0, r_f: float = 0.10, r_mac: float = 0.15,
    r_zeta: float = math.inf, method: Method = "assignment", monotonic: bool = False,
    max_permutations: int = 40320,
) -> ModePairing:
    """Match identified modes to FEM modes (Sec. 5.1, Eqs. (4)-(5), Figs. 11-12 of [004]).

    Parameters
    ----------
    f_id : (n_id,) array_like
        Identified natural frequencies, Hz (> 0).
    phi_id : (n_ch, n_id) array_like
        Identified shapes at the measured DOFs (real or complex).
    f_fem : (n_fem,) array_like
        FEM frequencies, Hz.
    phi_fem : (n_ch, n_fem) array_like
        FEM shapes at the same DOFs.
    zeta_id, zeta_fem : array_like, optional
        Damping ratios (used when ``w_zeta > 0``).
    w_mac, w_zeta : float
        Weights ``lambda^MAC`` and ``lambda^zeta`` of Eq. (3b) of [004].
    r_f, r_mac, r_zeta : float
        Windows of Eq. (4) of [004] (relative; [004] uses 10 % and 15 %).
    method : {"assignment", "greedy", "exhaustive"}
        Search (module docstring).
    monotonic : bool
        Greedy shortcut of Sec. 5.1 of [004].
    max_permutations : int
        Refuse ``"exhaustive"`` beyond this many permutations.

    Returns
    -------
    ModePairing

    Raises
    ------
    ShapeError
        Inconsistent sizes, non-positive identified frequencies, no identified modes.
    OptionError
        Unknown method, non-positive windows, too many permutations.

    Examples
    --------
    >>> phi = np.eye(3)
    >>> p = match_modes([1.0, 2.0], phi[:, :2], [1.02, 1.9, 2.05], phi[:, [0, 2, 1]])
    >>> p.fem_index.tolist()
    [0, 2]
    """
    if method not in ("assignment", "greedy", "exhaustive"):
        msg = f"method: expected one of ['assignment', 'greedy', 'exhaustive'], got {method!r}"
        raise OptionError(msg)
    if not (r_f > 0.0 and r_mac > 0.0 and r_zeta > 0.0):
        msg = f"r_f, r_mac, r_zeta: expected > 0, got {r_f!r}, {r_mac!r}, {r_zeta!r}"
        raise OptionError(msg)
    n_id = np.asarray(f_id, dtype=float).size
    if n_id == 0:
        msg = "f_id: expected at least one identified mode, got none"
        raise ShapeError(msg)
    cost, df, M, dz, inside = pair_costs(
        f_id, phi_id, f_fem, phi_fem, zeta_id=zeta_id, zeta_fem=zeta_fem, w_mac=w_mac,
        w_zeta=w_zeta, r_f=r_f, r_mac=r_mac, r_zeta=r_zeta)
    n_fem = cost.shape[1]
    C = np.where(inside > 0, cost, _BIG)
    idx = np.full(n_id, -1, dtype=np.int64)
    if method == "greedy":
        idx = _greedy(C, inside, f_id, f_fem, monotonic)
    elif method == "exhaustive":
        idx = _exhaustive(C, max_permutations)
    else:
        r, c = so.linear_sum_assignment(C)
        ok = C[r, c] < _BIG
        idx[r[ok]] = c[ok]
    sel = idx >= 0
    rows_i = np.flatnonzero(sel)
    pick = idx[sel]

    def take(A: FloatArray) -> FloatArray:
        out = np.full(n_id, np.nan)
        out[rows_i] = A[rows_i, pick]
        return out

    pc = np.full(n_id, math.inf)
    pc[rows_i] = cost[rows_i, pick]
    return ModePairing(
        fem_index=idx, df_rel=take(df), mac=take(M), dzeta_rel=take(dz), cost=pc,
        unmatched_id=tuple(int(i) for i in np.flatnonzero(~sel)),
        unused_fem=tuple(sorted(set(range(n_fem)) - {int(l) for l in pick})),
        method=method)


def nearest_partners(pairing: ModePairing, f_id: ArrayLike, phi_id: ArrayLike,
                     f_fem: ArrayLike, phi_fem: ArrayLike
                     ) -> tuple[IntArray, FloatArray, FloatArray, np.ndarray]:
    """Return model mode, df and MAC of every identified mode, and which are unmatched.

    A matched mode keeps its pair; an unmatched one (flagged) gets its nearest partner: the
    cheapest model mode no pair uses, by the pair cost ``|df| + (1 - MAC)`` of Eq. (3b) of
    [004] (one partner each), so a table shows how far off the model is at every mode.
    """
    idx = np.array(pairing.fem_index)
    df = np.array(pairing.df_rel, dtype=np.float64)
    mc = np.array(pairing.mac, dtype=np.float64)
    near = idx < 0
    miss = np.flatnonzero(near)
    ff = np.asarray(f_fem, dtype=float)
    free = np.setdiff1d(np.arange(ff.size), idx[idx >= 0])
    if miss.size and free.size:
        cost, d, m, *_ = pair_costs(np.asarray(f_id, dtype=float)[miss],
                                    np.asarray(phi_id)[:, miss], ff[free],
                                    np.asarray(phi_fem)[:, free])
        r, c = so.linear_sum_assignment(cost)
        idx[miss[r]], df[miss[r]], mc[miss[r]] = free[c], d[r, c], m[r, c]
    return idx, df, mc, near
