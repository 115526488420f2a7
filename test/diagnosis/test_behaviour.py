"""Labels from behaviour (issue 20, item 4): closed-form force laws written here, not the
library's, each read off its force along a random drift history; then the library's laws
with known parameters, reported in the family of what they do (the judge's words)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

from modal_twin.diagnosis.behaviour import LINEAR_R2, classify_behaviour, turning_points
from modal_twin.diagnosis.device_kind import behaviour_on, family_of
from modal_twin.diagnosis.effect_kind import Facts
from modal_twin.diagnosis.fitting import FittedEffect
from modal_twin.diagnosis.judge import labelled
from modal_twin.diagnosis.record import Record
from modal_twin.models.effects import EffectSpec
from modal_twin.models.loading import ModelFactory, load_model

FS = 100.0
K, C = 1.0e6, 2.0e4  # nominal linear law, N/m and N s/m


def drift(seed: int = 1, nt: int = 12000) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    sos = signal.butter(4, [0.3, 1.5], btype="band", fs=FS, output="sos")
    u = signal.sosfiltfilt(sos, rng.standard_normal(nt))
    u *= 0.05 / np.std(u)  # 5 cm RMS
    return u, np.gradient(u, 1 / FS)


def elastoplastic(u: np.ndarray, fy: float, uy: float) -> np.ndarray:
    """A slider of strength fy behind a spring fy / uy (return mapping, exact for a path)."""
    z, out = 0.0, np.empty_like(u)
    prev = u[0]
    for i, x in enumerate(u):
        z = float(np.clip(z + fy / uy * (x - prev), -fy, fy))
        prev = x
        out[i] = z
    return out


def iwan(u: np.ndarray, fy: float, uy_max: float, n: int = 40) -> np.ndarray:
    """Microslip: n parallel elastoplastic elements, yield drifts spread up to uy_max."""
    return sum(elastoplastic(u, fy / n, uy_max * (j + 1) / n) for j in range(n))


LAWS: dict[str, tuple[str, Callable[[np.ndarray, np.ndarray], np.ndarray]]] = {
    "stiffer": ("stiffness", lambda u, v: 1.3 * K * u + C * v),
    "more damping": ("damping", lambda u, v: K * u + 3.0 * C * v),
    "a dashpot-like Bouc-Wen fit (less damping)": ("damping", lambda u, v: K * u + 0.3 * C * v),
    "Coulomb slider, stiff stick": ("friction",
                                    lambda u, v: K * u + C * v + elastoplastic(u, 2e4, 2e-4)),
    "yielding damper": ("hysteresis", lambda u, v: K * u + C * v + elastoplastic(u, 2e4, 0.02)),
    "microslip": ("hysteresis", lambda u, v: K * u + C * v + iwan(u, 2e4, 0.08)),
    "cubic hardening": ("hardening", lambda u, v: K * u + C * v + 4e8 * u**3),
    "tanh softening": ("softening",
                       lambda u, v: K * 0.06 * np.tanh(u / 0.06) + C * v),
    "gap at 6 cm": ("gap", lambda u, v: K * u + C * v
                    + 3 * K * np.sign(u) * np.clip(np.abs(u) - 0.06, 0.0, None)),
    "nominal": ("nothing", lambda u, v: K * u + C * v),
}


@pytest.mark.parametrize("name", list(LAWS))
def test_each_closed_form_law_reads_as_its_family(name: str) -> None:
    family, law = LAWS[name]
    u, v = drift()
    b = classify_behaviour(u, v, law(u, v), k=K, c=C)
    assert b.family == family, f"{name}: {b.text()}"


def test_turning_points_ignore_small_wiggles() -> None:
    t = np.arange(2000) / FS
    u = np.sin(2 * np.pi * 0.5 * t) + 0.005 * np.sin(2 * np.pi * 20 * t)
    tp = turning_points(u)
    assert tp.size == 20  # two per period over 20 s, the 20 Hz ripple ignored
    np.testing.assert_allclose(np.abs(u[tp]), 1.0, atol=0.01)


# --- wired: the family a fitted library law reports is what it does on the record ------

BUILDING = Path(__file__).resolve().parents[2] / "config" / "structures" / "building.yaml"


def _site_record(factory: ModelFactory, site: str) -> Record:
    """A record of drift (and a placeholder force) at ``site``: only the drift is read."""
    ux, _ = drift(seed=2)
    uy, _ = drift(seed=3)
    u = np.vstack([ux, 0.3 * uy])
    chans = (f"{site}_dx", f"{site}_dy", f"{site}_fx", f"{site}_fy")
    data = np.vstack([u, np.zeros_like(u)])
    inputs = np.zeros((6, u.shape[1]))
    return Record(FS, factory.plant().input_names, inputs, chans, data, "drift")


def _labelled(effect: EffectSpec, evidence_family: str = "") -> FittedEffect:
    factory = load_model(BUILDING)
    rec = _site_record(factory, effect.component)
    b = behaviour_on(factory, factory.plant().channels, rec, effect)
    assert b is not None
    u99 = float(np.quantile(np.abs(rec.channels([f"{effect.component}_dx"])), 0.99))
    facts = Facts(drift_scale=u99, evidence_family=evidence_family, behaviour=b)
    return labelled(FittedEffect(effect, 3, 0.0, 0.0, 0.0, 0.0, 0, 0.0), facts)


def test_a_bouc_wen_fit_that_is_a_dashpot_reports_damping() -> None:
    """alpha 0.999: the law is k u + 0.3 c u' beside a loop of 1e-3 k (uy 2 cm): a dashpot
    with 70 % less damping; its own family (hysteresis) loses, and the output says so."""
    f = _labelled(EffectSpec("SDP2", "bouc_wen", {"alpha": 0.999, "uy": 0.02,
                                                  "c_factor": 0.3}))
    assert f.family == "damping", f.behaviour
    assert f.behaviour.startswith("fitted law bouc_wen, alpha 0.999")
    assert "behaves as a dashpot" in f.behaviour
    assert "its law's own family is hysteresis, the behaviour wins" in f.behaviour
    assert f.family_text() == f"damping ({f.behaviour})"


def test_a_yielding_bilinear_law_reports_hysteresis() -> None:
    """Yield at 4 cm of a 5 cm RMS drift, 10 % post-yield stiffness: a loop (loss share
    well above 0.15) that turns over gradually: hysteresis, as the law's own family."""
    f = _labelled(EffectSpec("SDP1", "bilinear_hysteretic", {"ub": 0.04, "ratio": 0.1}))
    assert f.family == "hysteresis", f.behaviour
    assert "behaves as a yielding loop (R2 linear" in f.behaviour
    assert "the behaviour wins" not in f.behaviour


