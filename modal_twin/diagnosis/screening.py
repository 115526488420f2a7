"""Cheap screening of candidate effects on residual force-state maps (Eq. (20) of [003]).

At each component whose drift ``u`` and force ``f`` are measured (isolators with load
cells, Sec. 2 of [004]), the residual restoring force of the nominal linear law is

    r(t) = f(t) - (k u(t) + c u'(t))

and its map over (u, u') shows what is missing: a loop that encloses area is a missing
internal state (hysteresis, friction), an odd function of ``u`` a stiffness nonlinearity,
a jump at velocity reversal friction, a linear map a wrong ``k`` or ``c``, and noise alone
nothing. Each candidate law of :mod:`modal_twin.models.effects` is driven along the
measured (u, u') for a small grid of parameters; its residual shape
``g = f_law(u, u') - (k u + c u')`` enters ONE least-squares fit together with the linear
terms (``r ~ a u + b u' + alpha g``: fitting the linear part first and the residual second
picks wrong terms). The score of a candidate is the share of the measured force variance
it explains beyond the linear terms; the best grid point gives its starting parameters.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.diagnosis.evidence import drift_state, velocity_cutoff
from modal_twin.diagnosis.restoring_force import state_derivatives
from modal_twin.errors import ModalTwinError
from modal_twin.models.devices import Device
from modal_twin.models.effects import EFFECT_LAWS, effect_device
from modal_twin.models.structure_yaml import DeviceSpec

__all__ = ["ScreenedCandidate", "drift_velocity", "parameter_grid", "screen_components"]


@dataclass(frozen=True, slots=True)
class ScreenedCandidate:
    """A candidate effect at a component after screening."""

    component: str
    law: str
    params: dict[str, float]
    score: float  # share of the measured force variance explained (linear terms + law)
    gain: float  # share explained beyond the linear terms alone
    linear_share: float  # share explained by the linear terms alone (k, c error)
    residual_share: float  # share of force variance the nominal law leaves
    alpha: float  # fitted scale of the law's residual shape (1 = right magnitude)
    evidence: str = ""
    extra: dict[str, float] = field(default_factory=dict)


def parameter_grid(law: str, u_max: float, f_max: float, k: float, weight: float
                   ) -> list[dict[str, float]]:
    """Return the starting grid of a law's parameters, scaled to the measured drift and force."""
    if law == "stick_slip":
        fk = [0.4 * f_max, 0.6 * f_max, 0.8 * f_max]
        return [{"Fs": r * a, "Fk": a} for a in fk for r in (1.0, 1.5)]
    if law == "regularised_friction":
        fk = [0.4 * f_max, 0.6 * f_max, 0.8 * f_max]
        return [{"Fs": r * a, "Fk": a, "kp": kp, "v_s": 0.05, "v_reg": 0.005} for a in fk
                for r in (1.0, 1.5) for kp in (0.0, 0.3)]
    if law == "bilinear":
        return [{"ub": g * u_max, "ratio": r} for g in (0.2, 0.4, 0.6) for r in (0.5, 0.75)]
    if law == "smooth_bilinear":  # a rounded knee (n = 2), nearer the origin than a sharp one
        return [{"ub": g * u_max, "ratio": r, "n": 2.0} for g in (0.1, 0.2, 0.4)
                for r in (0.3, 0.6)]
    if law == "bilinear_hysteretic":  # yielding, and a stiff slider beside a soft spring
        return ([{"ub": g * u_max, "ratio": r} for g in (0.2, 0.4, 0.6) for r in (0.5, 0.75)]
                + [{"k": 10.0 * k, "ratio": r, "ub": g * u_max} for g in (0.005, 0.02)
                   for r in (0.03, 0.1)])
    if law == "bouc_wen":  # one circular yield surface (Eq. (10) of [004]) first, then
        # each direction yielding on its own (two orthogonal dampers): the measured force
        # tells them apart where both directions yield (a tie keeps the first)
        return [{"uy": g * u_max, "alpha": a, **unc} for unc in ({}, {"uncoupled": 1.0})
                for g in (0.2, 0.4, 0.6) for a in (0.05, 0.5)]
    if law == "iwan":  # microslip: full slip within the drift seen or beyond it; each
        # direction with the nominal anisotropy, then one joint in x and y (a tie keeps the
        # first)
        return [{"uy": g * u_max, "alpha": a, **iso} for iso in ({}, {"isotropic": 1.0})
                for g in (0.5, 1.0, 2.0) for a in (0.1, 0.4)]
    if law == "cubic":  # Duffing, and a stiffer power (the shape's scale is fitted)
        u = max(u_max, 1e-9)
        return [{"k3": s * 0.3 * k / u ** (m - 1.0), "m": m} for s in (-1.0, 1.0)
                for m in (3.0, 5.0)]
    if law == "maxwell":  # the component's dashpot behind a spring: relaxation times
        return [{"tau": tau} for tau in (0.003, 0.01, 0.03, 0.1)]
    if law == "gap":  # a stop beside the component's own spring-dashpot (kp = 1): on
        # both sides, or on one (the other clearance beyond every drift seen)
        far = 10.0 * u_max
        return [{"g": gp, "g_neg": gn, "k": r * k, "kp": 1.0}
                for g in (0.3 * u_max, 0.5 * u_max, 0.7 * u_max) for r in (0.5, 2.0)
                for gp, gn in ((g, g), (g, far), (far, g))]
    return [{}]


