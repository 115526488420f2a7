"""Fit a candidate effect by full simulation on a training record, judge it on another.

The plant with the candidate law at its component is simulated on the measured inputs of
the training record; the law's parameters (in a transformed, bounded space) minimise the
whitened residual of the measured channels with ``scipy.optimize.least_squares``: each
channel in the unit the judge counts its error in (:func:`channel_scale`: its RMS times
the noise floor of the record's noise model and the model-form tolerance together), so
that the fit's optimum is the judge's (a near-noise-free force channel beside noisy
accelerometers weighs by what it can tell).
The fitted plant is then run on a record not used for fitting, and ranked by that held-out
error; the Bayesian information criterion ``BIC = N ln(SSE / N) + p ln N`` on the training
record guards against over-fitting (``N`` counts decimated samples).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import partial
from types import SimpleNamespace
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from modal_twin._types import FloatArray
from modal_twin.diagnosis.noise import whitening_sigma
from modal_twin.diagnosis.record import Record
from modal_twin.errors import ModalTwinError, OptionError
from modal_twin.models.effects import EffectSpec
from modal_twin.models.loading import ModelFactory
from modal_twin.models.plant import Plant
from modal_twin.twin.reuse import simulator_for
from modal_twin.twin.simulator import Simulator

__all__ = ["FittedEffect", "SimulationObjective", "channel_scale", "fit_effect", "judge_fit",
           "normalised_residual", "record_nmse", "simulate_record", "threshold_start",
           "warm_up_kernels"]

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class FittedEffect:
    """A candidate after its fit: parameters, errors before / after, information criterion."""

    effect: EffectSpec
    n_params: int
    train_nmse_pct: float  # mean NMSE over the channels, training record
    test_nmse_pct: float  # the same on the held-out record
    test_nmse_nominal_pct: float  # nominal model on the held-out record
    bic: float
    n_simulations: int
    seconds: float
    message: str = ""
    std: dict[str, float] = field(default_factory=dict)  # 1-sigma of each parameter
    at_bound: tuple[str, ...] = ()  # fitted parameters that ended on a bound
    # filled by the diagnosis's judgement (diagnosis.judge)
    family: str = ""
    place: str = ""
    flags: tuple[str, ...] = ()  # why --auto must not write it (bound, implausible value)
    rejected: str = ""  # the record it made worse, when it did
    records: tuple[tuple[str, float, float, float, float, float], ...] = ()  # (record,
    # NRMSE before, after, after / noise floor median, whitened RMS before, after), NRMSE as
    # the RMS over channels, the whitened RMS as in noise.ErrorFigures.score
    behaviour: str = ""  # beside the family: the law fitted and what it does (behaviour.py)

    def parameter_text(self) -> str:
        """Format ``name=value ±std`` per parameter.

        "not determined" where the data do not fix it (no finite standard deviation, or one
        larger than the value).
        """
        out = []
        for k, v in self.effect.params.items():
            s = self.std.get(k)
            if s is None:
                out.append(f"{k}={v:.4g}")
            elif np.isfinite(s) and s <= abs(v):
                out.append(f"{k}={v:.4g}±{s:.2g}")
            else:
                out.append(f"{k}={v:.4g} (not determined)")
        return ", ".join(out)

    def family_text(self) -> str:
        """Return the family reported, with the law fitted (and what it does) beside it."""
        return f"{self.family} ({self.behaviour or self.effect.law})"

    @property
    def error_ratio(self) -> float:
        """Held-out error of the nominal model over that of the fitted candidate."""
        return self.test_nmse_nominal_pct / max(self.test_nmse_pct, 1e-12)


def simulate_record(plant: Plant, rec: Record) -> FloatArray:
    """Plant channels (rows of ``rec.channel_names`` it has) driven by ``rec.inputs``."""
    have = [n for n in plant.input_names if n in rec.input_names]
    if not have:
        msg = (f"record {rec.source!r}: none of the model's inputs {list(plant.input_names)} "
               f"is measured (its inputs: {list(rec.input_names)})")
        raise OptionError(msg)
    ag = plant.input_matrix(rec.input_names, rec.inputs)  # unmeasured inputs: zero
    _say_missing(rec.source, [n for n in plant.input_names if n not in have])
    sim = simulator_for(plant.system, 1.0 / rec.fs_hz)  # built once per model content
    y = plant.measure(sim.step_block(ag), plant.delay_line(rec.fs_hz))
    names = plant.channel_names
    return y[[names.index(n) for n in rec.channel_names]]


def warm_up_kernels(plant: Plant, fs_hz: float = 1000.0) -> float:
    """Compile the numba kernels a diagnosis of ``plant`` runs; return the seconds it took.

    The simulator as :func:`simulate_record` runs it (without modal histories;
    :meth:`~modal_twin.twin.simulator.Simulator.warm_up`: two samples at rest), a device law
    evaluated once (:meth:`~modal_twin.models.devices.base.Device.evaluate`: the simulator
    of a candidate's plant asks its law for the stiffness at rest) and driven along a
    history (:meth:`~modal_twin.models.devices.base.Device.respond`, as the evidence and
    the behaviour labels drive the laws), and the stop operator of the evidence's
    hysteresis terms (:func:`.restoring_force.stop_operator`). Every law is a branch of
    those kernels, so one call serves every candidate. Tens of seconds on a cold numba cache,
    about a second from the disk cache; a node calls it before it says ready
    (:func:`modal_twin.io.ros.compile_kernels`) so that its first request does not wait.
    """
    from modal_twin.diagnosis.restoring_force import stop_operator
    from modal_twin.models.devices.linear import LinearDevice

    t0 = time.perf_counter()
    Simulator(plant.system, 1.0 / fs_hz, modal_histories=False).warm_up()
    law = LinearDevice([1.0], [0.0])
    law.evaluate(np.zeros(2), np.zeros(2), law.initial_state())
    law.respond(np.zeros((1, 2)))
    stop_operator(np.zeros(2), 1.0)
    return time.perf_counter() - t0


_SAID: set[tuple[str, tuple[str, ...]]] = set()


def _say_missing(source: str, missing: list[str]) -> None:
    """Log once per record that some model inputs are not measured (taken as zero)."""
    key = (source, tuple(missing))
    if missing and key not in _SAID:
        _SAID.add(key)
        log.info("record %s: model inputs %s not measured, taken as zero", source, missing)


def record_nmse(pred: FloatArray, rec: Record) -> FloatArray:
    """NMSE (percent) per channel of a simulation of ``rec`` over its scored samples."""
    meas, p = rec.scored, pred[:, rec.skip:]
    return 100.0 * np.var(p - meas, axis=1) / np.maximum(np.var(meas, axis=1), 1e-300)


# law -> (parameter names, x -> params, params -> x0, lower, upper)
Transform = tuple[list[str], Callable[[FloatArray], dict[str, float]],
                  Callable[[dict[str, float]], FloatArray], FloatArray, FloatArray]


def channel_scale(rec: Record) -> FloatArray:
    """Per channel of ``rec``, the unit of the fits' residual: the judge's sigma, (n_ch, 1).

    ``RMS(measured) * sigma`` with ``sigma = sqrt(floor^2 + MODEL_FORM^2)``
    (:func:`.noise.whitening_sigma`) and ``floor`` the record's noise model
    (``rec.noise_floor``, :func:`.judge.record_noise_floors`): the residual so divided,
    squared and averaged over a channel's samples, is the square of that channel's whitened
    error (:attr:`.noise.ErrorFigures.whitened`), so the sum the fits minimise is, per record,
    the judge's figure (:attr:`.noise.ErrorFigures.score`) squared times the samples kept. The
    one place the fits' channel weights are made. A record without a noise model is taken
    as noise-free (every channel at the tolerance alone: weighed by its RMS).
    """
    rms = np.sqrt(np.mean(rec.scored**2, axis=1))
    floor = np.zeros(rms.size) if rec.noise_floor is None else rec.noise_floor
    return np.maximum(rms * whitening_sigma(floor), 1e-300)[:, None]


def normalised_residual(plant: Plant, rec: Record, decimate: int, scale: FloatArray
                        ) -> FloatArray:
    """Return the whitened residual of ``plant`` on ``rec``: the vector the fits minimise.

    Each channel is divided by ``scale`` (:func:`channel_scale`: in units of what its error
    may be), every ``decimate``-th sample is kept, and the result is flattened (the samples
    dropped are never differenced: the same values, a fifth of the work).
    """
    pred = simulate_record(plant, rec)
    return ((pred[:, rec.skip::decimate] - rec.scored[:, ::decimate]) / scale).ravel()


Records = Record | Sequence[Record]


def as_records(rec: Records) -> tuple[Record, ...]:
    """One record or several as a tuple (the first is the training record proper)."""
    return (rec,) if isinstance(rec, Record) else tuple(rec)


class SimulationObjective:
    """Build the vector ``least_squares`` minimises for the plant ``build(x)``.

    :func:`normalised_residual` on the training record(s), concatenated (each record's
    channels whitened by its own noise model, :func:`channel_scale`, so a low-level record
    weighs by its own noise). A trial that fails to simulate (unstable, no convergence)
    returns a large penalty instead of stopping the fit (an error 1000 times each channel's
    RMS, whitened); ``n`` counts the simulations.
    """

    def __init__(self, build: Callable[[FloatArray], Plant], rec: Records, decimate: int
                 ) -> None:
        self.build, self.recs, self.decimate = build, as_records(rec), decimate
        self.rec = self.recs[0]
        self.scales = [channel_scale(r) for r in self.recs]
        self.penalty = np.concatenate([
            np.broadcast_to(1e3 * np.sqrt(np.mean(r.scored**2, axis=1))[:, None] / s,
                            r.scored[:, ::decimate].shape).ravel()
            for r, s in zip(self.recs, self.scales, strict=True)])
        self.size = self.penalty.size
        self.n = 0

    def __call__(self, x: FloatArray) -> FloatArray:
        """Return the residual of the plant ``build(x)``; a failed simulation the penalty."""
        self.n += 1
        try:
            plant = self.build(x)
            return np.concatenate([normalised_residual(plant, r, self.decimate, s)
                                   for r, s in zip(self.recs, self.scales, strict=True)])
        except ModalTwinError as err:
            log.debug("trial %s refused: %s", x, err)
            return self.penalty.copy()


# bounds that are a law's extension switched off, not a fit stopped short: at them the law
# is its classical form (no spring beside the slider, no speed dependence, no static
# excess; a linear contact, a stop on one side only); -1 lower, +1 upper bound
SWITCHED_OFF: dict[str, dict[str, int]] = {
    "stick_slip": {"kp": -1, "v_s": -1, "Fs": -1},
    "regularised_friction": {"kp": -1, "Fs": -1},
    "gap": {"n": -1, "g_neg": 1, "g": 1},
    "cubic": {"m": -1},
    "elastic_mount": {"n": 1},  # the softening mount's sharpest knee: the bilinear spring
}
# bounds that are a physical end, not a fit stopped short, though not the classical form:
# a slider with no dashpot beside it (a sliding bearing's friction is its whole damping)
PHYSICAL_ENDS: dict[str, dict[str, int]] = {"regularised_friction": {"c_factor": -1}}
# of the switched-off bounds, the optional extensions of a law (fitted once its classical form is)
EXTENSIONS: dict[str, tuple[str, ...]] = {"stick_slip": ("kp", "v_s"),
                                          "regularised_friction": ("kp",), "gap": ("n",)}
# laws whose force has a threshold (a friction force, a yield drift, a clearance) and the
# parameters that hold it (each the log of the threshold in the bounded space): where the
# threshold lies beyond what the record reaches the law is linear and the residual flat in
# it, so a local fit started there stays there (:func:`threshold_start`)
THRESHOLDS: dict[str, tuple[str, ...]] = {
    "stick_slip": ("Fk",), "regularised_friction": ("Fk",), "bilinear": ("ub",),
    "smooth_bilinear": ("ub",), "bilinear_hysteretic": ("ub",), "bouc_wen": ("uy",),
    "gap": ("g", "g_neg"),
}
N_THRESHOLD_STARTS = 6  # grid points over each threshold's bounded range


def judge_fit(effect: EffectSpec, fitted: Plant, nominal: Plant, sol: Any, n_params: int,
              train: Records, test: Record, objective: SimulationObjective, t0: float,
              std: dict[str, float]) -> FittedEffect:
    """Return the :class:`FittedEffect` of a finished fit.

    It holds the errors of the fitted and the nominal plant on both records and the BIC
    ``N ln(SSE / N) + p ln N`` of the training residual.
    """
    train = as_records(train)[0]
    N = sol.fun.size
    sse = float(sol.fun @ sol.fun)
    mask = np.asarray(getattr(sol, "active_mask", np.zeros(len(std))))
    off = {**SWITCHED_OFF.get(effect.law, {}), **PHYSICAL_ENDS.get(effect.law, {})}
    at_bound = tuple(n for n, a in zip(std, mask, strict=False)
                     if a != 0 and off.get(n) != int(a))
    return FittedEffect(
        effect, n_params,
        float(np.mean(record_nmse(simulate_record(fitted, train), train))),
        float(np.mean(record_nmse(simulate_record(fitted, test), test))),
        float(np.mean(record_nmse(simulate_record(nominal, test), test))),
        float(N * np.log(max(sse, 1e-300) / N) + n_params * np.log(N)), objective.n + 3,
        time.perf_counter() - t0, str(sol.message), std, at_bound)


def _t_stick_slip(start: dict[str, float], k: float) -> Transform:
    """With a spring beside it and a speed-dependent limit."""
    lf = np.log(start["Fk"])
    return (["Fk", "Fs", "kt_factor", "kp", "v_s"],
            lambda x: {"Fk": float(np.exp(x[0])), "Fs": float(np.exp(x[0]) * x[1]),
                       "kt_factor": float(np.exp(x[2])), "kp": float(x[3]),
                       "v_s": float(10.0 ** x[4])},
            lambda p: np.array([np.log(p["Fk"]), p["Fs"] / p["Fk"],
                                np.log(p.get("kt_factor", 1.0)), p.get("kp", 0.0),
                                np.log10(p.get("v_s", 0.0) or 1e-4)]),
            np.array([lf - 3, 1.0, np.log(0.5), 0.0, -4.0]),
            np.array([lf + 3, 3.0, np.log(50.0), 1.5, 0.0]))


def _t_regularised_friction(start: dict[str, float], k: float) -> Transform:
    """Limit at rest and sliding, speeds, spring and share of the dashpot beside."""
    lf = np.log(start["Fk"])
    return (["Fk", "Fs", "kp", "v_s", "v_reg", "c_factor"],
            lambda x: {"Fk": float(np.exp(x[0])), "Fs": float(np.exp(x[0]) * x[1]),
                       "kp": float(x[2]), "v_s": float(10.0 ** x[3]),
                       "v_reg": float(10.0 ** x[4]), "c_factor": float(x[5])},
            lambda p: np.array([np.log(p["Fk"]), p["Fs"] / p["Fk"], p.get("kp", 0.0),
                                np.log10(p.get("v_s", 0.05)),
                                np.log10(p.get("v_reg", 0.005)), p.get("c_factor", 1.0)]),
            np.array([lf - 3, 1.0, 0.0, -3.0, -4.0, 0.0]),
            np.array([lf + 3, 3.0, 1.5, 0.0, -1.0, 3.0]))


def _t_bilinear(start: dict[str, float], k: float) -> Transform:
    """Fitted parameters of ``bilinear``."""
    lu = np.log(start["ub"])
    return (["ub", "ratio", "k"],
            lambda x: {"ub": float(np.exp(x[0])), "ratio": float(x[1]), "k": k * float(x[2])},
            lambda p: np.array([np.log(p["ub"]), p["ratio"], p.get("k", k) / k]),
            np.array([lu - 3, 0.02, 0.7]), np.array([lu + 3, 3.0, 1.3]))


def _t_smooth_bilinear(start: dict[str, float], k: float) -> Transform:
    """Fitted parameters of ``smooth_bilinear``: those of ``bilinear`` and the sharpness.

    log n from 0 (n = 1, the softest knee) to log 30 (all but the sharp bilinear).
    """
    lu = np.log(start["ub"])
    return (["ub", "ratio", "k", "n"],
            lambda x: {"ub": float(np.exp(x[0])), "ratio": float(x[1]), "k": k * float(x[2]),
                       "n": float(np.exp(x[3]))},
            lambda p: np.array([np.log(p["ub"]), p["ratio"], p.get("k", k) / k,
                                np.log(p.get("n", 2.0))]),
            np.array([lu - 3, 0.02, 0.7, 0.0]), np.array([lu + 3, 3.0, 1.3, np.log(30.0)]))


def _t_bilinear_hysteretic(start: dict[str, float], k: float) -> Transform:
    """Also a stiff slider beside a soft spring (friction)."""
    lu, lk = np.log(start["ub"]), np.log(start.get("k", k) / k)
    return (["ub", "ratio", "k"],
            lambda x: {"ub": float(np.exp(x[0])), "ratio": float(np.exp(x[1])),
                       "k": k * float(np.exp(x[2]))},
            lambda p: np.array([np.log(p["ub"]), np.log(p["ratio"]),
                                np.log(p.get("k", k) / k)]),
            np.array([lu - 4, np.log(0.005), min(lk, 0.0) + np.log(0.5)]),
            np.array([lu + 4, np.log(3.0), max(lk, 0.0) + np.log(30.0)]))


def _t_loop(flag: str, k_top: float, start: dict[str, float], k: float) -> Transform:
    """Yield (or full-slip) drift (log), alpha, stiffness and dashpot free: ``bouc_wen``, ``iwan``.

    With its dashpot free (a device whose viscous part changed). The form ``flag``
    (``uncoupled``: each direction yielding on its own; ``isotropic``: one joint in x and y)
    as started: chosen by the screening on the measured force, held in the fit, named (and
    counted) only where it is set. ``k_top``: the stiffness factor's upper bound.
    """
    lu = np.log(start["uy"])
    form = {flag: 1.0} if start.get(flag, 0.0) >= 0.5 else {}
    return (["uy", "alpha", "k", "c_factor", *form],
            lambda x: {"uy": float(np.exp(x[0])), "alpha": float(x[1]), "k": k * float(x[2]),
                       "c_factor": float(x[3]), **form},
            lambda p: np.array([np.log(p["uy"]), p.get("alpha", 0.2), p.get("k", k) / k,
                                p.get("c_factor", 1.0)]),
            np.array([lu - 3, 0.0, 0.7, 0.0]), np.array([lu + 3, 1.0, k_top, 3.0]))


def _t_cubic(start: dict[str, float], k: float) -> Transform:
    """Power spring ``k3 u |u|^(m-1) = sign k (|u| / u_h)^(m-1) u``: u_h, k, m free."""
    sign = 1.0 if start["k3"] >= 0 else -1.0
    m0 = float(start.get("m", 3.0))
    lu = np.log((k / max(abs(start["k3"]), 1e-300)) ** (1.0 / (m0 - 1.0)))

    def power(x: FloatArray) -> dict[str, float]:
        kk, m = k * float(x[1]), float(x[2])
        return {"k3": sign * kk / float(np.exp(x[0])) ** (m - 1.0), "k": kk, "m": m}

    def back(p: dict[str, float]) -> FloatArray:
        kk, m = p.get("k", k), p.get("m", 3.0)
        return np.array([np.log((kk / max(abs(p["k3"]), 1e-300)) ** (1.0 / (m - 1.0))),
                         kk / k, m])

    return (["k3", "k", "m"], power, back, np.array([lu - 4.0, 0.7, 2.0]),
            np.array([lu + 4.0, 1.3, 9.0]))


def _t_gap(start: dict[str, float], k: float) -> Transform:
    """Clearances on both sides and contact stiffness; kp as started."""
    lg, kp = np.log(start["g"]), float(start.get("kp", 0.0))
    lgn = np.log(start.get("g_neg", start["g"]))
    return (["g", "k", "g_neg", "n", "kp"],
            lambda x: {"g": float(np.exp(x[0])), "k": k * float(np.exp(x[1])),
                       "g_neg": float(np.exp(x[2])), "n": float(x[3]), "kp": kp},
            lambda p: np.array([np.log(p["g"]), np.log(p.get("k", k) / k),
                                np.log(p.get("g_neg", p["g"])), p.get("n", 1.0)]),
            np.array([lg - 3, np.log(0.02), lgn - 3, 1.0]),
            np.array([lg + 3, np.log(50.0), lgn + 3, 3.0]))


def _t_maxwell(start: dict[str, float], k: float) -> Transform:
    """Relaxation time (log), the parallel spring and the dashpot's scale."""
    return (["tau", "k", "c_factor"],
            lambda x: {"tau": float(10.0 ** x[0]), "k": k * float(x[1]),
                       "c_factor": float(x[2])},
            lambda p: np.array([np.log10(p.get("tau", 0.02)), p.get("k", k) / k,
                                p.get("c_factor", 1.0)]),
            np.array([-3.0, 0.7, 0.1]), np.array([0.5, 1.3, 5.0]))


def _t_linear(start: dict[str, float], k: float) -> Transform:
    """Fitted parameters of ``linear``."""
    return (["k", "ky", "c", "cy"],
            lambda x: {"k": k * float(x[0]), "ky": k * float(x[1]),
                       "c": float(x[2]) * start["c0"], "cy": float(x[3]) * start["c0"]},
            lambda p: np.array([p.get("k", k) / k, p.get("ky", k) / k,
                                p.get("c", start["c0"]) / start["c0"],
                                p.get("cy", start["c0"]) / start["c0"]]),
            np.array([0.2, 0.2, 0.0, 0.0]), np.array([5.0, 5.0, 20.0, 20.0]))


_TRANSFORMS: dict[str, Callable[[dict[str, float], float], Transform]] = {
    "stick_slip": _t_stick_slip,
    "regularised_friction": _t_regularised_friction,
    "bilinear": _t_bilinear,
    "smooth_bilinear": _t_smooth_bilinear,
    "bilinear_hysteretic": _t_bilinear_hysteretic,
    "bouc_wen": partial(_t_loop, "uncoupled", 1.3),
    "iwan": partial(_t_loop, "isotropic", 2.0),
    "cubic": _t_cubic,
    "gap": _t_gap,
    "linear": _t_linear,
    "maxwell": _t_maxwell,
}


def _transform(law: str, start: dict[str, float], k: float) -> Transform:
    """Fitted parameters of a law in a bounded space.

    Each law is refitted together with the component's own stiffness, the parameter that
    interacts with it (``kt_factor`` of friction, ``k`` of the others): adding friction or
    softening at a bearing changes what its linear stiffness should be.
    """
    make = _TRANSFORMS.get(law)
    if make is None:
        msg = f"no fit transform for law {law!r}"
        raise OptionError(msg)
    return make(start, k)


def fit_effect(
    factory: ModelFactory,
    component: str,
    law: str,
    start: dict[str, float],
    train: Records,
    test: Record,
    *,
    decimate: int = 5,
    max_nfev: int = 40,
) -> FittedEffect:
    """Fit ``law`` at ``component`` on ``train`` (starting at ``start``), judge on ``test``.

    Raises
    ------
    OptionError
        Unknown law or component; records without the plant's inputs.
    """
    t0 = time.perf_counter()
    spec = factory.sites.get(component)
    if spec is None:
        msg = f"unknown component {component!r}; components: {sorted(factory.sites)}"
        raise OptionError(msg)
    k = float(np.mean(spec.k))
    start = dict(start)
    if law == "linear":
        start.setdefault("c0", float(np.mean(spec.c)) or 1.0)
    names, to_params, to_x, lo, hi = _transform(law, start, k)
    x0 = np.clip(to_x(start), lo + 1e-9, hi - 1e-9)
    objective = SimulationObjective(
        lambda x: factory.plant([EffectSpec(component, law, to_params(x))]), train, decimate)
    # the screened start and, for a law with thresholds, the best of a grid over them: each
    # refined, the lower end kept (never worse than the screened start alone)
    starts = [x0]
    grid = threshold_start(objective, [names.index(n) for n in THRESHOLDS.get(law, ())
                                       if n in names], x0, lo, hi)
    if not np.array_equal(grid, x0):
        starts.append(grid)
    ends = [least_squares(objective, _classical_first(objective, law, names, xs, lo, hi,
                                                      max_nfev),
                          bounds=(lo, hi), diff_step=1e-3, max_nfev=max_nfev, x_scale="jac")
            for xs in starts]
    sol = min(ends, key=lambda e: float(e.cost))
    far = _extensions_at_far_bound(law, names, sol)
    if far:  # judged at its bound it could never be accepted: its classical form instead
        sol = _held_fit(objective, sol, far, [SWITCHED_OFF[law][names[i]] for i in far],
                        lo, hi, max_nfev)
    params = to_params(sol.x)
    effect = EffectSpec(component, law, {n: params[n] for n in names if n in params}
                        if law != "linear" else params)
    return judge_fit(effect, factory.plant([effect]), factory.plant(), sol, len(names), train,
                     test, objective, t0, _parameter_std(sol, to_params, names))


def _extensions_at_far_bound(law: str, names: list[str], sol: Any) -> list[int]:
    """Return the law's switchable extensions that ended at their far bound.

    Extensions of :data:`SWITCHED_OFF` at the bound opposite to their "off" one (a
    static-to-kinetic ratio run to its cap).
    """
    off = SWITCHED_OFF.get(law, {})
    mask = np.asarray(getattr(sol, "active_mask", np.zeros(len(names))))
    return [i for i, (n, a) in enumerate(zip(names, mask, strict=False))
            if n in off and a != 0 and int(a) != off[n]]


def _held_fit(objective: SimulationObjective, sol: Any, held: list[int], side: list[int],
              lo: FloatArray, hi: FloatArray, max_nfev: int) -> Any:
    """Refit ``sol`` with the coordinates ``held`` switched off, the others free.

    Held at their ``side`` bound (-1 lower, +1 upper), from ``sol.x``.

    Returns a solution on the full coordinates (the held columns of its Jacobian zero, so
    their standard deviation reads "not determined"; their active mask the "off" side, so
    they are not flagged as stopped at a bound).
    """
    x = np.array(sol.x, float)
    for i, a in zip(held, side, strict=True):
        x[i] = lo[i] if a < 0 else hi[i]
    free = np.ones(x.size, bool)
    free[held] = False
    if not free.any():
        return sol
    x[free] = np.clip(x[free], lo[free] + 1e-9, hi[free] - 1e-9)
    r = _fit_free(objective, x, free, lo, hi, max_nfev)
    x[free] = r.x
    jac = np.zeros((r.fun.size, x.size))
    jac[:, free] = r.jac
    mask = np.zeros(x.size, int)
    mask[free] = r.active_mask
    mask[held] = side
    return SimpleNamespace(x=x, fun=r.fun, jac=jac, active_mask=mask, cost=r.cost,
                           message=f"{r.message} (extensions {held} switched off: they ran "
                                   "to their far bound)")


def threshold_start(objective: Callable[[FloatArray], FloatArray], axes: Sequence[int],
                    x0: FloatArray, lo: FloatArray, hi: FloatArray,
                    n: int = N_THRESHOLD_STARTS) -> FloatArray:
    """Return the best start of a law with thresholds: ``x0`` or a point of a grid over them.

    A bounded global stage before the local refine: each threshold coordinate in ``axes``
    in turn takes ``n`` values spread evenly over the inside of its bounds (the others at
    the best point so far), and the point of least ``sum(objective(x)^2)`` is kept; ``x0``
    (the screened start) stays unless a grid point is lower. One simulation per point
    (``n`` per threshold); nothing is evaluated when ``axes`` is empty.
    :func:`fit_effect` refines from both ``x0`` and this point and keeps the lower end: a
    lower cost at a grid point (the other parameters held at their start) need not lie in
    the basin of the lowest minimum.
    """
    x0 = np.asarray(x0, float)
    if not len(axes):
        return x0
    best, best_cost = x0, float(np.sum(objective(x0) ** 2))
    for i in axes:
        span = hi[i] - lo[i]
        for t in lo[i] + span * (np.arange(n) + 0.5) / n:
            x = best.copy()
            x[i] = t
            cost = float(np.sum(objective(x) ** 2))
            if cost < best_cost:
                best, best_cost = x, cost
    return best


def _classical_first(objective: SimulationObjective, law: str, names: list[str],
                     x0: FloatArray, lo: FloatArray, hi: FloatArray,
                     max_nfev: int) -> FloatArray:
    """Fit the law's classical form first, its extensions held switched off.

    Extensions (:data:`SWITCHED_OFF`) that start at their "off" bound have no gradient
    there; freeing them from the first step lets the optimizer wander. The start of the
    full fit is the classical optimum (``x0`` unchanged when nothing starts off).
    """
    off = {n: SWITCHED_OFF[law][n] for n in EXTENSIONS.get(law, ())}
    held = np.array([i < x0.size and names[i] in off and
                     (x0[i] - lo[i] if off[names[i]] < 0 else hi[i] - x0[i])
                     <= 1e-6 * (hi[i] - lo[i]) for i in range(x0.size)])
    if not held.any() or held.all():
        return x0
    free = ~held
    out = x0.copy()
    out[free] = _fit_free(objective, x0, free, lo, hi, max_nfev).x
    return out


def _fit_free(objective: Callable[[FloatArray], FloatArray], x: FloatArray,
              free: np.ndarray, lo: FloatArray, hi: FloatArray, max_nfev: int) -> Any:
    """Return the least-squares fit over the coordinates ``free`` of ``x``.

    The others are held at ``x``; the fit starts at ``x[free]`` and its result is on the
    free coordinates.
    """

    def sub(xs: FloatArray) -> FloatArray:
        xf = x.copy()
        xf[free] = xs
        return objective(xf)

    return least_squares(sub, x[free], bounds=(lo[free], hi[free]), diff_step=1e-3,
                         max_nfev=max_nfev, x_scale="jac")


def _parameter_std(sol: object, to_params: Callable[[FloatArray], dict[str, float]],
                   names: list[str]) -> dict[str, float]:
    """Return the 1-sigma of the parameters from the Gauss-Newton covariance s^2 (J'J)^-1.

    The covariance is mapped through the transform (first order). Samples are treated as
    independent, so this is a lower bound where the residual is correlated in time.
    """
    J = np.asarray(sol.jac)  # type: ignore[attr-defined]
    x = np.asarray(sol.x)  # type: ignore[attr-defined]
    dof = max(J.shape[0] - J.shape[1], 1)
    s2 = float(sol.fun @ sol.fun) / dof  # type: ignore[attr-defined]
    JTJ = J.T @ J
    w, v = np.linalg.eigh(JTJ)
    if w.size == 0 or w[-1] <= 0.0:
        return {n: float("nan") for n in names}
    # directions the data do not determine (e.g. a clearance beyond every drift seen): the
    # coordinates that take part in them are "not determined"; the others get their
    # covariance with those held (a lower bound, like the rest of this estimate)
    null = v[:, w <= 1e-10 * w[-1]]
    free = ~np.any(np.abs(null) > 0.1, axis=1) if null.size else np.ones(x.size, bool)
    cov_x = np.full((x.size, x.size), np.nan)
    if free.any():
        cov_x[np.ix_(free, free)] = s2 * np.linalg.inv(JTJ[np.ix_(free, free)])
    p0 = to_params(x)
    T = np.zeros((len(names), x.size))
    for j in range(x.size):
        h = 1e-6 * max(1.0, abs(x[j]))
        xp = x.copy()
        xp[j] += h
        pj = to_params(xp)
        T[:, j] = [(pj[n] - p0[n]) / h for n in names]
    out = {}
    for i, n in enumerate(names):
        used = T[i] != 0.0
        if not used.any():  # held fixed
            out[n] = 0.0
        elif not free[used].all():
            out[n] = float("nan")
        else:
            c = cov_x[np.ix_(used, used)]
            out[n] = float(np.sqrt(max(float(T[i, used] @ c @ T[i, used]), 0.0)))
    return out