def test_a_small_loop_beside_a_large_stiffness_change_is_still_a_loop() -> None:
    """Yield at 5 mm of a 5 cm RMS drift, 35 % post-yield stiffness: a spring-dashpot
    explains 99.7 % of the residual force (it is mostly the lost stiffness) and leaves 0.7 %
    of the law's force, yet the loop encloses area: a loop (friction, as the law's elastic
    range is under 5 % of the drift), not a stiffness change."""
    f = _labelled(EffectSpec("RB2", "bilinear_hysteretic", {"ub": 0.005, "ratio": 0.35}))
    assert f.family == "friction", f.behaviour
    assert "behaves as a loop that dissipates energy" in f.behaviour
    r2 = float(f.behaviour.split("R2 linear ")[1].split(",")[0])
    assert r2 > LINEAR_R2


def test_within_one_kind_the_law_names_the_family() -> None:
    """The same loop where the evidence named friction: a dissipative law stays in the
    family its parameters and the evidence give (the turn-over is not trusted to split
    friction from hysteresis); the words say it is a loop and why friction."""
    eff = EffectSpec("SDP1", "bilinear_hysteretic", {"ub": 0.04, "ratio": 0.1})
    assert family_of(eff, Facts(evidence_family="friction")) == "friction"
    f = _labelled(eff, evidence_family="friction")
    assert f.family == "friction", f.behaviour
    assert "behaves as a loop that dissipates energy" in f.behaviour
    assert f.behaviour.endswith("; friction by the law's parameters")


def test_a_cubic_softening_spring_reports_softening_and_agrees_with_its_law() -> None:
    """k u + k3 u^3 with k3 = -0.3 k / (13 cm)^2: elastic, secant falling with amplitude."""
    k = float(np.mean(load_model(BUILDING).sites["RB2"].k))
    f = _labelled(EffectSpec("RB2", "cubic", {"k3": -0.3 * k / 0.13**2}))
    assert f.family == "softening", f.behaviour
    assert "behaves as a softening spring" in f.behaviour
    assert "the behaviour wins" not in f.behaviour  # the law's own family agrees


def test_without_a_measured_drift_the_law_reports_its_own_family() -> None:
    factory = load_model(BUILDING)
    rec = _site_record(factory, "SDP2")
    eff = EffectSpec("RB1", "bouc_wen", {"alpha": 0.999})  # RB1's drift is not in rec
    assert behaviour_on(factory, factory.plant().channels, rec, eff) is None
    f = labelled(FittedEffect(eff, 3, 0.0, 0.0, 0.0, 0.0, 0, 0.0), Facts())
    assert f.family == "hysteresis" and f.behaviour == ""
    assert f.family_text() == "hysteresis (bouc_wen)"


