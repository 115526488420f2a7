r"""Automatic selection of physical modes by hierarchical clustering of the poles.

The procedure of Magalhaes, Cunha & Caetano (2009) with the data-derived cut-off of
Reynders, Houbrechts & De Roeck (2012), on the poles of every model order of a
:class:`~modal_twin.identification.modal_model.StabilizationDiagram`:

1. **Distance** between two poles :math:`i, j` (Reynders, Houbrechts & De Roeck 2012):

   .. math:: d_{ij} = \frac{|\lambda_i - \lambda_j|}{\max(|\lambda_i|, |\lambda_j|)}
             + 1 - \mathrm{MAC}_{ij},

   with the continuous pole :math:`\lambda = \omega(-\zeta + j\sqrt{1 - \zeta^2})`, so the
   first term combines the relative frequency difference and the damping difference
   (:math:`\approx \sqrt{(\Delta f / f)^2 + \Delta\zeta^2}`) and MAC is Eq. (6) of [002].
2. **Poles that repeat**: each pole's distance to the nearest pole of the next model
   order (the previous one for the last order), :math:`d_{\rm next}`. The poles of a
   physical mode repeat closely over orders, spurious ones do not: a two-class k-means on
   :math:`\log d_{\rm next}` (:func:`scipy.cluster.vq.kmeans2`) separates them, and the
   cut-off distance is :math:`d_c = \bar d + 2 s_d` of the repeating class (as Reynders
   et al. 2012 derive theirs), kept in [:data:`CUT_MIN`, :data:`CUT_MAX`]. Poles with
   :math:`d_{\rm next} > d_c` are left out.
3. **Clusters**: single-linkage hierarchical clustering of the repeating poles
   (:func:`scipy.cluster.hierarchy.linkage`) cut at :math:`d_c`: a pole joins the cluster
   of its nearest neighbour, so a column that drifts slowly over the orders stays one
   cluster while the MAC term keeps close modes of distinct shapes apart.
4. **Outliers** (Magalhaes et al. 2009): in each cluster, poles damped outside
   (``zeta_min``, ``zeta_max``) are removed (a harmonic's column is damped at about
   zero; where the record is at hand, a column damped below ``zeta_min`` is removed only
   when the response band-passed at its frequency is a sine by its kurtosis, as
   :func:`is_harmonic`, its threshold from the number of independent samples the
   record holds: a lightly damped structural mode is kept), then at most one pole
   per model order is kept (the nearest to the cluster's median pole), then poles whose
   damping lies more than three scaled median absolute deviations from the median.
   Two clusters too short to count, one over low orders and one over higher ones, with
   shapes of MAC above ``mac_split``, frequencies within the low part's half-power
   bandwidth and the high part damped no more, are one mode's column broken where the
   order first fits it (:func:`_join_order_split`), represented by the high-order part.
5. **Physical modes**: a cluster is reported when it keeps at least ``n_min`` poles
   (``frac_orders`` of the model orders, at least 3, and ``rel_size`` of the largest
   cluster: physical modes form the large clusters, spurious poles the small ones, as
   in the last stage of Reynders et al. 2012), its median MPC (Eqs. (7)-(9) of
   [002]) is at least ``mpc_min``, its damping's standard deviation is at most
   ``zeta_cv_max`` times its median (a column of noise poles near the unit circle
   scatters about a damping near zero), where the response is at hand the output
   spectrum along its shape peaks at its frequency (:func:`spectral_peak`: a spurious
   pole that fits noise has no peak of its own), and no larger reported cluster lies
   within ``rel_tol_dup`` in frequency with MAC above ``mac_dup`` (a duplicate). Its
   representative is the median frequency and damping of its poles, with the shape of
   the pole nearest that median; its size is the number of poles kept.

Every cluster of at least 3 poles that is not reported comes back as a
:class:`~modal_twin.identification.stabilization.DroppedColumn` with the reason.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import scipy.cluster.hierarchy as sch
from scipy.cluster.vq import kmeans2

from modal_twin._types import ComplexArray, FloatArray, IntArray
from modal_twin.errors import OptionError
from modal_twin.identification.metrics import mpc
from modal_twin.identification.modal_model import ModalModel, StabilizationDiagram
from modal_twin.identification.peaks import on_peak
from modal_twin.identification.stabilization import DroppedColumn, _unit_shapes

__all__ = ["CUT_MAX", "CUT_MIN", "HARMONIC_KURTOSIS", "PEAK_RATIO", "ZETA_MIN",
           "ClusteredModes", "cluster_modes", "is_harmonic", "pole_distances",
           "spectral_peak"]

CUT_MIN = 0.015
"""Smallest cut-off distance (1.5 % in frequency with equal shapes): the poles of a
mode on a real record drift over the orders by more than those of adjacent orders differ."""
CUT_MAX = 0.1
"""Largest cut-off distance: noisier poles are not merged beyond it."""
MIN_COLUMN = 3
"""Fewest poles of a cluster listed as a column when not reported."""
MAC_SPLIT = 0.9
"""Least MAC of two clusters over disjoint order ranges joined as one mode's column."""
ZETA_MIN = 0.001
"""Least damping of a physical pole (0.1 %): a harmonic in the response or a noise pole
near the unit circle shows as a column damped at about zero."""
HARMONIC_KURTOSIS = 2.2
"""Largest kurtosis of a band-passed response read as a harmonic: a sine's is 1.5, the
narrow-band response of a randomly excited mode is Gaussian, 3 (Brincker, Andersen &
Moller 2000, "An indicator for separation of structural and harmonic modes in
output-only modal testing")."""


