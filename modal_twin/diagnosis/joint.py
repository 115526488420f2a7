"""Joint refit of several effects found one after another.

Effects found in rounds were each fitted with the earlier ones frozen; the last step fits
all their parameters together on the training record (the same normalised residual and
bounded transforms as the single fits, :mod:`.fitting`), so that an effect found first does
not keep the share of the error a later one explains better. Mounts and sensor effects are
kept as found.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np
from scipy.optimize import least_squares

from modal_twin._types import FloatArray
from modal_twin.diagnosis.fitting import (
    FittedEffect,
    SimulationObjective,
    _transform,
    as_records,
)
from modal_twin.diagnosis.record import Record
from modal_twin.errors import ModalTwinError
from modal_twin.models.effects import EffectSpec
from modal_twin.models.loading import ModelFactory

__all__ = ["refit_jointly"]

PARAMETER_LAWS = ("added_mass", "stiffness", "damping")


Piece = tuple[int, Callable[[FloatArray], dict[str, float]], FloatArray, FloatArray,
              FloatArray]


def _pieces(factory: ModelFactory, f: FittedEffect) -> Piece | None:
    """(size, x -> params, x0, lower, upper) of an effect refitted jointly; None to keep it."""
    e = f.effect
    if e.law in PARAMETER_LAWS:
        if len(e.params) > 1:
            return None  # an added mass with its position: kept as found
        v = float(e.params[e.component])
        nom = factory.parameters()[e.component]
        lo = 0.0 if e.law == "added_mass" else min(0.3 * nom, 0.5 * v)
        hi = max(5.0 * nom + 1.0, 2.0 * v)
        name = e.component

        def one(x: FloatArray) -> dict[str, float]:
            return {name: float(x[0])}

        return 1, one, np.array([v]), np.array([lo]), np.array([hi])
    spec = factory.sites.get(e.component)
    if spec is None:
        return None
    start = dict(e.params)
    if e.law == "linear":
        start.setdefault("c0", float(np.mean(spec.c)) or 1.0)
    try:
        names, to_p, to_x, lo_x, hi_x = _transform(e.law, start, float(np.mean(spec.k)))
    except ModalTwinError:
        return None
    x0 = np.clip(to_x(start), lo_x + 1e-9, hi_x - 1e-9)
    keep_all = e.law == "linear"

    def params(x: FloatArray) -> dict[str, float]:
        return {n: v for n, v in to_p(x).items() if keep_all or n in names}

    return len(names), params, x0, lo_x, hi_x


def refit_jointly(factory: ModelFactory, found: Sequence[FittedEffect],
                  train: Record | Sequence[Record], *,
                  decimate: int = 5, max_nfev: int = 30) -> list[FittedEffect]:
    """``found`` with the parameters of its device-law and parameter effects refitted together.

    On ``train`` (on the channels the model has: a record may carry others, e.g. device
    strokes and forces the model has no site for); unchanged when the joint fit does not
    lower the training error.
    """
    have = set(factory.plant().channel_names)
    train = [r if set(r.channel_names) <= have else
             r.with_channels([c for c in r.channel_names if c in have])
             for r in as_records(train)]
    parts = [(_pieces(factory, f), f) for f in found]
    free = [(p, f) for p, f in parts if p is not None]
    fixed = [f.effect for p, f in parts if p is None]
    if len(free) < 2:
        return list(found)
    sizes = [p[0] for p, _ in free]
    cuts = np.cumsum([0, *sizes])

    def split(x: FloatArray) -> tuple[dict[str, float], list[EffectSpec]]:
        theta: dict[str, float] = {}
        effects = list(fixed)
        for (p, f), a, b in zip(free, cuts[:-1], cuts[1:], strict=True):
            params = p[1](x[a:b])
            if f.effect.law in PARAMETER_LAWS:
                theta.update(params)
            else:
                effects.append(EffectSpec(f.effect.component, f.effect.law, params))
        return theta, effects

    def build(x: FloatArray):
        theta, effects = split(x)
        return (factory.with_theta(theta) if theta else factory).plant(effects)

    x0 = np.concatenate([p[2] for p, _ in free])
    lo = np.concatenate([p[3] for p, _ in free])
    hi = np.concatenate([p[4] for p, _ in free])
    obj = SimulationObjective(build, train, decimate)
    r0 = obj(x0)
    sol = least_squares(obj, x0, bounds=(lo, hi), diff_step=1e-3, max_nfev=max_nfev,
                        x_scale="jac")
    if float(sol.fun @ sol.fun) >= float(r0 @ r0):
        return list(found)
    theta, effects = split(sol.x)
    by_comp = {(e.component, e.law): e for e in effects}
    out = []
    for f in found:
        e = f.effect
        if e.law in PARAMETER_LAWS:
            out.append(replace(f, effect=replace(e, params={e.component: theta[e.component]})))
        else:
            out.append(replace(f, effect=by_comp.get((e.component, e.law), e)))
    return out
