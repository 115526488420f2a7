"""Candidate effect: a mass the model holds rigidly that really hangs on a spring-damper.

Underframe equipment of a rail vehicle is hung "through either elastic or rigid hanging
mechanisms" (sec. 2.1 and Fig. 3 of [002]); a model that bolts an elastically hung box
rigidly misses the mode near the mount frequency and mis-predicts the floor response
around it (scenario S2). The same holds for any lumped mass a model attaches rigidly.

Screening: the mount frequency on a log grid (damping ratio 5 %), each trial simulated on
the training record; the share of the normalised residual energy the best trial removes is
the score. Fit: ``(ln f, zeta)`` by ``scipy.optimize.least_squares`` on the training record,
judged on the held-out record, with the BIC of :mod:`.fitting`; then the same with a mount
that hardens (a power spring) and one that softens (a bilinear spring with a rounded knee,
Richard-Abbott), the lowest BIC kept.

A factory offers the masses it can hang through ``attachments()`` and builds the plant of an
``EffectSpec(name, "elastic_mount", {"f_hz": f, "zeta": z})`` in ``plant(effects)``.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from modal_twin._types import FloatArray
from modal_twin.diagnosis.effect_kind import Facts, Job, PlacedEffect, Round
from modal_twin.diagnosis.fitting import (
    FittedEffect,
    Records,
    SimulationObjective,
    _parameter_std,
    channel_scale,
    judge_fit,
    normalised_residual,
)
from modal_twin.diagnosis.record import Record
from modal_twin.errors import ModalTwinError, OptionError
from modal_twin.models.effects import MOUNT_LAW, EffectSpec
from modal_twin.models.loading import ModelFactory

log = logging.getLogger(__name__)

__all__ = ["MOUNT", "MOUNT_LAW", "AttachmentCandidate", "MountKind", "fit_attachment",
           "screen_attachments"]

_ZETA_BOUNDS = (0.005, 0.4)


@dataclass(frozen=True, slots=True)
class AttachmentCandidate:
    """A rigidly attached mass that explains part of the residual when hung elastically."""

    component: str
    f_hz: float  # best mount frequency of the screening grid
    gain: float  # share of the training residual energy it removes


def _mount(component: str, f_hz: float, zeta: float, **hardening: float) -> EffectSpec:
    return EffectSpec(component, MOUNT_LAW, {"f_hz": float(f_hz), "zeta": float(zeta),
                                             **hardening})


def screen_attachments(factory: Any, train: Record, *, freqs_hz: FloatArray | None = None,
                       zeta: float = 0.05, decimate: int = 5) -> list[AttachmentCandidate]:
    """Score every mass of ``factory.attachments()`` over a grid of mount frequencies.

    The grid defaults to 14 frequencies from 2 Hz to the lower of 40 Hz and a quarter of
    the sampling rate. Best first.
    """
    names = tuple(factory.attachments())
    if not names:
        return []
    if freqs_hz is None:
        freqs_hz = np.geomspace(2.0, min(40.0, train.fs_hz / 4.0), 14)
    scale = channel_scale(train)
    r0 = normalised_residual(factory.plant(), train, decimate, scale)
    e0 = float(r0 @ r0)
    out = []
    for name in names:
        best_e, best_f = e0, float("nan")
        for f in np.asarray(freqs_hz, dtype=float):
            try:
                r = normalised_residual(factory.plant([_mount(name, f, zeta)]), train,
                                        decimate, scale)
            except ModalTwinError:
                continue
            e = float(r @ r)
            if e < best_e:
                best_e, best_f = e, float(f)
        if np.isfinite(best_f) and e0 > 0:
            out.append(AttachmentCandidate(name, best_f, 1.0 - best_e / e0))
    return sorted(out, key=lambda c: -c.gain)


def fit_attachment(factory: Any, component: str, start: dict[str, float], train: Records,
                   test: Record, *, decimate: int = 5, max_nfev: int = 30) -> FittedEffect:
    """Fit the mount frequency and damping ratio of ``component`` on ``train``.

    ``start`` holds ``f_hz`` (required) and optionally ``zeta`` (default 0.05).

    Raises
    ------
    OptionError
        ``component`` is not a mass the factory can hang, or ``f_hz`` is not positive.
    """
    if component not in tuple(factory.attachments()):
        msg = (f"{MOUNT_LAW}: unknown component {component!r}; masses that can be hung: "
               f"{sorted(factory.attachments())}")
        raise OptionError(msg)
    f0 = float(start.get("f_hz", 0.0))
    if not f0 > 0.0:
        msg = f"{MOUNT_LAW} at {component}: start f_hz must be > 0, got {start.get('f_hz')}"
        raise OptionError(msg)
    z0 = float(np.clip(start.get("zeta", 0.05), *_ZETA_BOUNDS))
    t0 = time.perf_counter()

    def to_params(x: FloatArray) -> dict[str, float]:
        return {"f_hz": float(np.exp(x[0])), "zeta": float(x[1])}

    objective = SimulationObjective(
        lambda x: factory.plant([_mount(component, **to_params(x))]), train, decimate)
    lo = np.array([np.log(0.2), _ZETA_BOUNDS[0]])
    hi = np.array([np.log(min(200.0, objective.rec.fs_hz / 2.0)), _ZETA_BOUNDS[1]])
    x0 = np.clip([np.log(f0), z0], lo + 1e-9, hi - 1e-9)
    sol = least_squares(objective, x0, bounds=(lo, hi), diff_step=1e-3, max_nfev=max_nfev,
                        x_scale=[0.1, 0.02])
    linear = judge_fit(_mount(component, **to_params(sol.x)),
                       factory.plant([_mount(component, **to_params(sol.x))]), factory.plant(),
                       sol, 2, train, test, objective, t0,
                       _parameter_std(sol, to_params, ["f_hz", "zeta"]))
    fits = [linear] + [_fit_nonlinear(factory, component, sol.x, lo, hi, train, test,
                                      decimate, max_nfev, form) for form in _FORMS]
    return min((f for f in fits if f is not None), key=lambda f: f.bic)


# the mount laws beyond the linear one: extra parameters (name, x -> value, lower, upper,
# start); x is the optimiser's coordinate (log for a displacement)
_FORMS: dict[str, tuple[tuple[str, Callable[[float], float], float, float, float], ...]] = {
    # hardening power spring k d (1 + (|d| / u_h)^(m - 1))
    "hardening": (("u_h", np.exp, np.log(1e-5), np.log(1.0), np.log(1e-2)),
                  ("m", float, 2.0, 9.0, 3.0)),
    # softening spring: tangent k at rest, r k beyond |d| ~ u_s, the knee between of
    # sharpness n (Richard-Abbott; n -> inf: the bilinear spring of Eq. (9) of [004]):
    # rubber softens gradually, and a sharp knee left ~2 % of a tanh-softening mount's
    # force where the rounded one leaves ~0.1 %
    "softening": (("u_s", np.exp, np.log(1e-6), np.log(1e-2), np.log(1e-4)),
                  ("r", float, 0.05, 0.99, 0.5),
                  ("n", np.exp, np.log(1.0), np.log(30.0), np.log(2.0))),
}


def _fit_nonlinear(factory: Any, component: str, x_lin: FloatArray, lo: FloatArray,
                   hi: FloatArray, train: Records, test: Record, decimate: int,
                   max_nfev: int, form: str) -> FittedEffect | None:
    """Refit a mount that hardens or softens (:data:`_FORMS`), from the linear fit.

    None when the model cannot carry that mount.
    """
    t0 = time.perf_counter()
    extra = _FORMS[form]

    def to_params(x: FloatArray) -> dict[str, float]:
        return {"f_hz": float(np.exp(x[0])), "zeta": float(x[1]),
                **{n: float(f(v)) for (n, f, *_), v in zip(extra, x[2:], strict=True)}}

    objective = SimulationObjective(
        lambda x: factory.plant([_mount(component, **to_params(x))]), train, decimate)
    lo4 = np.r_[lo, [e[2] for e in extra]]
    hi4 = np.r_[hi, [e[3] for e in extra]]
    x0 = np.clip(np.r_[x_lin, [e[4] for e in extra]], lo4 + 1e-9, hi4 - 1e-9)
    try:
        sol = least_squares(objective, x0, bounds=(lo4, hi4), diff_step=1e-3,
                            max_nfev=max_nfev, x_scale="jac")
        effect = _mount(component, **to_params(sol.x))
        fitted = factory.plant([effect])
    except (ModalTwinError, ValueError) as err:
        log.debug("%s mount at %s not fitted: %s", form, component, err)
        return None
    names = ["f_hz", "zeta", *(e[0] for e in extra)]
    return judge_fit(effect, fitted, factory.plant(), sol, len(names), train, test,
                     objective, t0, _parameter_std(sol, to_params, names))


class MountKind(PlacedEffect):
    """Effect kind ``mount``: a rigidly attached mass that hangs on an elastic mount."""

    name = "mount"
    families: tuple[str, ...] = ("elastic_attachment", "softening")

    def family(self, effect: EffectSpec, facts: Facts) -> str:
        """Return the family of a fitted mount.

        ``softening`` for a mount that softens (``r < 1`` beyond ``u_s``), else
        ``elastic_attachment`` (a linear or hardening mount of a rigidly modelled mass).
        """
        soft = effect.params.get("u_s", 0.0) > 0.0 and effect.params.get("r", 1.0) < 1.0
        return "softening" if soft else "elastic_attachment"

    def owns(self, law: str) -> bool:
        """:data:`MOUNT_LAW`."""
        return law == MOUNT_LAW

    def laws(self) -> tuple[str, ...]:
        """:data:`MOUNT_LAW`."""
        return (MOUNT_LAW,)

    def screen(self, rnd: Round) -> tuple[AttachmentCandidate, ...]:
        """:func:`screen_attachments` when the model has attached masses."""
        if not tuple(rnd.factory.attachments()):
            return ()
        rnd.say("screening elastic mounts of the rigidly attached masses")
        return tuple(screen_attachments(rnd.factory, rnd.train))

    def jobs(self, rnd: Round, candidates: tuple[Any, ...]) -> list[Job]:
        """Return the best ``n_fit`` above the gain threshold, from their best grid frequency."""
        return [(f"{MOUNT_LAW} at {ac.component}", partial(
            fit_attachment, rnd.factory, ac.component, {"f_hz": ac.f_hz}, rnd.fit_on,
            rnd.test)) for ac in candidates[:rnd.n_fit] if ac.gain >= rnd.gain_threshold]

    def report(self, candidates: tuple[Any, ...]) -> list[str]:
        """One line for each of the best four."""
        return [f"  {ac.component:<12} {MOUNT_LAW:<14} removes {100 * ac.gain:6.2f} "
                f"% of the residual (best mount frequency {ac.f_hz:.3g} Hz)"
                for ac in candidates[:4]]

    def start(self, factory: ModelFactory, component: str, law: str, train: Record
              ) -> dict[str, float]:
        """Return the best mount frequency of the screening grid (10 Hz if none), 5 % damping."""
        best = [c for c in screen_attachments(factory, train) if c.component == component]
        return {"f_hz": best[0].f_hz if best else 10.0, "zeta": 0.05}

    def fit(self, factory: ModelFactory, component: str, law: str, start: dict[str, float],
            train: Record, test: Record) -> FittedEffect:
        """:func:`fit_attachment`."""
        return fit_attachment(factory, component, start, train, test)



MOUNT = MountKind()