def is_harmonic(y: FloatArray, fs_hz: float, f_hz: float, rel_band: float = 0.01,
                kurtosis_max: float = HARMONIC_KURTOSIS) -> bool:
    r"""Whether the response ``y`` (n_ch, nt) holds a harmonic at ``f_hz``.

    Each channel is band-passed to ``f_hz * (1 -+ rel_band)`` (a 4th-order Butterworth,
    forward and backward); the channel with the most power there decides: its kurtosis
    (fourth moment over the squared variance) at most ``kurtosis_max`` is a sine's
    bimodal amplitude distribution, above it a random response's Gaussian one.

    The estimate comes from about :math:`N = T B` independent envelope samples (record
    length times band width); for a Gaussian response its standard deviation is about
    :math:`3 / \sqrt{N}` (the delta method on the envelope power, exponential:
    :math:`\mathrm{var}(\overline{w^2} / \bar w^2) \approx 4 / N`). The threshold is
    therefore also at most :math:`3 - 6 / \sqrt{N}`, two deviations below a Gaussian's:
    on a short record (an earthquake's 40-65 s at a few Hz, :math:`N \approx 3`) a
    randomly driven mode is not read as a harmonic by chance, and a column damped at
    about zero is then judged by its other rules (a harmonic is told only from records
    long enough: :math:`N \ge 56` for the 2.2 threshold).
    """
    from scipy.signal import butter, sosfiltfilt
    from scipy.stats import kurtosis

    y = np.atleast_2d(np.asarray(y, float))
    lo, hi = f_hz * (1.0 - rel_band), f_hz * (1.0 + rel_band)
    if not (0.0 < lo < hi < 0.5 * fs_hz) or y.shape[1] < 64:
        return True  # cannot tell: the damping rule stands
    sos = butter(4, [lo, hi], btype="bandpass", fs=fs_hz, output="sos")
    yb = sosfiltfilt(sos, y, axis=1)
    skip = min(y.shape[1] // 10, int(10 * fs_hz / max(hi - lo, 1e-12)))  # filter transients
    yb = yb[:, skip: y.shape[1] - skip]
    best = int(np.argmax(np.var(yb, axis=1)))
    n_eff = (yb.shape[1] / fs_hz) * (hi - lo)  # independent envelope samples, T x B
    k_max = min(kurtosis_max, 3.0 - 6.0 / np.sqrt(max(n_eff, 1e-12)))
    return bool(kurtosis(yb[best], fisher=False) <= k_max)


PEAK_REL_TOL = 0.005
"""Least half-width of the window of :func:`spectral_peak`, relative to the frequency:
a lightly damped pole and its spectral peak differ by the bias of either estimate (a
UFF record's 182.3 Hz peak, its pole column at 182.85 Hz, 0.06 % damped)."""
PEAK_RATIO = 2.0
"""Least ratio (3 dB) of a mode's peak in the spectrum along its shape to the median of
that spectrum on its flanks (:func:`spectral_peak`), as the prominence of an FDD peak."""


def spectral_peak(y: FloatArray, fs_hz: float, ratio: float = PEAK_RATIO
                  ) -> Callable[[float, float, ComplexArray], bool]:
    r"""Return ``peak(f_hz, zeta, shape)``: whether the response shows the mode.

    The output PSD matrix :math:`G(f)` (Welch, Hann, segments of the largest power of
    two with at least 8 averages at 50 % overlap) projected on the mode's shape,
    :math:`p(f) = \phi^H G(f) \phi / \phi^H \phi` (the spectrum of the enhanced FDD,
    Brincker et al. 2001), must have a local maximum within
    :math:`w = \max(\min(\zeta, 0.02) f, 0.005 f, 1.5\,\Delta f)` (its half-power
    width, at most 2 %; the 0.5 % a pole and its peak may differ by on a sharp peak;
    1.5 lines) of the mode's frequency that
    stands at least ``ratio`` above the median of :math:`p` at :math:`3w`-:math:`6w`
    from it. A pole of the model that fits noise, or a heavily damped one on a
    neighbour's flank, has no peak of its own; with no flank or no line within the
    band the mode is not judged (True).
    """
    import scipy.signal as sig

    y0 = np.atleast_2d(np.asarray(y, float))
    y0 = y0 - y0.mean(axis=1, keepdims=True)
    nper = int(2 ** np.floor(np.log2(max(y0.shape[1] / 4.5, 16.0))))
    fg, G = sig.csd(y0[:, None, :], y0[None, :, :], fs=fs_hz, nperseg=nper, axis=-1)
    G = np.moveaxis(G, -1, 0)
    df = float(fg[1] - fg[0])

    def peak(f_hz: float, zeta: float, shape: ComplexArray) -> bool:
        phi = np.asarray(shape, complex)
        p = np.real(np.einsum("i,fij,j->f", phi.conj(), G, phi)) / max(
            float(np.vdot(phi, phi).real), 1e-300)
        w = max(min(max(zeta, 0.0), 0.02) * f_hz, PEAK_REL_TOL * f_hz, 1.5 * df)
        return bool(on_peak(fg, p, f_hz, w, ratio)[0])

    return peak


@dataclass(frozen=True, slots=True)
class ClusteredModes:
    """What :func:`cluster_modes` reports.

    Attributes
    ----------
    modes : ModalModel
        The clusters' representatives (``n_support``: poles kept in each cluster).
    dropped : tuple of DroppedColumn
        Clusters of at least 3 poles not reported, with the reason.
    cutoff : float
        The cut-off distance :math:`d_c` derived from the data.
    n_min : int
        Fewest poles a reported cluster keeps.
    """

    modes: ModalModel
    dropped: tuple[DroppedColumn, ...]
    cutoff: float
    n_min: int


def _lambda(f: FloatArray, z: FloatArray) -> ComplexArray:
    w = 2 * np.pi * f
    out: ComplexArray = w * (-z + 1j * np.sqrt(np.clip(1 - z**2, 0.0, None)))
    return out


def pole_distances(f_a: FloatArray, z_a: FloatArray, u_a: ComplexArray,
                   f_b: FloatArray, z_b: FloatArray, u_b: ComplexArray) -> FloatArray:
    r"""Distances :math:`d_{ij}` of the module docstring between two sets of poles.

    Parameters
    ----------
    f_a, z_a : (n_a,) arrays
        Frequencies (Hz) and damping ratios.
    u_a : (n_ch, n_a) complex array
        Shapes of unit norm.
    f_b, z_b, u_b
        The same for the second set.

    Returns
    -------
    (n_a, n_b) array
    """
    la, lb = _lambda(f_a, z_a), _lambda(f_b, z_b)
    rel = np.abs(la[:, None] - lb[None, :]) / np.maximum(
        np.maximum(np.abs(la)[:, None], np.abs(lb)[None, :]), 1e-300)
    M = np.minimum(np.abs(u_a.conj().T @ u_b) ** 2, 1.0)
    out: FloatArray = rel + 1.0 - M
    return out


def _cutoff(d_next: FloatArray) -> float:
    r"""Cut-off :math:`\bar d + 2 s_d` of the repeating class of ``d_next`` (step 2)."""
    d = d_next[np.isfinite(d_next)]
    if d.size < 4:
        return CUT_MIN
    x = np.log(np.maximum(d, 1e-12))[:, None]
    init = np.array([[x.min()], [x.max()]])
    rep = d
    if init[0, 0] != init[1, 0]:
        cent, lab = kmeans2(x, init, minit="matrix", iter=50)
        rep = d[lab == int(np.argmin(cent[:, 0]))]
    return float(np.clip(rep.mean() + 2 * rep.std(), CUT_MIN, CUT_MAX))


def _empty(n_ch: int, method: str) -> ModalModel:
    e = np.zeros(0)
    i = np.zeros(0, np.int64)
    return ModalModel(e, e, np.zeros((n_ch, 0), complex), e, e, method, 0, i, i)


def cluster_modes(diagram: StabilizationDiagram, *, zeta_max: float = 0.2,
                  zeta_min: float = ZETA_MIN,
                  f_range_hz: tuple[float, float] | None = None,
                  harmonic: Callable[[float], bool] | None = None,
                  spectrum: Callable[[float, float, ComplexArray], bool] | None = None,
                  frac_orders: float = 0.2, rel_size: float = 0.35, mpc_min: float = 0.0,
                  zeta_cv_max: float = 1.0,
                  rel_tol_dup: float = 0.02, mac_dup: float = 0.8,
                  mac_split: float = MAC_SPLIT) -> ClusteredModes:
    """Physical modes of a diagram by clustering its poles (module docstring).

    Parameters
    ----------
    diagram : StabilizationDiagram
        Poles of every order (the stability flags are not used: the clustering judges
        the poles by how closely they repeat).
    zeta_max, zeta_min : float
        Poles damped outside (``zeta_min``, ``zeta_max``) are not physical.
    f_range_hz : (float, float), optional
        Report modes in this band only (a column outside it that would be a mode is
        listed as dropped).
    harmonic : callable, optional
        ``harmonic(f_hz)``: whether the record holds a harmonic at ``f_hz``
        (:func:`is_harmonic` on the response). A cluster damped below ``zeta_min`` at its
        median is then kept down to zero damping unless it is one; without it every
        pole damped below ``zeta_min`` is removed.
    spectrum : callable, optional
        ``spectrum(f_hz, zeta, shape)``: whether the response shows the mode
        (:func:`spectral_peak`); a cluster it does not show is not reported, and said.
    frac_orders : float
        A mode's cluster keeps poles at this fraction of the model orders (at least 3).
    rel_size : float
        ... and at least this fraction of the largest cluster's poles.
    mpc_min : float
        Smallest median MPC of a reported cluster (0: off).
    zeta_cv_max : float
        Largest spread of a reported cluster's damping, its standard deviation over its
        median (noise poles near the unit circle scatter about a damping near zero).
    rel_tol_dup, mac_dup : float
        A cluster within ``rel_tol_dup`` in frequency of a larger reported one whose
        shape has MAC above ``mac_dup`` with it is a duplicate.
    mac_split : float
        Two clusters over disjoint order ranges whose shapes have MAC above it and whose
        frequencies differ by less than the lower one's half-power bandwidth are one mode
        (:func:`_join_order_split`).

    Returns
    -------
    ClusteredModes

    Raises
    ------
    OptionError
        Not ``0 <= zeta_min < zeta_max <= 1``, ``frac_orders`` outside (0, 1],
        ``rel_size`` or ``mpc_min`` outside [0, 1].
    """
    if not (0.0 <= zeta_min < zeta_max <= 1.0 and 0.0 < frac_orders <= 1.0
            and 0.0 <= rel_size <= 1.0 and 0.0 <= mpc_min <= 1.0):
        msg = (f"zeta_min, zeta_max, frac_orders, rel_size, mpc_min: expected 0 <= zeta_min "
               f"< zeta_max <= 1 and values in (0, 1], [0, 1], [0, 1], got {zeta_min!r}, "
               f"{zeta_max!r}, {frac_orders!r}, {rel_size!r}, {mpc_min!r}")
        raise OptionError(msg)
    n_ord = len(diagram.poles)
    n_min = max(MIN_COLUMN, int(np.ceil(frac_orders * n_ord)))
    lo, hi = f_range_hz if f_range_hz is not None else (0.0, np.inf)
    t = _pole_table(diagram)
    cut = _cutoff(t.d_next)
    rep = np.nonzero(t.d_next <= cut)[0]
    if rep.size < MIN_COLUMN:
        return ClusteredModes(_empty(t.u.shape[0], diagram.method), (), cut, n_min)
    D = pole_distances(t.f[rep], t.z[rep], t.u[:, rep], t.f[rep], t.z[rep], t.u[:, rep])
    D = 0.5 * (D + D.T)
    np.fill_diagonal(D, 0.0)
    lab = sch.fcluster(sch.linkage(D[np.triu_indices(rep.size, 1)], method="single"),
                       t=cut, criterion="distance")
    groups = _groups(t, rep, lab, zeta_min, zeta_max, harmonic)
    inside = [bool(lo <= np.median(t.f[g[0]]) <= hi) for g in groups]
    groups = _join_order_split(groups, t, mac_split, max(n_min, int(np.ceil(rel_size * max(
        (g[2].size for g, i in zip(groups, inside, strict=True) if i), default=0)))))
    inside = [bool(lo <= np.median(t.f[g[0]]) <= hi) for g in groups]
    n_min = max(n_min, int(np.ceil(rel_size * max(
        (g[2].size for g, i in zip(groups, inside, strict=True) if i), default=0))))
    cands, dropped = [], []
    for (idx, ok, kept, top), within in zip(groups, inside, strict=True):
        span = (int(diagram.orders[t.order_ix[idx].min()]),
                int(diagram.orders[t.order_ix[idx].max()]))
        fm0, zm0 = float(np.median(t.f[idx])), float(np.median(t.z[idx]))
        if not within:
            if kept.size >= n_min:  # a column outside the band; noise there is not listed
                dropped.append(DroppedColumn(fm0, zm0, int(idx.size), span,
                                             f"outside the band {lo:.3g}-{hi:.3g} Hz"))
            continue
        if kept.size < n_min:
            if ok.size < idx.size - ok.size:
                why = (f"damping {100 * zm0:.2f} % outside ({100 * zeta_min:g}, "
                       f"{100 * zeta_max:g} %) at {idx.size - ok.size} of its {idx.size} poles"
                       + (" (a harmonic or noise)" if zm0 <= zeta_min else ""))
            else:
                why = (f"too few poles: {kept.size} of {n_ord} orders after outliers, a mode "
                       f"needs {n_min} ({100 * frac_orders:g} % of the orders, "
                       f"{100 * rel_size:g} % of the largest cluster)")
            dropped.append(DroppedColumn(fm0, zm0, int(idx.size), span, why))
            continue
        c_, why = _candidate(t, top, span, mpc_min, zeta_cv_max, spectrum)
        c_ = replace(c_, size=int(kept.size))
        if why:
            dropped.append(DroppedColumn(c_.f_hz, c_.zeta, c_.size, span, why))
        else:
            cands.append(c_)
    modes = _without_duplicates(cands, t, rel_tol_dup, mac_dup, dropped)
    return ClusteredModes(_model(diagram, modes, t),
                          tuple(sorted(dropped, key=lambda d: d.f_hz)), cut, n_min)


@dataclass(frozen=True, slots=True)
class _Poles:
    """Every pole of the diagram in one table (finite, positive frequency)."""

    order_ix: IntArray  # index of its model order
    pole_ix: IntArray  # index in that order's PoleSet
    f: FloatArray
    z: FloatArray
    u: ComplexArray  # unit shapes, (n_ch, n_poles)
    d_next: FloatArray  # distance to the nearest pole of the next order


@dataclass(frozen=True, slots=True)
class _Cluster:
    f_hz: float
    zeta: float
    best: int  # the pole nearest the median
    size: int
    span: tuple[int, int]


def _pole_table(diagram: StabilizationDiagram) -> _Poles:
    P = diagram.poles
    n_ord = len(P)
    sets = []  # per order: indices kept, f, zeta, unit shapes
    for p in P:
        q = np.nonzero(np.isfinite(p.f_hz) & np.isfinite(p.zeta) & (p.f_hz > 0)
                       & np.all(np.isfinite(p.shapes), axis=0))[0]
        sets.append((q, p.f_hz[q].astype(float), p.zeta[q].astype(float),
                     _unit_shapes(p.shapes[:, q], "phi_a")))
    d_next = []
    for k, (_q, f, z, u) in enumerate(sets):
        _, fb, zb, ub = sets[k + 1 if k + 1 < n_ord else max(k - 1, 0)]
        if f.size == 0 or fb.size == 0:
            d_next.append(np.full(f.size, np.inf))
        else:
            d_next.append(pole_distances(f, z, u, fb, zb, ub).min(axis=1))
    return _Poles(np.concatenate([np.full(s[0].size, k) for k, s in enumerate(sets)]),
                  np.concatenate([s[0] for s in sets]),
                  np.concatenate([s[1] for s in sets]), np.concatenate([s[2] for s in sets]),
                  np.concatenate([s[3] for s in sets], axis=1), np.concatenate(d_next))


def _candidate(t: _Poles, kept: IntArray, span: tuple[int, int], mpc_min: float,
               zeta_cv_max: float,
               spectrum: Callable[[float, float, ComplexArray], bool] | None = None
               ) -> tuple[_Cluster, str]:
    """Return the cluster's median pole and why it is not a mode ('' when it is one)."""
    fm, zm = float(np.median(t.f[kept])), float(np.median(t.z[kept]))
    lm = _lambda(np.array([fm]), np.array([zm]))[0]
    best = int(kept[np.argmin(np.abs(_lambda(t.f[kept], t.z[kept]) - lm))])
    c = _Cluster(fm, zm, best, int(kept.size), span)
    m = float(np.median(mpc(t.u[:, kept])))
    if m < mpc_min:
        return c, f"MPC {m:.2f} below {mpc_min:g} (a noise-like, complex shape)"
    sz = float(np.std(t.z[kept]))
    if sz > zeta_cv_max * zm:
        return c, (f"damping not determined: its poles scatter by {100 * sz:.2f} % about a "
                   f"median of {100 * zm:.2f} %")
    if spectrum is not None and not spectrum(fm, zm, t.u[:, best]):
        w = 100 * max(min(zm, 0.02), PEAK_REL_TOL)
        return c, (f"no peak of its own in the spectrum along its shape (within {w:.2g} % "
                   f"of it): a pole that fits noise or a neighbour's flank")
    return c, ""


def _without_duplicates(cands: list[_Cluster], t: _Poles, rel_tol: float, mac_min: float,
                        dropped: list[DroppedColumn]) -> list[_Cluster]:
    """Return the candidates less those that repeat a larger one (each said)."""
    modes: list[_Cluster] = []
    for c in sorted(cands, key=lambda c_: -c_.size):
        macs = [float(np.abs(t.u[:, m.best].conj() @ t.u[:, c.best]) ** 2) for m in modes]
        dup = [(m, x) for m, x in zip(modes, macs, strict=True)
               if abs(m.f_hz - c.f_hz) <= rel_tol * m.f_hz and x > mac_min]
        if dup:
            m, x = dup[0]
            dropped.append(DroppedColumn(c.f_hz, c.zeta, c.size, c.span,
                                         f"duplicate of the reported {m.f_hz:.3f} Hz (MAC "
                                         f"{x:.2f}, {m.size} poles against {c.size})"))
        else:
            modes.append(c)
    return sorted(modes, key=lambda c_: c_.f_hz)


_Group = tuple[IntArray, IntArray, IntArray, IntArray]
"""A cluster: all its poles, those damped in range, those kept after the outliers, and
those its representative is the median of (the kept ones but for a joined column)."""


def _groups(t: _Poles, rep: IntArray, lab: IntArray, zeta_min: float, zeta_max: float,
            harmonic: Callable[[float], bool] | None) -> list[_Group]:
    """Return the clusters of at least :data:`MIN_COLUMN` poles with their outliers removed."""
    groups = []
    for c in np.unique(lab):
        idx = rep[lab == c]
        if idx.size >= MIN_COLUMN:  # fewer: scattered poles, not a column
            z_lo = zeta_min
            if (harmonic is not None and np.median(t.z[idx]) <= zeta_min
                    and not harmonic(float(np.median(t.f[idx])))):
                z_lo = 0.0  # a lightly damped mode of a randomly driven response
            ok = idx[(t.z[idx] > z_lo) & (t.z[idx] < zeta_max)]
            kept = _damping_inliers(_one_per_order(ok, t), t.z)
            groups.append((idx, ok, kept, kept))
    return groups


def _join_order_split(groups: list[_Group], t: _Poles, mac_min: float, n_min: int
                      ) -> list[_Group]:
    r"""Join the clusters of one mode split by the model order (module docstring, step 4).

    Below the order that fits every mode of the band a physical pole is biased (the model
    lumps what it cannot fit into it) and it moves to its converged place as the order
    grows: its column may then break into a low-order and a high-order cluster, each too
    short to count. Two clusters ``a`` (lower orders) and ``b`` (higher), each a column
    (at least :data:`MIN_COLUMN` poles after the outliers) and neither with the
    ``n_min`` poles of a mode on its own, are one mode's column when no model order
    has a pole in both, every order of ``a`` lies below every order of ``b``, their
    median poles' shapes have MAC above ``mac_min``, their frequencies differ by less
    than the half-power bandwidth :math:`2 \zeta_a f_a` of the lower part (two peaks of
    one shape closer than that are one peak of the response) and the high-order part is
    damped no more than the low-order one (an under-fitted pole lumps its neighbours'
    energy into a wider peak and sharpens as it converges; a column of noise poles has
    no such trend).
    The joined cluster counts both parts' poles and is represented by the high-order
    part (the 4th item of each group: the poles its median is taken over).
    """
    def med(g: _Group) -> tuple[float, float, int]:
        k = g[3]
        fm, zm = float(np.median(t.f[k])), float(np.median(t.z[k]))
        lm = _lambda(np.array([fm]), np.array([zm]))[0]
        return fm, zm, int(k[np.argmin(np.abs(_lambda(t.f[k], t.z[k]) - lm))])

    out = list(groups)
    joined = True
    while joined:
        joined = False
        for i, a in enumerate(out):
            for j, b in enumerate(out):
                if i == j or not MIN_COLUMN <= a[2].size < n_min \
                        or not MIN_COLUMN <= b[2].size < n_min \
                        or t.order_ix[a[2]].max() >= t.order_ix[b[2]].min():
                    continue
                (fa, za, pa), (fb, zb, pb) = med(a), med(b)
                mac = float(np.abs(t.u[:, pa].conj() @ t.u[:, pb]) ** 2)
                if abs(fb - fa) < 2 * max(za, 0.0) * fa and zb <= za and mac > mac_min:
                    out[i] = (np.concatenate([a[0], b[0]]), np.concatenate([a[1], b[1]]),
                              np.concatenate([a[2], b[2]]), b[3])
                    del out[j]
                    joined = True
                    break
            if joined:
                break
    return out


def _one_per_order(idx: IntArray, t: _Poles) -> IntArray:
    """At most one pole per model order: the nearest to the median pole."""
    f, z, order_ix = t.f, t.z, t.order_ix
    if idx.size == 0:
        return idx
    lm = _lambda(np.array([np.median(f[idx])]), np.array([np.median(z[idx])]))[0]
    dist = np.abs(_lambda(f[idx], z[idx]) - lm)
    out = []
    for o in np.unique(order_ix[idx]):
        sub = np.nonzero(order_ix[idx] == o)[0]
        out.append(idx[sub[np.argmin(dist[sub])]])
    return np.array(out, dtype=np.int64)


def _damping_inliers(idx: IntArray, z: FloatArray, k: float = 3.0) -> IntArray:
    """Poles whose damping is within ``k`` scaled MADs (1.4826 MAD) of the median."""
    if idx.size < 3:
        return idx
    med = np.median(z[idx])
    mad = 1.4826 * np.median(np.abs(z[idx] - med))
    if mad == 0:
        return idx
    out: IntArray = idx[np.abs(z[idx] - med) <= k * mad]
    return out


def _model(diagram: StabilizationDiagram, modes: list[_Cluster], t: _Poles) -> ModalModel:
    if not modes:
        return _empty(t.u.shape[0], diagram.method)
    P = diagram.poles
    sel = [(int(t.order_ix[c.best]), int(t.pole_ix[c.best])) for c in modes]
    shapes = np.stack([P[k].shapes[:, q] for k, q in sel], axis=1).astype(np.complex128)
    orders = np.array([int(diagram.orders[k]) for k, _ in sel], dtype=np.int64)
    return ModalModel(
        np.array([c.f_hz for c in modes]), np.array([c.zeta for c in modes]), shapes,
        np.array([P[k].std_f_hz[q] for k, q in sel], dtype=float),
        np.array([P[k].std_zeta[q] for k, q in sel], dtype=float),
        diagram.method, int(orders.max()), orders,
        np.array([c.size for c in modes], dtype=np.int64))
