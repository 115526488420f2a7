"""Candidate linear effects: a model parameter that is wrong or missing.

Added mass on a floor (``m_*``), a wrong concrete modulus (``E_*``): screened by
simulated sensitivities and fitted by simulation like the device laws.

Screening: with ``r`` the normalised residual of the nominal model on the training record
and ``s_p = d(prediction)/d(theta_p)`` by one forward difference (one simulation per
parameter), the share of ``|r|^2`` that ``alpha s_p`` removes is the score; ``alpha`` is the
starting change. A residual "with the shape of a mode" -- a linear stiffness or mass error --
is explained this way; a nonlinearity is not.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from modal_twin._types import FloatArray
from modal_twin.diagnosis.fitting import (
    FittedEffect,
    Records,
    SimulationObjective,
    _parameter_std,
    judge_fit,
    normalised_residual,
)
from modal_twin.diagnosis.record import Record
from modal_twin.errors import ModalTwinError, OptionError
from modal_twin.models.effects import EffectSpec
from modal_twin.models.loading import ModelFactory

__all__ = ["KINDS", "PARAMETER_LAWS", "ParameterCandidate", "fit_parameter",
           "screen_parameters"]

KINDS = {"m_": "added_mass", "E_": "stiffness", "EI_": "stiffness", "k_": "stiffness",
         "c_": "damping"}
PARAMETER_LAWS = tuple(KINDS.values())  # effects that change a parameter value


@dataclass(frozen=True, slots=True)
class ParameterCandidate:
    """A parameter change that explains part of the residual."""

    name: str
    kind: str  # added_mass | stiffness
    nominal: float
    start: float  # starting value (nominal + alpha h)
    gain: float  # share of the residual energy the change removes (training record)


def _residual(factory: ModelFactory, theta: dict[str, float], rec: Record, decimate: int,
              scale: FloatArray) -> FloatArray:
    plant = (factory.with_theta(theta) if theta else factory).plant()
    return normalised_residual(plant, rec, decimate, scale)


def screen_parameters(factory: ModelFactory, train: Record, *,
                      prefixes: Sequence[str] | None = None, rel_step: float = 0.05,
                      decimate: int = 5) -> list[ParameterCandidate]:
    """Score every parameter whose name starts with one of ``prefixes`` (best first).

    ``prefixes`` defaults to the factory's ``parameter_prefixes`` (the building: masses and
    moduli -- its isolators' k and c are screened as device laws; the vehicle: also its
    suspensions' k and c), else to every kind of :data:`KINDS`.
    """
    if prefixes is None:
        prefixes = tuple(getattr(factory, "parameter_prefixes", tuple(KINDS)))
    values = factory.parameters()
    scale = np.maximum(np.std(train.scored, axis=1), 1e-300)[:, None]
    r0 = _residual(factory, {}, train, decimate, scale)
    e0 = float(r0 @ r0)
    out = []
    for name, nominal in values.items():
        kind = next((KINDS[p] for p in prefixes if name.startswith(p)), None)
        if kind is None or e0 <= 0:
            continue
        h = rel_step * abs(nominal)
        try:
            s = (_residual(factory, {name: nominal + h}, train, decimate, scale) - r0) / h
        except ModalTwinError:
            continue
        ss = float(s @ s)
        if ss <= 0:
            continue
        alpha = -float(s @ r0) / ss  # least-squares step along the sensitivity
        gain = float((s @ r0) ** 2 / ss / e0)
        out.append(ParameterCandidate(name, kind, float(nominal), float(nominal + alpha),
                                      gain))
    return sorted(out, key=lambda c: -c.gain)


def fit_parameter(factory: ModelFactory, cand: ParameterCandidate, train: Records,
                  test: Record, *, decimate: int = 5, max_nfev: int = 30) -> FittedEffect:
    """Fit one parameter by simulation on ``train``, judge on ``test``.

    Raises
    ------
    OptionError
        A start outside the physical range (negative mass or modulus).
    """
    t0 = time.perf_counter()
    # a mass may be added from nothing; a damper may have all but failed; a stiffness or
    # modulus is searched down to 30 %
    lo = {"added_mass": 0.0, "damping": 0.01 * cand.nominal}.get(cand.kind, 0.3 * cand.nominal)
    hi = cand.nominal * 5.0 + 1.0
    x0 = float(np.clip(cand.start, lo + 1e-9 * hi, hi * (1 - 1e-9)))
    if not lo < x0 < hi:
        msg = f"{cand.name}: start {cand.start} outside ({lo}, {hi})"
        raise OptionError(msg)

    def to_params(x: FloatArray) -> dict[str, float]:
        return {cand.name: float(x[0])}

    objective = SimulationObjective(lambda x: factory.with_theta(to_params(x)).plant(),
                                    train, decimate)
    sol = least_squares(objective, [x0], bounds=([lo], [hi]),
                        x_scale=[abs(cand.nominal) or 1.0], diff_step=1e-3, max_nfev=max_nfev)
    effect = EffectSpec(cand.name, cand.kind, to_params(sol.x))
    return judge_fit(effect, factory.with_theta(effect.params).plant(), factory.plant(), sol,
                     1, train, test, objective, t0,
                     _parameter_std(sol, to_params, [cand.name]))
