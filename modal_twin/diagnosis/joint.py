"""Joint refit of several effects found one after another.

Effects found in rounds were each fitted with the earlier ones frozen; the last step fits
all their parameters together on the training record (the same normalised residual and
bounded transforms as the single fits, :mod:`.fitting`), so that an effect found first does
not keep the share of the error a later one explains better. Mounts and sensor effects are
kept as found.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from scipy.optimize import least_squares

from modal_twin._types import FloatArray
from modal_twin.diagnosis.effect_kind import Piece
from modal_twin.diagnosis.fitting import FittedEffect, SimulationObjective, as_records
from modal_twin.diagnosis.kinds import kind_of
from modal_twin.diagnosis.record import Record
from modal_twin.models.effects import EffectSpec
from modal_twin.models.loading import ModelFactory

__all__ = ["refit_jointly"]


def _pieces(factory: ModelFactory, f: FittedEffect) -> Piece | None:
    """(size, x -> params, x0, lower, upper) of an effect refitted jointly; None to keep it."""
    return kind_of(f.effect.law).joint(factory, f.effect)


def refit_jointly(factory: ModelFactory, found: Sequence[FittedEffect],
                  train: Record | Sequence[Record], *,
                  decimate: int = 5, max_nfev: int = 30, min_free: int = 2
                  ) -> list[FittedEffect]:
    """``found`` with the parameters of its device-law and parameter effects refitted together.

    On ``train`` (on the channels the model has: a record may carry others, e.g. device
    strokes and forces the model has no site for); unchanged when the joint fit does not
    lower the training error, or when fewer than ``min_free`` effects can be refitted (the
    backward elimination refits what is left after a drop, one effect too: ``min_free=1``).
    """
    have = set(factory.plant().channel_names)
    train = [r if set(r.channel_names) <= have else
             r.with_channels([c for c in r.channel_names if c in have])
             for r in as_records(train)]
    parts = [(_pieces(factory, f), f) for f in found]
    free = [(p, f) for p, f in parts if p is not None]
    fixed = [f.effect for p, f in parts if p is None]
    if len(free) < max(min_free, 1):
        return list(found)
    sizes = [p[0] for p, _ in free]
    cuts = np.cumsum([0, *sizes])

    def split(x: FloatArray) -> tuple[dict[str, float], tuple[EffectSpec, ...],
                                      list[EffectSpec]]:
        theta: dict[str, float] = {}
        effects: tuple[EffectSpec, ...] = ()
        for e in fixed:  # kept as found: a parameter stays a value, the rest effects
            theta, effects = kind_of(e.law).into_version(theta, effects, e)
        each = []
        for (p, f), a, b in zip(free, cuts[:-1], cuts[1:], strict=True):
            e = EffectSpec(f.effect.component, f.effect.law, p[1](x[a:b]))
            theta, effects = kind_of(e.law).into_version(theta, effects, e)
            each.append(e)
        return theta, effects, each

    def build(x: FloatArray):
        theta, effects, _ = split(x)
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
    _, _, each = split(sol.x)
    refitted = {id(f): e for (_, f), e in zip(free, each, strict=True)}
    return [replace(f, effect=refitted.get(id(f), f.effect)) for f in found]