def test_a_relaxing_linear_law_is_told_from_a_softening_spring_by_homogeneity() -> None:
    """A Maxwell damper's force halves with its drift history (linear, with memory); a
    bilinear spring's does not once the drift passes its knee."""
    from modal_twin.diagnosis.device_kind import _homogeneous
    from modal_twin.models.devices.bilinear import BilinearElastic
    from modal_twin.models.devices.maxwell import MaxwellDamper

    fs = 200.0
    t = np.arange(4000) / fs
    u = (0.02 * np.sin(2 * np.pi * 1.3 * t) * np.minimum(t / 5, 1.0))[None, :]
    v = np.gradient(u, 1 / fs, axis=1)
    dev = MaxwellDamper([1.0e5], [8.0e5], [4.0e4], dt=1 / fs)
    f = dev.respond(u, v, dt=1 / fs).f
    assert _homogeneous(dev, u, v, f, 1 / fs)
    spring = BilinearElastic(1.0e6, 0.3e6, 0.005, [0.0])
    fb = spring.respond(u, v).f
    assert not _homogeneous(spring, u, v, fb, 1 / fs)


@pytest.mark.parametrize(("ratio", "family"), [(0.35, "softening"), (3.0, "hardening")])
def test_a_smooth_bilinear_spring_reports_softening_or_hardening_by_its_ratio(
        ratio: float, family: str) -> None:
    """Richard-Abbott curve with its knee at 2 cm of a 5 cm RMS drift (n = 2): elastic
    (loads and unloads on one curve), its secant falling with amplitude for kb = 0.35 k,
    rising for kb = 3 k; the behaviour agrees with the law's own rule on ``ratio``."""
    eff = EffectSpec("RB2", "smooth_bilinear", {"ub": 0.02, "ratio": ratio, "n": 2.0})
    assert family_of(eff) == family
    f = _labelled(eff)
    assert f.family == family, f.behaviour
    assert f"behaves as a {family} spring" in f.behaviour
    assert "the behaviour wins" not in f.behaviour


# --- a clearance is a knee: a stiff smooth hardening over a decade of amplitude is no gap --


def swelling_drift(seed: int = 4, nt: int = 12000) -> tuple[np.ndarray, np.ndarray]:
    """A narrow-band drift (0.9-1.1 Hz) whose amplitude grows tenfold, to 10 cm at the end."""
    rng = np.random.default_rng(seed)
    sos = signal.butter(4, [0.9, 1.1], btype="band", fs=FS, output="sos")
    u = signal.sosfiltfilt(sos, rng.standard_normal(nt))
    u *= np.linspace(0.1, 1.0, nt) / np.max(np.abs(u))
    u *= 0.10 / np.max(np.abs(u))
    return u, np.gradient(u, 1 / FS)


def test_a_cubic_spring_over_a_decade_of_amplitude_is_hardening_not_a_gap() -> None:
    """k3 u^3: its secant grows as A^2, so cycles from 1 to 10 cm see secants 1:100 (the
    smallest below a tenth of the largest: the secant ratio alone reads a gap), but a power
    law explains the force exactly (knee share ~0): a hardening spring."""
    u, v = swelling_drift()
    b = classify_behaviour(u, v, K * u + C * v + 4e8 * u**3, k=K, c=C)
    assert b.family == "hardening", b.text()
    assert b.knee_share < 1e-6
    assert "knee share" in b.text()


@pytest.mark.parametrize(("g", "n", "family"), [(0.06, 1.0, "gap"), (0.05, 1.5, "gap"),
                                                (0.005, 2.5, "hardening")])
def test_a_clearance_is_a_gap_only_where_the_record_resolves_its_knee(
        g: float, n: float, family: str) -> None:
    """A contact spring beyond a clearance g (overlap to the power n) along the swelling
    drift: at 6 cm (linear) or 5 cm (Hertz) of a 10 cm peak the force is nil through most
    cycles, then rises at a knee no power law has; at 5 mm (the foot of the drift) a power
    law of the overlap, ~u^2.5 beyond it, is one of the smooth springs: hardening."""
    u, v = swelling_drift()
    contact = 3 * K * g * np.sign(u) * (np.clip(np.abs(u) - g, 0.0, None) / g) ** n
    b = classify_behaviour(u, v, K * u + C * v + contact, k=K, c=C)
    assert b.family == family, b.text()
    assert (b.knee_share >= 1e-3) == (family == "gap")


@pytest.mark.parametrize(("g", "n", "family"), [(0.06, 1.5, "gap"), (0.005, 2.5, "hardening")])
def test_a_gap_law_without_a_knee_on_the_record_reports_hardening(
        g: float, n: float, family: str) -> None:
    """The library's gap law (beside the nominal spring, kp = 1) fitted with a clearance of
    5 mm under a 5 cm RMS drift acts as a smooth hardening spring and is reported as one,
    its own family beside it (the narrow-band sinh case of session 12 named such a fit a
    gap); a clearance of 6 cm stays a gap."""
    eff = EffectSpec("RB1", "gap", {"g": g, "g_neg": g, "n": n, "k": 5.0e6, "kp": 1.0})
    f = _labelled(eff)
    assert f.family == family, f.behaviour
    if family == "hardening":
        assert "behaves as a hardening spring" in f.behaviour
        assert "its law's own family is gap, the behaviour wins" in f.behaviour
