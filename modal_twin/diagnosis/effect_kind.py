"""What an effect kind is: the protocol every candidate kind of the diagnosis follows.

An **effect kind** is a way a model can be wrong that the diagnosis knows how to look for:
a device law at a site, a parameter (element group, added mass, damping), an elastic
mount of an attached mass, a sensor. Each kind says, through :class:`EffectKind`,

* how it is **screened** on a round's training record (:meth:`EffectKind.screen`: its
  candidates, best first) and which **fit jobs** its candidates make
  (:meth:`EffectKind.jobs`);
* how one of its effects is **applied** to a model (:meth:`EffectKind.apply`,
  :meth:`EffectKind.plant`) and stored in a model version (:meth:`EffectKind.into_version`);
* which **family** of the one vocabulary (:data:`modal_twin.diagnosis.kinds.FAMILIES`) a
  fitted effect reports in, at which **place**, with which **flags**;
* how a user's effect is started and fitted (``effects add``: :meth:`EffectKind.start`,
  :meth:`EffectKind.fit`) and whether it joins the joint refit (:meth:`EffectKind.joint`).

The kinds are registered in :data:`modal_twin.diagnosis.kinds.KINDS` (a dict, as rosbags
keeps its type stores); the pipeline, the whole-job helpers, the joint refit and the report
loop over that dict and never test an effect's law by name.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.diagnosis.behaviour import Behaviour
from modal_twin.diagnosis.fitting import FittedEffect
from modal_twin.diagnosis.record import Record
from modal_twin.models.effects import EffectSpec
from modal_twin.models.loading import ModelFactory, merge_effects, with_effects
from modal_twin.models.plant import Plant

__all__ = ["EffectKind", "Facts", "Job", "Piece", "PlacedEffect", "Round"]

Job = tuple[str, Callable[[], FittedEffect]]
"""A fit job: its label and the call that fits it."""

Piece = tuple[int, Callable[[FloatArray], dict[str, float]], FloatArray, FloatArray,
              FloatArray]
"""(size, x -> params, x0, lower, upper) of an effect refitted jointly."""


@dataclass(slots=True)
class Round:
    """What one round of the diagnosis hands every kind's screening.

    ``records`` are restricted to the channels the model has: ``records[0]`` trains,
    ``records[1]`` is held out, the rest are other levels. ``fit_on`` are the records the
    fits use (all but the held-out one); ``noise[i]`` the noise floor of ``records[i]``;
    ``significant`` the channels above their noise floor; ``skipped`` collects what was
    left out (a kind appends to it).
    """

    factory: ModelFactory
    records: Sequence[Record]
    nominal: Plant
    noise: Sequence[np.ndarray]
    significant: tuple[str, ...]
    skipped: list[str]
    say: Callable[[str], None]
    n_fit: int = 3
    gain_threshold: float = 0.01
    n_families: int = 2
    evidence_family: dict[str, str] = field(default_factory=dict)  # place -> family named

    @property
    def train(self) -> Record:
        """Return the training record."""
        return self.records[0]

    @property
    def test(self) -> Record:
        """Return the held-out record."""
        return self.records[1]

    @property
    def fit_on(self) -> tuple[Record, ...]:
        """Every record but the held-out one (a low level pins what a law does when idle)."""
        return (self.records[0], *self.records[2:])


@dataclass(frozen=True, slots=True)
class Facts:
    """What the judgement of one fitted effect knows about its model and place.

    Attributes
    ----------
    values : mapping
        The model's parameter values (nominal, before the effect).
    nominal_k, nominal_c : float, optional
        Mean nominal stiffness and damping of the device site the effect sits at.
    drift_scale : float, optional
        99th percentile of the measured drift at that site (training record).
    evidence_family : str
        The family the evidence named at that place ("" when none).
    behaviour : Behaviour, optional
        What the fitted effect does along the training record (:mod:`.behaviour`); a kind
        that knows it reports its family (None: the law's own family).
    """

    values: Mapping[str, float] = field(default_factory=dict)
    nominal_k: float | None = None
    nominal_c: float | None = None
    drift_scale: float | None = None
    evidence_family: str = ""
    behaviour: Behaviour | None = None


class EffectKind(Protocol):
    """One kind of candidate effect (module docstring)."""

    name: str
    """Registry key (``device``, ``parameter``, ``mount``, ``sensor`` ...)."""
    families: tuple[str, ...]
    """Return the families its effects report in (part of the one vocabulary)."""

    def owns(self, law: str) -> bool:
        """Whether an effect with law ``law`` is of this kind."""
        ...

    def laws(self) -> tuple[str, ...]:
        """Return the effect laws of this kind (``EffectSpec.law``)."""
        ...

    def screen(self, rnd: Round) -> tuple[Any, ...]:
        """Return the candidates of this kind on the round's training record, best first."""
        ...

    def jobs(self, rnd: Round, candidates: tuple[Any, ...]) -> list[Job]:
        """Return the fit jobs the candidates make."""
        ...

    def report(self, candidates: tuple[Any, ...]) -> list[str]:
        """Return the report's lines on the screened candidates (may be empty)."""
        ...

    def plant(self, factory: ModelFactory, effect: EffectSpec) -> Plant:
        """Return the plant of ``factory`` with ``effect`` in place."""
        ...

    def apply(self, factory: ModelFactory, effect: EffectSpec) -> ModelFactory:
        """Return a factory whose plants carry ``effect``."""
        ...

    def into_version(self, theta: dict[str, float], effects: tuple[EffectSpec, ...],
                     effect: EffectSpec) -> tuple[dict[str, float], tuple[EffectSpec, ...]]:
        """Return a version's parameter values and effects with ``effect`` added."""
        ...

    def facts(self, rnd: Round, effect: EffectSpec) -> Facts:
        """Return what the judgement of ``effect`` needs to know about its model and place."""
        ...

    def family(self, effect: EffectSpec, facts: Facts) -> str:
        """Return the family of what the fitted ``effect`` does."""
        ...

    def place(self, effect: EffectSpec, factory: ModelFactory | None = None) -> str:
        """Return where ``effect`` sits (with ``factory``: as its model names the place)."""
        ...

    def flags(self, effect: EffectSpec, facts: Facts) -> tuple[str, ...]:
        """Return why the fitted ``effect`` is implausible (empty when it is not)."""
        ...

    def start(self, factory: ModelFactory, component: str, law: str, train: Record
              ) -> dict[str, float]:
        """Return starting parameters of ``law`` at ``component`` from the training record."""
        ...

    def fit(self, factory: ModelFactory, component: str, law: str, start: dict[str, float],
            train: Record, test: Record) -> FittedEffect:
        """Fit ``law`` at ``component`` from ``start`` on ``train``; judged on ``test``."""
        ...

    def joint(self, factory: ModelFactory, effect: EffectSpec) -> Piece | None:
        """Return the joint refit's piece of ``effect``; None keeps it as found."""
        ...


class PlacedEffect:
    """What the kinds whose effect the factory places (``plant(effects)``) share.

    A device law, a mount, a sensor effect: applied as an effect at its component (which is
    its place), stored among a version's effects, judged with the model's parameter values
    and no flags of its own, in the first family it lists. A kind overrides what differs.
    """

    families: tuple[str, ...] = ()

    def family(self, effect: EffectSpec, facts: Facts) -> str:
        """Return the kind's (first) family."""
        return self.families[0]

    def plant(self, factory: ModelFactory, effect: EffectSpec) -> Plant:
        """Return the plant with the effect at its component."""
        return factory.plant([effect])

    def apply(self, factory: ModelFactory, effect: EffectSpec) -> ModelFactory:
        """Return the factory with the effect at its component (replacing one in its slot)."""
        return with_effects(factory, [effect])

    def into_version(self, theta: dict[str, float], effects: tuple[EffectSpec, ...],
                     effect: EffectSpec) -> tuple[dict[str, float], tuple[EffectSpec, ...]]:
        """Return the version's effects with this one merged in."""
        return theta, merge_effects(effects, [effect])

    def facts(self, rnd: Round, effect: EffectSpec) -> Facts:
        """Return the model's parameter values and the evidence at the place."""
        return Facts(rnd.factory.parameters(),
                     evidence_family=rnd.evidence_family.get(effect.component, ""))

    def place(self, effect: EffectSpec, factory: ModelFactory | None = None) -> str:
        """Return the component."""
        return effect.component

    def flags(self, effect: EffectSpec, facts: Facts) -> tuple[str, ...]:
        """Return no flags beyond the judgement's own (bounds)."""
        return ()

    def joint(self, factory: ModelFactory, effect: EffectSpec) -> Piece | None:
        """Return None: kept as found by the joint refit."""
        return None
