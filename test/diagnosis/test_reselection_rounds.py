"""The law of each early device effect chosen again: one round per site, its decision said.

Known answers on a given world (the rounds at each site and the whitened information
criterion of each set of laws are given, so the rule alone decides): five effects found;
the last is never tried and a parameter effect is no device. At RB1 a law with a lower
criterion (5 -> 4) is taken; at ESB1 the best law is the one found; at SDP1 the best
other law's criterion (4.5) is not below the current set's, which is now 4 (the set with
RB1's new law); at SDP2 no law is usable. The criterion of the current set is computed
once and again only when a law is taken: three calls in all.
"""

from __future__ import annotations

from typing import Any

import pytest

import modal_twin.diagnosis.pipeline as pipeline
import modal_twin.diagnosis.refine as refine
from modal_twin.diagnosis.fitting import FittedEffect
from modal_twin.diagnosis.pipeline import Diagnosis, _reselected
from modal_twin.models.effects import EffectSpec


def fit(component: str, law: str, family: str, *, rejected: str = "") -> FittedEffect:
    return FittedEffect(EffectSpec(component, law, {}), 1, 1.0, 1.0, 1.0, 0.0, 1, 0.0,
                        family=family, place=component, rejected=rejected)


class World:
    """The effects in the model as a set of (site, law), standing in for a factory/plant."""

    def __init__(self, effects: Any = ()) -> None:
        self.effects = frozenset((f.effect.component, f.effect.law) for f in effects)

    def plant(self) -> frozenset[tuple[str, str]]:
        return self.effects


def test_each_early_device_law_is_chosen_again_with_its_decision(
        monkeypatch: pytest.MonkeyPatch) -> None:
    found = [fit("RB1", "stick_slip", "stiffness"), fit("ESB1", "bilinear_hysteretic",
                                                          "hysteresis"),
             fit("F2", "added_mass", "mass"), fit("SDP1", "regularised_friction", "friction"),
             fit("SDP2", "bilinear", "softening"), fit("RB2", "bouc_wen", "hysteresis")]
    rounds = {"RB1": (fit("RB1", "bouc_wen", "hysteresis"), fit("RB1", "stick_slip",
                                                                "friction")),
              "ESB1": (fit("ESB1", "bilinear_hysteretic", "hysteresis"),),
              "SDP1": (fit("SDP1", "stick_slip", "friction"),),
              "SDP2": (fit("SDP2", "cubic", "softening", rejected="makes low worse"),)}
    tried: list[str] = []
    calls: list[frozenset[tuple[str, str]]] = []

    def given_round(world: World, records: Any, *, only: str, **kw: Any) -> Diagnosis:
        tried.append(only)
        assert (only, next(f.effect.law for f in found if f.effect.component == only)) \
            not in world.effects  # the site's own effect is out while its laws are fitted
        return Diagnosis(True, f"no candidate at {only}", None, rounds[only], ())  # type: ignore[arg-type]

    def criterion(figs: frozenset[tuple[str, str]], n_params: int, records: Any) -> float:
        calls.append(figs)
        return 5.0 - (("RB1", "bouc_wen") in figs) + 0.5 * (("SDP1", "stick_slip") in figs)

    monkeypatch.setattr(pipeline, "diagnose_round", given_round)
    for module in (pipeline, refine):  # the rounds' model, and the criterion's
        monkeypatch.setattr(module, "apply_all", lambda factory, effects: World(effects))
    monkeypatch.setattr(refine, "figures_on", lambda plant, records, noises: plant)
    monkeypatch.setattr(refine, "information_criterion", criterion)
    said: list[str] = []
    out, rows = _reselected(World(), found, [], [], [], said.append)
    assert tried == ["RB1", "ESB1", "SDP1", "SDP2"]  # devices before the last, in order
    assert out[0] is rounds["RB1"][0] and out[1:] == found[1:]
    assert len(calls) == 3
    crit = " (whitened information criterion over every record, lower is better)"
    assert [r[2] for r in rows] == [
        f"law at RB1 re-chosen: stick_slip -> bouc_wen, criterion 5.0000 -> 4.0000{crit}",
        "law at ESB1 kept: bilinear_hysteretic (the best law there with the others in place)",
        "law at SDP1 kept: regularised_friction (the best fit there, stick_slip: criterion "
        f"4.0000 -> 4.5000{crit}, not lower)",
        "law at SDP2 kept: bilinear (no law there is usable with the others in place: no "
        "candidate at SDP2)"]
    assert [r[3] for r in rows] == [rounds["RB1"][0], None, None, None]
    assert [r[1] for r in rows] == [rounds[s] for s in ("RB1", "ESB1", "SDP1", "SDP2")]
    assert rows[0][0] == (
        "the law at RB1 chosen again (stick_slip, found in round 1), the model as given with "
        "hysteresis at ESB1 (bilinear_hysteretic), mass at F2 (added_mass), friction at SDP1 "
        "(regularised_friction), softening at SDP2 (bilinear), hysteresis at RB2 (bouc_wen)")
    assert rows[2][0].startswith("the law at SDP1 chosen again (regularised_friction, found "
                                 "in round 4), the model as given with hysteresis at RB1 "
                                 "(bouc_wen), ")  # the law taken before is in place
    assert said == ["stiffness at RB1: with the other effects in place bouc_wen fits better "
                    "than stick_slip; taken instead"]
