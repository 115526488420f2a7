"""Non-parametric evidence at a device: what the measured force-state data say before any fit.

At a component whose drift ``u`` and force ``f`` are measured, the residual restoring
force of the nominal linear law (Eq. (20) of [003])

    r(t) = f(t) - (k u(t) + c u'(t))

is examined in two ways.

**Cycles** (reversal to reversal of the drift): for each cycle its amplitude ``A``, the
energy dissipated beyond the nominal law ``E = closed integral of (f - k u) du`` against the
nominal viscous share ``E_c = closed integral of c u' du``, and the secant stiffness
``k_sec = (f(u_max) - f(u_min)) / (u_max - u_min)``. How ``E - E_c`` grows with ``A`` (a
log-log slope near 1: friction, a force of fixed size; near 2 with the cycle's rate: a
viscous change; between: hysteresis) and how ``k_sec / k`` moves with ``A`` (falling:
softening or yielding; rising: hardening or contact) are reported with their numbers.

**A sparse regression of r over families of state functions** (Eqs. 2-12 and 13-17 of
[003]: the restoring-force surface and the slip elements of a Prandtl-Ishlinskii / Iwan
model), each family a group of columns built from the record's own scales (``A99``, the
99th percentile of ``|u|``; ``V`` the RMS velocity):

============  =====================================================================
family        columns
============  =====================================================================
stiffness     u                       (a change of the linear stiffness)
damping       u'                      (a change of the viscous damping)
friction      tanh(u' / eps) for eps = 0.01, 0.05 V; the same times exp(-|u'| / V)
              (a rate-dependent coefficient); stop(u, r) for r <= 2 % A99
hysteresis    stop(u, r) for r = 5, 12, 25, 45, 70 % A99 (slip elements that yield
              gradually: any smoothness, Masing or not)
elastic       u^3 / A99^2, u |u| / A99, A99 tanh(u / (0.5 A99)), dead zones
              sign(u) max(|u| - g, 0) for g = 0.2, 0.4, 0.6, 0.8 A99
============  =====================================================================

The elastic group is named by what its fitted backbone does: **hardening** when it adds
stiffness with amplitude, **softening** when it removes it, **gap** when the dead-zone
columns alone explain it at least as well as the smooth ones. Each family's score is the
share of the residual it explains, alone and uniquely (all families fitted together minus
all but it), always in [0, 1]: for stiffness and damping the share of ``var(r)``, for the
nonlinear families the share of what the linear terms leave (a nonlinearity always
projects partly on them). A family counts when its gain beats the noise: the drop of the
residual sum of squares must exceed ``p ln N`` noise variances (BIC, ``p`` columns) and
10 % of the residual it is judged on.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import signal

from modal_twin._types import FloatArray
from modal_twin.diagnosis.restoring_force import state_derivatives, stop_operator

__all__ = [
    "CycleFeatures",
    "DeviceEvidence",
    "cycle_features",
    "device_evidence",
    "drift_state",
    "velocity_cutoff",
]

FAMILY_GROUPS = ("stiffness", "damping", "friction", "hysteresis", "elastic")


@dataclass(frozen=True, slots=True)
class CycleFeatures:
    """Per-cycle figures of one direction (arrays of equal length, one entry a cycle)."""

    amplitude: FloatArray  # m
    energy_excess: FloatArray  # J dissipated beyond the nominal viscous share
    energy_nominal: FloatArray  # J the nominal dashpot dissipates on the same path
    k_secant_ratio: FloatArray  # secant stiffness / nominal k
    rate_hz: FloatArray  # cycles per second

    def slopes(self) -> tuple[float, float]:
        """(d ln E_excess / d ln A, d (k_sec / k) / d (A / A_max)), NaN when undetermined."""
        ok = (self.energy_excess > 0) & (self.amplitude > 0)
        e_slope = float("nan")
        if ok.sum() >= 4 and np.ptp(np.log(self.amplitude[ok])) > 0.3:
            e_slope = float(np.polyfit(np.log(self.amplitude[ok]),
                                       np.log(self.energy_excess[ok]), 1)[0])
        k_slope = float("nan")
        if self.amplitude.size >= 4 and np.ptp(self.amplitude) > 0:
            a = self.amplitude / self.amplitude.max()
            k_slope = float(np.polyfit(a, self.k_secant_ratio, 1)[0])
        return e_slope, k_slope


def velocity_cutoff(u: FloatArray, fs_hz: float) -> float:
    """Low-pass edge for differentiating a drift.

    Twice the frequency below which 99 % of its power lies (Welch, Hann window; never above
    0.45 fs), derived from the record.
    """
    x = np.atleast_2d(u)
    nper = int(min(x.shape[-1], 4096))
    f, p = signal.welch(x, fs=fs_hz, nperseg=nper, axis=-1)
    c = np.cumsum(np.sum(p, axis=0))
    if c[-1] <= 0:
        return 0.45 * fs_hz
    f99 = float(f[np.searchsorted(c, 0.99 * c[-1])])
    return float(min(max(2.0 * f99, 2.0 * f[1]), 0.45 * fs_hz))


def turning_points(u: FloatArray, threshold: float) -> FloatArray:
    """Return the indices of the peaks and valleys of ``u``.

    Only those that stand ``threshold`` above / below their neighbours count (ripples
    smaller than that are not cycles); the first sample leads.
    """
    ext = [0]
    cand, trend = 0, 0
    for i in range(1, u.size):
        if trend == 0:
            if abs(u[i] - u[0]) >= threshold:
                trend, cand = (1 if u[i] > u[0] else -1), i
        elif trend * (u[i] - u[cand]) > 0:
            cand = i
        elif trend * (u[cand] - u[i]) >= threshold:
            ext.append(cand)
            trend, cand = -trend, i
    return np.asarray(ext, dtype=int)


def cycle_features(u: FloatArray, f: FloatArray, v: FloatArray, k: float, c: float,
                   fs_hz: float, *, min_fraction: float = 0.1) -> CycleFeatures:
    """Cycles of one direction between every other reversal of ``u`` (see module doc).

    Reversals are the turning points of ``u`` that stand ``min_fraction`` of its range
    above their neighbours (noise and ripples are not cycles); a cycle is two successive
    swings within 20 % of each other (a nearly closed loop).
    """
    keep = turning_points(u, min_fraction * float(np.ptp(u)))
    amp, e_ex, e_nom, ksec, rate = [], [], [], [], []
    du = np.diff(u)
    w_el = 0.5 * ((f - k * u)[1:] + (f - k * u)[:-1]) * du
    w_c = 0.5 * (c * (v[1:] + v[:-1])) * du
    for i in range(len(keep) - 2):
        a, b = keep[i], keep[i + 2]
        h1, h2 = abs(u[keep[i + 1]] - u[a]), abs(u[b] - u[keep[i + 1]])
        if min(h1, h2) < 0.8 * max(h1, h2):
            continue  # not a closed cycle: the swing out and back differ
        seg = u[a:b + 1]
        lo, hi = int(np.argmin(seg)), int(np.argmax(seg))
        if seg[hi] - seg[lo] <= 0:
            continue
        amp.append(0.5 * float(seg[hi] - seg[lo]))
        e_ex.append(float(np.sum(w_el[a:b]) - np.sum(w_c[a:b])))
        e_nom.append(float(np.sum(w_c[a:b])))
        fs_ = f[a:b + 1]
        ksec.append(float((fs_[hi] - fs_[lo]) / (seg[hi] - seg[lo])) / k if k else np.nan)
        rate.append(fs_hz / max(b - a, 1))
    arr = [np.asarray(x, float) for x in (amp, e_ex, e_nom, ksec, rate)]
    return CycleFeatures(*arr)


def _columns(u: FloatArray, v: FloatArray, a99: float, vrms: float
             ) -> dict[str, list[tuple[str, FloatArray]]]:
    """Return the candidate state functions of one direction, grouped by family."""
    cols: dict[str, list[tuple[str, FloatArray]]] = {g: [] for g in FAMILY_GROUPS}
    cols["stiffness"].append(("u", u))
    cols["damping"].append(("v", v))
    for eps in (0.01, 0.05):
        t = np.tanh(v / (eps * vrms))
        cols["friction"].append((f"tanh(v/{eps}V)", t))
        cols["friction"].append((f"tanh(v/{eps}V)exp(-|v|/V)", t * np.exp(-np.abs(v) / vrms)))
    cols["friction"].append(("stop(u,0.02A)", stop_operator(u, 0.02 * a99) / 0.02))
    for r in (0.05, 0.12, 0.25, 0.45, 0.7):
        cols["hysteresis"].append((f"stop(u,{r}A)", stop_operator(u, r * a99) / r))
    cols["elastic"] += [("u^3", u**3 / a99**2), ("u|u|", u * np.abs(u) / a99),
                        ("tanh(u/0.5A)", 0.5 * a99 * np.tanh(u / (0.5 * a99)))]
    for g in (0.2, 0.4, 0.6, 0.8):
        cols["elastic"].append((f"dead(u,{g}A)", np.sign(u) * np.maximum(np.abs(u) - g * a99,
                                                                          0.0)))
    return cols


def _sse(A: FloatArray, b: FloatArray) -> tuple[float, FloatArray]:
    if A.shape[1] == 0:
        return float(b @ b), np.zeros(0)
    scale = np.linalg.norm(A, axis=0)
    scale[scale == 0] = 1.0
    coef, *_ = np.linalg.lstsq(A / scale, b, rcond=None)
    coef = coef / scale
    res = b - A @ coef
    return float(res @ res), coef


@dataclass(frozen=True, slots=True)
class DeviceEvidence:
    """What the force-state data of one component say (module docstring)."""

    component: str
    residual_share: float  # var(r) / var(f): what the nominal law leaves
    noise_share: float  # var(force noise) / var(f)
    alone: dict[str, float]  # family -> share of var(r) it explains beyond linear, alone
    unique: dict[str, float]  # family -> share only it explains (all fitted together)
    significant: tuple[str, ...]  # families whose gain beats the noise (best first)
    elastic_kind: str  # hardening | softening | gap (what the elastic group does)
    dk_ratio: float  # fitted linear stiffness change / k
    dc_ratio: float  # fitted damping change / c
    energy_slope: float  # d ln E_excess / d ln A over the cycles
    k_secant_slope: float  # d (k_sec / k) / d (A / A_max)
    excess_energy_ratio: float  # sum E_excess / sum E_nominal over the cycles
    n_cycles: int
    notes: tuple[str, ...] = field(default_factory=tuple)

    def family_scores(self) -> dict[str, float]:
        """Family (hysteresis, friction, softening, hardening, gap, stiffness.

        Damping) -> score in [0, 1]: the share of the residual it explains alone, zero when
        not significant.
        """
        out: dict[str, float] = {}
        for g, s in self.alone.items():
            name = self.elastic_kind if g == "elastic" else g
            out[name] = s if g in self.significant else 0.0
        return out

    def format(self) -> str:
        """Evidence lines with their numbers."""
        fam = ", ".join(f"{(self.elastic_kind if g == 'elastic' else g)} "
                        f"{100 * self.alone[g]:.0f} % (unique {100 * self.unique[g]:.0f} %)"
                        for g in sorted(self.alone, key=lambda g: -self.alone[g]))
        sig = ", ".join(self.elastic_kind if g == "elastic" else g for g in self.significant)
        return (f"{self.component}: nominal law leaves {100 * self.residual_share:.1f} % of the "
                f"force variance (noise {100 * self.noise_share:.2f} %); {self.n_cycles} "
                f"cycles: excess energy x{self.excess_energy_ratio:.2f} of the nominal "
                f"dashpot's, ln E / ln A slope {self.energy_slope:.2f}, secant k / k slope "
                f"{self.k_secant_slope:+.3f} over amplitude; dk/k {self.dk_ratio:+.3f}, dc/c "
                f"{self.dc_ratio:+.3f}\n    explained share of the residual: {fam}\n"
                f"    significant: {sig or 'none'}"
                + "".join(f"\n    note: {n}" for n in self.notes))


def drift_state(u: FloatArray, fs_hz: float, cutoff_hz: float | None = None,
                input_share: tuple[FloatArray, FloatArray] | None = None
                ) -> tuple[FloatArray, FloatArray]:
    """Return the low-passed drift and its velocity, each row (n_dir, nt).

    Spectral, below ``cutoff_hz`` (default :func:`velocity_cutoff` of the drift). Where the
    input carries a known part of the drift and its rate, ``input_share = (u_in, v_in)``
    (a primary suspension's stroke holds the rough track, up to Nyquist), only the rest is
    filtered and differentiated and the input's part added back: ``u = (u - u_in)_f + u_in``,
    ``u' = (u - u_in)' + v_in``.
    """
    u = np.atleast_2d(np.asarray(u, float))
    u_in = v_in = np.zeros_like(u)
    if input_share is not None:
        u_in, v_in = (np.atleast_2d(np.asarray(a, float)) for a in input_share)
    body = u - u_in
    cut = velocity_cutoff(body, fs_hz) if cutoff_hz is None else cutoff_hz
    uf, v = np.empty_like(u), np.empty_like(u)
    for i in range(u.shape[0]):
        uf[i], v[i], _ = state_derivatives(body[i], fs_hz, f_max_hz=cut)
    return uf + u_in, v + v_in


def device_evidence(component: str, u: FloatArray, f: FloatArray, k: Sequence[float],
                    c: Sequence[float], fs_hz: float, *, noise_var: Sequence[float] | None = None,
                    min_share: float = 0.01,
                    input_share: tuple[FloatArray, FloatArray] | None = None
                    ) -> DeviceEvidence:
    """Evidence at one component from its measured drift and force, shape (n_dir, nt).

    A component whose nominal law leaves less than ``min_share`` of the force variance (and
    not four times its noise) is reported as such without the regression. ``input_share``:
    the input's own part of the drift and its rate (:func:`drift_state`).
    """
    u = np.atleast_2d(np.asarray(u, float))
    f = np.atleast_2d(np.asarray(f, float))
    n_dir, nt = u.shape
    cut = velocity_cutoff(u if input_share is None
                          else u - np.atleast_2d(input_share[0]), fs_hz)
    uf, v = drift_state(u, fs_hz, cut, input_share)
    k_arr = np.asarray(k, float)[:n_dir]
    c_arr = np.asarray(c, float)[:n_dir]
    r = f - k_arr[:, None] * uf - c_arr[:, None] * v
    fc = f - f.mean(axis=1, keepdims=True)
    f_var = float(np.sum(fc**2))
    r_c = r - r.mean(axis=1, keepdims=True)
    r_var = float(np.sum(r_c**2))
    nv = np.zeros(n_dir) if noise_var is None else np.asarray(noise_var, float)[:n_dir]
    sse_noise = float(np.sum(nv) * nt)
    if r_var < max(min_share * f_var, 4.0 * sse_noise):
        zero = dict.fromkeys(FAMILY_GROUPS, 0.0)
        return DeviceEvidence(component, float(r_var / max(f_var, 1e-300)),
                              float(sse_noise / max(f_var, 1e-300)), zero, dict(zero), (),
                              "softening", 0.0, 0.0, float("nan"), float("nan"), float("nan"),
                              0, ("the nominal law explains the force to its noise",))
    # the columns need the full-rate history (slip elements); the fit does not
    step = max(1, int(fs_hz / (20.0 * cut)))
    groups_x = [_columns(uf[i], v[i], max(float(np.quantile(np.abs(uf[i]), 0.99)), 1e-12),
                         max(float(np.std(v[i])), 1e-12)) for i in range(n_dir)]
    groups_x = [{g: [(n, col[::step]) for n, col in cols] for g, cols in gx.items()}
                for gx in groups_x]
    nt_full, nt = nt, groups_x[0]["stiffness"][0][1].size
    r = r[:, ::step]
    sse_noise *= nt / nt_full
    share, noise_share = r_var / max(f_var, 1e-300), sse_noise / nt * nt_full / max(f_var, 1e-300)
    r_var = float(np.sum((r - r.mean(axis=1, keepdims=True)) ** 2))

    def design(names: Sequence[str]) -> FloatArray:
        return _blockdiag([np.column_stack([np.ones(nt)] + [c_ for g in names
                                                           for _, c_ in groups_x[i][g]])
                           for i in range(n_dir)])

    b = r.ravel()
    alone, unique, gains, sse_lin, coef_lin = _family_shares(design, b, r_var)
    sig = _significant_families(gains, alone, groups_x, n_dir, b.size,
                                max(sse_noise / max(nt, 1), 1e-300), max(r_var, 1e-300),
                                sse_lin)
    elastic_kind = _elastic_kind(design, groups_x, b, n_dir)
    # linear changes (relative to nominal) from the linear fit, direction-averaged
    per = 3  # [1, u, v] per direction
    dk = float(np.mean([coef_lin[per * i + 1] / k_arr[i] for i in range(n_dir)]))
    dc = float(np.mean([coef_lin[per * i + 2] / c_arr[i] if c_arr[i] else 0.0
                        for i in range(n_dir)]))
    e_slope, k_slope, ratio, n_cycles = _cycle_summary(uf, f, v, k_arr, c_arr, fs_hz)
    return DeviceEvidence(component, float(share), float(noise_share), alone, unique, tuple(sig),
                          elastic_kind, dk, dc, e_slope, k_slope, ratio, n_cycles)


def _family_shares(design: Callable[[Sequence[str]], FloatArray], b: FloatArray, r_var: float
                   ) -> tuple[dict[str, float], dict[str, float], dict[str, float], float,
                              FloatArray]:
    """Each family's share of the residual alone and uniquely, its gain, the linear fit.

    Linear families are judged on the whole residual, nonlinear ones on what the linear
    terms leave.
    """
    sse_lin, coef_lin = _sse(design(["stiffness", "damping"]), b)
    nonlin = ("friction", "hysteresis", "elastic")
    sse_all, _ = _sse(design(["stiffness", "damping", *nonlin]), b)
    base = max(r_var, 1e-300)
    alone: dict[str, float] = {}
    unique: dict[str, float] = {}
    gains: dict[str, float] = {}
    sse_none, _ = _sse(design([]), b)
    for g in ("stiffness", "damping"):
        others = [x for x in ("stiffness", "damping") if x != g]
        s_without, _ = _sse(design(others), b)
        alone[g] = float(np.clip((sse_none - _sse(design([g]), b)[0]) / base, 0, 1))
        unique[g] = float(np.clip((s_without - sse_lin) / base, 0, 1))
        gains[g] = s_without - sse_lin
    for g in nonlin:
        s_g, _ = _sse(design(["stiffness", "damping", g]), b)
        # a nonlinear family is judged on what the linear terms leave
        alone[g] = float(np.clip((sse_lin - s_g) / max(sse_lin, 1e-300), 0, 1))
        s_wo, _ = _sse(design(["stiffness", "damping", *[x for x in nonlin if x != g]]), b)
        unique[g] = float(np.clip((s_wo - sse_all) / max(sse_lin, 1e-300), 0, 1))
        gains[g] = sse_lin - s_g
    return alone, unique, gains, sse_lin, coef_lin


def _significant_families(gains: dict[str, float], alone: dict[str, float],
                          groups_x: Sequence[dict], n_dir: int, n_obs: int,
                          noise_level: float, base: float, sse_lin: float) -> list[str]:
    """Families whose gain beats ``p ln N`` noise variances and 10 % of what it is judged on.

    Largest share alone first.
    """
    sig = []
    for g, gain in gains.items():
        p = sum(len(groups_x[i][g]) for i in range(n_dir))
        ref = base if g in ("stiffness", "damping") else sse_lin
        if gain > p * np.log(n_obs) * noise_level and gain > 0.1 * ref:
            sig.append(g)
    sig.sort(key=lambda g: -alone[g])
    return sig


def _cycle_summary(uf: FloatArray, f: FloatArray, v: FloatArray, k: FloatArray,
                   c: FloatArray, fs_hz: float) -> tuple[float, float, float, int]:
    """Slopes of excess energy and secant stiffness over amplitude, energy ratio, cycles."""
    feats = [cycle_features(uf[i], f[i], v[i], float(k[i]), float(c[i]), fs_hz)
             for i in range(uf.shape[0])]
    amp = np.concatenate([x.amplitude for x in feats])
    cf = CycleFeatures(amp, np.concatenate([x.energy_excess for x in feats]),
                       np.concatenate([x.energy_nominal for x in feats]),
                       np.concatenate([x.k_secant_ratio for x in feats]),
                       np.concatenate([x.rate_hz for x in feats]))
    e_slope, k_slope = cf.slopes()
    e_nom = float(np.sum(cf.energy_nominal))
    ratio = float(np.sum(cf.energy_excess) / e_nom) if e_nom > 0 else float("nan")
    return e_slope, k_slope, ratio, int(amp.size)


def _elastic_kind(design, groups_x, b: FloatArray, n_dir: int) -> str:
    """hardening, softening or gap: what the fitted elastic backbone does with amplitude."""
    A = design(["stiffness", "damping", "elastic"])
    _, coef = _sse(A, b)
    # evaluate the elastic part of direction 0's backbone at its 99th percentile drift
    cols0 = groups_x[0]
    n_lin = 1 + len(cols0["stiffness"]) + len(cols0["damping"])
    n_el = len(cols0["elastic"])
    c_el = coef[n_lin:n_lin + n_el]
    u_grid = np.linspace(0.0, 1.0, 50)  # in units of A99, where the columns were scaled
    a99 = 1.0
    shapes = np.column_stack([u_grid**3, u_grid * np.abs(u_grid),
                              0.5 * np.tanh(u_grid / 0.5)]
                             + [np.maximum(u_grid - g, 0.0) for g in (0.2, 0.4, 0.6, 0.8)])
    g_el = shapes @ c_el * a99
    # the tanh column adds linear stiffness at small u: compare the secant at the top of the
    # range with the tangent at the origin
    k0 = c_el[2] * 1.0  # d/du of 0.5 tanh(u / 0.5) at 0 is 1
    top = g_el[-1] - k0 * u_grid[-1]
    # a dead zone explains it as well as the smooth columns -> gap
    dead_only = design(["stiffness", "damping"])
    dz = [np.column_stack([c_ for name, c_ in groups_x[i]["elastic"] if name.startswith("dead")])
          for i in range(n_dir)]
    smooth = [np.column_stack([c_ for name, c_ in groups_x[i]["elastic"]
                               if not name.startswith("dead")]) for i in range(n_dir)]
    sse_dz = _sse(np.hstack([dead_only, _blockdiag(dz)]), b)[0]
    sse_sm = _sse(np.hstack([dead_only, _blockdiag(smooth)]), b)[0]
    if top > 0 and sse_dz <= 0.8 * sse_sm:
        return "gap"
    return "hardening" if top > 0 else "softening"


def _blockdiag(blocks: list[FloatArray]) -> FloatArray:
    rows = [np.hstack([blocks[i] if j == i else np.zeros((blocks[i].shape[0], blocks[j].shape[1]))
                       for j in range(len(blocks))]) for i in range(len(blocks))]
    return np.vstack(rows)
