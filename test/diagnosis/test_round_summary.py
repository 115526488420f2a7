"""The round's one-line summary says why nothing was taken (issue 20, deliverable 7)."""

from __future__ import annotations

from dataclasses import replace

from modal_twin.diagnosis.fitting import FittedEffect
from modal_twin.diagnosis.judge import rank
from modal_twin.diagnosis.pipeline import _round_summary
from modal_twin.models.effects import EffectSpec


def _fit(place: str, held_out: float, **kw: object) -> FittedEffect:
    """A judged candidate whose held-out whitened RMS after is ``held_out``."""
    rows = (("train", 0.05, 0.02, 1.1, 3.0, 1.1), ("test", 0.05, 0.02, 1.2, 3.0, held_out))
    f = FittedEffect(EffectSpec(place, "cubic", {"k3": 1.0}), 1, 1.0, 2.0, 5.0, 0.0, 1, 0.0,
                     family="hardening", place=place, records=rows)
    return replace(f, **kw)  # type: ignore[arg-type]


def test_a_refused_round_names_the_best_candidate_and_its_reason() -> None:
    why = "lowers test only within its sampling tolerance (whitened RMS x1.10 -> x1.08)"
    ranked = rank([_fit("RB2", 2.0, rejected="makes low worse"),
                   _fit("RB1", 1.5, rejected=why)])
    line = _round_summary(ranked, ["a", "b"])
    assert line.startswith("the model fails (2 channels above")
    assert "no candidate is accepted" in line
    assert f"hardening (cubic) at RB1: {why}" in line  # the lower held-out error first
    flagged = _round_summary([_fit("RB1", 2.0, flags=("k3 at its bound",))], ["a"])
    assert flagged.endswith("at RB1: k3 at its bound)")
    assert _round_summary([], ["a"]).endswith("no candidate could be fitted")


def test_an_accepted_candidate_is_reported_with_its_held_out_figures() -> None:
    ok = _fit("RB1", 1.2)
    line = _round_summary([ok], ["a"])
    assert line == ("missing: hardening (cubic) at RB1 -- held-out NRMSE 5.00 % -> 2.00 % "
                    "(x1.20 the noise floor)")
