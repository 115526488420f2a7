r"""Stabilization diagram and automatic selection of physical modes.

Stability rule of sec. 3 of [004] (after Peeters, 2000): a pole of order n is stable when
a pole of the next order lies within 1 % in frequency and 5 % in damping ratio and their
mode shapes have MAC > 0.95. All three thresholds are options; deviations are relative.

Selection: stable poles with damping in (0, ``zeta_max``) are clustered by the distance
:math:`d = \max(|\Delta f| / \bar f / \mathrm{tol}_f, (1 - \mathrm{MAC}) / (1 -
\mathrm{MAC}_{min}))` (average linkage, cut at 1), so that close modes with distinct
shapes stay apart. Clusters supported by fewer than ``min_support`` poles (isolated poles)
are rejected, and (``rel_support``, 25 % in ``identify``) so are clusters with fewer than
that fraction of the largest cluster's poles (spurious poles scatter into small clusters;
Magalhaes et al. 2009, Reynders et al. 2012); each remaining cluster is one mode,
represented by the pole nearest the cluster's median frequency and damping.
:func:`dropped_columns` lists the clusters not reported, with the reason.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.cluster.hierarchy as sch

from modal_twin._types import BoolArray, ComplexArray, FloatArray
from modal_twin.errors import OptionError
from modal_twin.identification.metrics import _shapes
from modal_twin.identification.modal_model import (
    ModalModel,
    PoleSet,
    PoleSweep,
    StabilizationDiagram,
)

__all__ = ["REL_SUPPORT", "DroppedColumn", "dropped_columns", "select_modes",
           "stabilization_diagram"]

REL_SUPPORT = 0.25
"""Smallest cluster, as a fraction of the largest, that :func:`select_modes` reports."""


def _unit_shapes(shapes: ComplexArray, name: str) -> ComplexArray:
    """Shapes of unit norm, so that MAC = :math:`|u_a^H u_b|^2` (Eq. (6) of [002]).

    Same validation and the same scaling by the largest entry first as
    :func:`~modal_twin.identification.metrics.mac`; all-zero shapes stay zero (MAC 0).
    Each order's shapes are normalised once and compared with both neighbours.
    """
    a = _shapes(shapes, name)
    a = a / np.where((ma := np.abs(a).max(axis=0)) > 0, ma, 1.0)
    nrm = np.sqrt(np.einsum("ij,ij->j", a.real, a.real) + np.einsum("ij,ij->j", a.imag, a.imag))
    out: ComplexArray = a / np.where(nrm > 0, nrm, 1.0)
    return out


def _compare(
    a: PoleSet,
    b: PoleSet,
    tol_f: float,
    tol_z: float,
    mac_min: float,
    unit: Callable[[PoleSet, str], ComplexArray],
) -> tuple[BoolArray, BoolArray, BoolArray]:
    n = a.f_hz.size
    if n == 0 or b.f_hz.size == 0:
        z = np.zeros(n, dtype=bool)
        return z, z.copy(), z.copy()
    df = np.abs(b.f_hz[None, :] - a.f_hz[:, None]) / np.maximum(a.f_hz[:, None], 1e-300)
    M = np.minimum(np.abs(unit(a, "phi_a").conj().T @ unit(b, "phi_b")) ** 2, 1.0)  # MAC
    # candidate of the next order: within the frequency tolerance, best MAC; else nearest
    score = np.where(df <= tol_f, M, -1.0 - df)
    j = np.argmax(score, axis=1)
    r = np.arange(n)
    ok_f = df[r, j] <= tol_f
    za, zb = a.zeta, b.zeta[j]
    ok_z = np.abs(zb - za) <= tol_z * np.abs(za)
    ok_m = M[r, j] >= mac_min
    return ok_f, ok_z & ok_f, ok_m & ok_f


def stabilization_diagram(
    sweep: PoleSweep,
    *,
    rel_tol_f: float = 0.01,
    rel_tol_zeta: float = 0.05,
    mac_min: float = 0.95,
) -> StabilizationDiagram:
    """Flag each pole as stable against the next model order (sec. 3 of [004]).

    Parameters
    ----------
    sweep : PoleSweep
        Poles over orders from :func:`~modal_twin.identification.n4sid.n4sid`,
        :func:`~modal_twin.identification.ssi_cov.ssi_cov` or
        :func:`~modal_twin.identification.polymax.polymax`.
    rel_tol_f : float
        Relative frequency deviation allowed (0.01 = 1 % in [004]).
    rel_tol_zeta : float
        Relative damping deviation allowed (0.05 = 5 % in [004]).
    mac_min : float
        Minimum MAC with the matching pole (0.95 in [004]).

    Returns
    -------
    StabilizationDiagram

    Raises
    ------
    OptionError
        Tolerances not positive, ``mac_min`` outside [0, 1], or fewer than two orders.
    """
    if not (rel_tol_f > 0 and rel_tol_zeta > 0 and 0.0 <= mac_min <= 1.0):
        msg = (
            "rel_tol_f, rel_tol_zeta, mac_min: expected > 0, > 0 and in [0, 1], got "
            f"{rel_tol_f!r}, {rel_tol_zeta!r}, {mac_min!r}"
        )
        raise OptionError(msg)
    P = sweep.poles
    if len(P) < 2:
        msg = f"sweep: expected at least 2 model orders for stability, got {len(P)}"
        raise OptionError(msg)
    sf, sz, sm = [], [], []
    cache: dict[int, ComplexArray] = {}

    def unit(p: PoleSet, name: str) -> ComplexArray:
        if id(p) not in cache:
            cache[id(p)] = _unit_shapes(p.shapes, name)
        return cache[id(p)]

    for k, a in enumerate(P):
        b = P[k + 1] if k + 1 < len(P) else P[k - 1]
        f_ok, z_ok, m_ok = _compare(a, b, rel_tol_f, rel_tol_zeta, mac_min, unit)
        sf.append(f_ok)
        sz.append(z_ok)
        sm.append(m_ok)
    st = tuple(a & b & c for a, b, c in zip(sf, sz, sm, strict=True))
    return StabilizationDiagram(
        sweep.method,
        sweep.orders,
        P,
        tuple(sf),
        tuple(sz),
        tuple(sm),
        st,
        float(rel_tol_f),
        float(rel_tol_zeta),
        float(mac_min),
    )


def select_modes(
    diagram: StabilizationDiagram,
    *,
    zeta_max: float = 0.2,
    min_support: int | None = None,
    f_range_hz: tuple[float, float] | None = None,
    rel_support: float = 0.0,
) -> ModalModel:
    """Pick physical modes from the stable poles of a diagram.

    Parameters
    ----------
    diagram : StabilizationDiagram
    zeta_max : float
        Poles with damping outside (0, zeta_max) are rejected (0.2 = 20 %).
    min_support : int, optional
        Minimum number of stable poles in a cluster; default
        ``max(3, ceil(0.2 * n_orders))``.
    rel_support : float
        A cluster also needs this fraction of the largest cluster's poles (0: off;
        :func:`~modal_twin.identification.record.identify_record` uses
        :data:`REL_SUPPORT`, 0.25): physical
        modes form the large clusters, spurious poles the small ones (the size-based
        split of Reynders et al. 2012 after the clustering of Magalhaes et al. 2009).
    f_range_hz : (float, float), optional
        Keep modes in this band only.

    Returns
    -------
    ModalModel
        Empty (zero modes) when no cluster qualifies.

    Raises
    ------
    OptionError
        ``zeta_max`` outside (0, 1] or ``min_support`` < 1.
    """
    if not 0.0 < zeta_max <= 1.0:
        msg = f"zeta_max: expected a value in (0, 1], got {zeta_max!r}"
        raise OptionError(msg)
    ms = _min_support(diagram, min_support)
    if ms < 1:
        msg = f"min_support: expected an integer >= 1, got {min_support!r}"
        raise OptionError(msg)
    rows: list[tuple[int, int]] = []  # (model order, pole index)
    fl, zl, Sl = [], [], []  # the kept poles, gathered order by order
    for k, (p, s) in enumerate(zip(diagram.poles, diagram.stable, strict=True)):
        keep = s & (p.zeta > 0) & (p.zeta < zeta_max)
        if f_range_hz is not None:
            keep &= (p.f_hz >= f_range_hz[0]) & (p.f_hz <= f_range_hz[1])
        q = np.nonzero(keep)[0]
        rows.extend((k, int(qq)) for qq in q)
        fl.append(p.f_hz[q])
        zl.append(p.zeta[q])
        Sl.append(p.shapes[:, q])
    n_ch = diagram.poles[0].shapes.shape[0]
    if len(rows) < ms:
        e = np.zeros(0)
        return ModalModel(
            e, e, np.zeros((n_ch, 0), complex), e, e, diagram.method, 0,
            np.zeros(0, np.int64), np.zeros(0, np.int64),
        )  # fmt: skip
    f = np.concatenate(fl).astype(float)
    z = np.concatenate(zl).astype(float)
    lab = _clusters(f, np.concatenate(Sl, axis=1), diagram)
    modes = []
    sizes = np.bincount(lab)
    ms = max(ms, int(np.ceil(rel_support * sizes.max())))
    for c in np.unique(lab):
        idx = np.nonzero(lab == c)[0]
        if idx.size < ms:
            continue
        fm, zm = np.median(f[idx]), np.median(z[idx])
        best = idx[np.argmin(np.abs(f[idx] - fm) / fm + np.abs(z[idx] - zm) / zm)]
        modes.append((best, idx.size))
    modes.sort(key=lambda t: f[t[0]])
    sel = [rows[b] for b, _ in modes]
    P = diagram.poles

    def pick(attr: str) -> FloatArray:
        return np.array([getattr(P[k], attr)[q] for k, q in sel], dtype=float)

    shapes = np.stack([P[k].shapes[:, q] for k, q in sel], axis=1) if sel else np.zeros((n_ch, 0))
    mode_orders = np.array([int(diagram.orders[k]) for k, _ in sel], dtype=np.int64)
    return ModalModel(
        pick("f_hz"),
        pick("zeta"),
        shapes.astype(np.complex128),
        pick("std_f_hz"),
        pick("std_zeta"),
        diagram.method,
        int(mode_orders.max()) if sel else 0,
        mode_orders,
        np.array([s for _, s in modes], dtype=np.int64),
    )


def _clusters(f: FloatArray, S: ComplexArray, diagram: StabilizationDiagram) -> np.ndarray:
    """Cluster labels of poles: average linkage on the distance of the module docstring."""
    if f.size < 2:
        return np.ones(f.size, dtype=int)
    df = np.abs(f[:, None] - f[None, :]) / (0.5 * (f[:, None] + f[None, :]))
    u = _unit_shapes(S, "phi_a")
    M = np.minimum(np.abs(u.conj().T @ u) ** 2, 1.0)  # MAC, Eq. (6) of [002]
    d = np.maximum(df / diagram.rel_tol_f, (1.0 - M) / max(1 - diagram.mac_min, 1e-6))
    np.fill_diagonal(d, 0.0)
    Z = sch.linkage(d[np.triu_indices(f.size, 1)], method="average")
    return np.asarray(sch.fcluster(Z, t=1.0, criterion="distance"))


def _min_support(diagram: StabilizationDiagram, min_support: int | None) -> int:
    n_ord = len(diagram.orders)
    return max(3, int(np.ceil(0.2 * n_ord))) if min_support is None else int(min_support)


@dataclass(frozen=True, slots=True)
class DroppedColumn:
    """A column of stable poles that is not reported as a mode, and why.

    Attributes
    ----------
    f_hz, zeta : float
        Median frequency and damping of its poles.
    n_poles : int
        Poles stable in frequency in it.
    orders : (int, int)
        First and last model order it spans.
    reason : str
    """

    f_hz: float
    zeta: float
    n_poles: int
    orders: tuple[int, int]
    reason: str

    def describe(self) -> str:
        """One line: where it is and why it is not a mode."""
        return (f"{self.f_hz:.3f} Hz (zeta {100 * self.zeta:.1f} %, orders {self.orders[0]}-"
                f"{self.orders[1]}): {self.reason}")


def dropped_columns(diagram: StabilizationDiagram, modes: ModalModel, *,
                    zeta_max: float = 0.2, min_support: int | None = None,
                    f_range_hz: tuple[float, float] | None = None,
                    min_poles: int = 3, rel_support: float = REL_SUPPORT
                    ) -> list[DroppedColumn]:
    """Columns of stable poles that :func:`select_modes` did not report, with the reason.

    The poles stable in frequency (the columns an engineer sees in the diagram) that are
    not in a reported mode's cluster are clustered as in :func:`select_modes`; a cluster
    is a column when it holds at least ``min_poles`` fully stable poles or as many poles
    stable in frequency as a mode needs. The reason is the first of: the frequency of a
    reported mode (another shape or damping), outside the band, damping not in
    (0, ``zeta_max``), too few fully stable poles (damping or MAC unstable at the others),
    too few poles at all. ``min_support`` and ``rel_support`` are those the modes were
    selected with.
    """
    ms = _min_support(diagram, min_support)
    if modes.n_support.size:
        ms = max(ms, int(np.ceil(rel_support * modes.n_support.max())))
    fl, zl, Sl, ol, fs = [], [], [], [], []
    for order, p, sf, st in zip(diagram.orders, diagram.poles, diagram.stable_f,
                                diagram.stable, strict=True):
        q = np.nonzero(sf)[0]
        fl.append(p.f_hz[q])
        zl.append(p.zeta[q])
        Sl.append(p.shapes[:, q])
        ol.append(np.full(q.size, int(order)))
        fs.append(st[q])
    if not fl or sum(x.size for x in fl) == 0:
        return []
    f, z = np.concatenate(fl).astype(float), np.concatenate(zl).astype(float)
    S, o, full = np.concatenate(Sl, axis=1), np.concatenate(ol), np.concatenate(fs)
    lab = _clusters(f, np.nan_to_num(S), diagram)
    lo, hi = f_range_hz if f_range_hz is not None else (-np.inf, np.inf)
    reported = {(int(o_), float(f_)) for o_, f_ in zip(modes.mode_orders, modes.f_hz,
                                                      strict=True)}
    out = []
    for c in np.unique(lab):
        idx = np.nonzero(lab == c)[0]
        n_full = int(full[idx].sum())
        if n_full < min_poles and idx.size < ms:
            continue  # scattered poles, not a column
        fm, zm = float(np.median(f[idx])), float(np.median(z[idx]))
        if any((int(o[k]), float(f[k])) in reported for k in idx):
            continue  # the reported mode's own column
        near = (modes.f_hz[np.argmin(np.abs(modes.f_hz - fm))] if modes.f_hz.size
                else np.inf)
        if abs(near - fm) <= diagram.rel_tol_f * fm:
            reason = (f"within {100 * diagram.rel_tol_f:g} % of the reported {near:.3f} Hz "
                      f"with another shape (MAC < {diagram.mac_min:g}) or damping")
        elif not lo <= fm <= hi:
            reason = f"outside the band {lo:.3g}-{hi:.3g} Hz"
        elif not 0 < zm < zeta_max:
            if idx.size < ms:
                continue  # a few poles of negative or large damping: noise, not a column
            reason = f"damping {100 * zm:.1f} % outside (0, {100 * zeta_max:g} %)"
        elif n_full < ms:
            reason = (f"stable in frequency at {idx.size} orders, in damping and MAC > "
                      f"{diagram.mac_min:g} too at {n_full}: fewer than the {ms} a mode "
                      f"needs (20 % of the orders, {100 * rel_support:g} % of the largest "
                      f"column)")
        else:
            reason = (f"its poles scatter in damping or shape: no cluster of {ms} among "
                      f"those damped in (0, {100 * zeta_max:g} %)")
        out.append(DroppedColumn(fm, zm, int(idx.size), (int(o[idx].min()),
                                                        int(o[idx].max())), reason))
    return sorted(out, key=lambda d: d.f_hz)