# the registry's laws with a relative form, but the nominal law itself
SCREEN_LAWS = tuple(law for law in EFFECT_LAWS if law != "linear")


def drift_velocity(u: FloatArray, fs_hz: float, cutoff_hz: float) -> FloatArray:
    """Return the velocity of each row of ``u`` below ``cutoff_hz``.

    Spectral, even-extended: :func:`~modal_twin.diagnosis.restoring_force.state_derivatives`.
    """
    f_max = min(cutoff_hz, 0.45 * fs_hz)
    return np.vstack([state_derivatives(row, fs_hz, f_max_hz=f_max)[1]
                      for row in np.atleast_2d(u)])


def screen_components(
    drifts: Mapping[str, FloatArray],
    forces: Mapping[str, FloatArray],
    sites: Mapping[str, DeviceSpec],
    weights: Mapping[str, float],
    fs_hz: float,
    *,
    laws: tuple[str, ...] = SCREEN_LAWS,
    cutoff_hz: float | None = None,
    input_shares: Mapping[str, tuple[FloatArray, FloatArray]] | None = None,
) -> list[ScreenedCandidate]:
    """Screen every (component, law) on the measured force-state data.

    Parameters
    ----------
    drifts, forces : mapping component -> (n_dir, nt) array
        Measured drift (m) and force (N) in x and y (an isolator) or z (a suspension).
    sites : mapping component -> DeviceSpec
        Nominal linear law of each component (``k``, ``c``).
    weights : mapping component -> float
        Carried weight, N (for friction laws).
    fs_hz : float
    cutoff_hz : float, optional
        Low-pass applied to the drift before differentiating it (default: from the drift's
        own spectrum, :func:`~modal_twin.diagnosis.evidence.velocity_cutoff`).
    input_shares : mapping component -> (u_in, v_in), optional
        The input's own part of a drift and of its rate (a primary suspension's stroke
        holds the track): only the rest is differentiated
        (:func:`~modal_twin.diagnosis.evidence.drift_state`).

    Returns
    -------
    list of ScreenedCandidate, best first (one per component and law: the best grid point),
    plus one ``linear`` candidate per component (a k / c error).
    """
    out: list[ScreenedCandidate] = []
    for name, spec in sites.items():
        if name not in drifts or name not in forces:
            continue
        u = np.asarray(drifts[name], dtype=float)
        f = np.asarray(forces[name], dtype=float)
        share = (input_shares or {}).get(name)
        if share is None:
            v = drift_velocity(u, fs_hz, cutoff_hz or velocity_cutoff(u, fs_hz))
        else:
            v = drift_state(u, fs_hz, cutoff_hz, share)[1]
        n_dir = u.shape[0]  # 2 for an isolator (x, y), 1 for a vehicle's suspension (z)
        k = np.asarray(spec.k, float)[:n_dir, None]
        c = np.asarray(spec.c, float)[:n_dir, None]
        r = (f - (k * u + c * v)).ravel()  # residual restoring force, Eq. (20) of [003]
        f_var = float(np.sum((f - f.mean(axis=1, keepdims=True)) ** 2))
        if f_var <= 0:
            continue
        lin = np.column_stack([*_per_direction(u), *_per_direction(v), np.ones(r.size)])
        _, sse_lin = _lstsq(lin, r)
        sse0 = float(r @ r)
        lin_share = (sse0 - sse_lin) / f_var
        res_share = sse0 / f_var
        ev = f"nominal law leaves {100 * res_share:.1f} % of the force variance at {name}"
        out.append(ScreenedCandidate(name, "linear", {}, lin_share, 0.0, lin_share, res_share, 1.0,
                                     f"{ev}; linear k/c change explains {100 * lin_share:.1f} %"))
        u_max = float(np.quantile(np.abs(u), 0.99))
        f_max = float(np.quantile(np.abs(f), 0.99))
        for law in laws:
            best: ScreenedCandidate | None = None
            for params in parameter_grid(law, u_max, f_max, float(k.mean()),
                                         float(weights.get(name, 0.0))):
                try:
                    dev = effect_device(spec, law, params, weight=float(weights.get(name, 0.0)))
                    g = (_respond(dev, u, v, 1.0 / fs_hz) - (k * u + c * v)).ravel()
                except (ModalTwinError, ValueError):
                    continue
                if not np.all(np.isfinite(g)) or not np.any(g):
                    continue
                coef, sse = _lstsq(np.column_stack([lin, g]), r)
                gain = (sse_lin - sse) / f_var
                if best is None or gain > best.gain:
                    start = dict(params)
                    if law == "cubic":  # the shape is linear in k3: take the fitted scale
                        start["k3"] *= float(coef[-1])
                    best = ScreenedCandidate(
                        name, law, start, lin_share + gain, gain, lin_share, res_share,
                        float(coef[-1]), f"{ev}; {law} explains {100 * gain:.1f} % more "
                        f"(shape scale {coef[-1]:.2f})")
            if best is not None:
                out.append(best)
    return sorted(out, key=lambda s: (-s.score, s.gain))


def _per_direction(u: FloatArray) -> list[FloatArray]:
    """One column per direction: that direction's history, zeros over the others."""
    n, nt = u.shape
    cols = []
    for i in range(n):
        col = np.zeros(n * nt)
        col[i * nt:(i + 1) * nt] = u[i]
        cols.append(col)
    return cols


def _respond(dev: Device, u: FloatArray, v: FloatArray, dt: float) -> FloatArray:
    """Return the force of ``dev`` along ``u`` (a 2-direction law on one: the other at rest).

    ``dt``: the sample interval (a rate law integrates over it).
    """
    n = u.shape[0]
    if dev.n_dir > n:
        pad = np.zeros((dev.n_dir - n, u.shape[1]))
        return dev.respond(np.vstack([u, pad]), np.vstack([v, pad]), dt=dt).f[:n]
    return dev.respond(u, v, dt=dt).f


def _lstsq(A: FloatArray, b: FloatArray) -> tuple[FloatArray, float]:
    scale = np.linalg.norm(A, axis=0)
    scale[scale == 0] = 1.0
    coef, *_ = np.linalg.lstsq(A / scale, b, rcond=None)
    coef = coef / scale
    res = b - A @ coef
    return coef, float(res @ res)
