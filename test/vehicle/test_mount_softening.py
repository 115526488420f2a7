"""An equipment mount that softens (issue 20, item 7): the law, and its fit on a known truth.

Known answers: the softening mount's spring is ``k d`` up to ``|d| = u_s`` and
``r k d + (1 - r) k u_s sign(d)`` beyond (Eq. (9) of [004] with ``kb = r k``); a record of
the car with EQ1 hung on such a mount (10 Hz, 5 %, ``u_s`` = 40 um, ``r`` = 0.35) is fitted
by the mount candidate as a softening mount with those values, and reported as
``softening``; a hardening fit is still reported as an elastic attachment. With a
sharpness ``n`` the knee is rounded (Richard-Abbott,
``r k d + (1 - r) k d / (1 + |d / u_s|^n)^(1/n)``): a truth with ``n`` = 2 is fitted with
its ``n``, and the sharp truth's fit ends at the sharpest knee, the bilinear spring, which
is not a fit stopped at a bound.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from modal_twin.diagnosis.attachments import MOUNT, fit_attachment
from modal_twin.diagnosis.effect_kind import Facts
from modal_twin.diagnosis.record import Record, record_from_blocks
from modal_twin.errors import ModelError
from modal_twin.models.effects import EffectSpec
from modal_twin.models.loading import load_model
from modal_twin.models.track import random_profile, wheelset_inputs
from modal_twin.models.vehicle import assemble_vehicle
from modal_twin.models.vehicle_spec import equipment_mounted
from modal_twin.rig.truth import TruthRig
from modal_twin.signal_block import SignalBlock

ROOT = Path(__file__).resolve().parents[2]
VEHICLE = ROOT / "config" / "vehicles" / "trailer_car.yaml"
FS = 200.0
T = 16.0
SOFT = EffectSpec("EQ1", "elastic_mount", {"f_hz": 10.0, "zeta": 0.05, "u_s": 4e-5,
                                           "r": 0.35})


def test_softening_mount_force_is_the_bilinear_closed_form() -> None:
    spec = equipment_mounted(load_model(VEHICLE).spec, "EQ1", 10.0, 0.05, u_s=4e-5, r=0.35)
    rs = assemble_vehicle(spec).to_reduced_system()
    (att,) = [a for a in rs.devices if a.device.name == "mount_EQ1"]
    k = 3000.0 * (2 * math.pi * 10.0) ** 2
    for d in (1e-5, -3e-5, 1e-4, -2.5e-4):
        f, kt, _, _ = att.device.evaluate(np.array([d]), np.zeros(1), att.device.initial_state())
        soft = abs(d) > 4e-5
        want = 0.35 * k * d + 0.65 * k * 4e-5 * np.sign(d) if soft else k * d
        assert f[0] == pytest.approx(want, rel=1e-9)
        assert kt[0, 0] == pytest.approx(0.35 * k if soft else k, rel=1e-9)


def test_rounded_softening_mount_force_is_the_richard_abbott_closed_form() -> None:
    spec = equipment_mounted(load_model(VEHICLE).spec, "EQ1", 10.0, 0.05, u_s=4e-5, r=0.35,
                             n=2.0)
    rs = assemble_vehicle(spec).to_reduced_system()
    (att,) = [a for a in rs.devices if a.device.name == "mount_EQ1"]
    k = 3000.0 * (2 * math.pi * 10.0) ** 2
    for d in (1e-5, -3e-5, 4e-5, 1e-4, -2.5e-4):
        f, _, _, _ = att.device.evaluate(np.array([d]), np.zeros(1), att.device.initial_state())
        want = 0.35 * k * d + 0.65 * k * d / (1.0 + (abs(d) / 4e-5) ** 2) ** 0.5
        assert f[0] == pytest.approx(want, rel=1e-9)
    with pytest.raises(ModelError):
        equipment_mounted(load_model(VEHICLE).spec, "EQ1", 10.0, 0.05, u_s=4e-5, r=0.35, n=0.2)


def test_softening_and_hardening_together_are_refused() -> None:
    spec = load_model(VEHICLE).spec
    with pytest.raises(ModelError):
        equipment_mounted(spec, "EQ1", 10.0, 0.05, u_s=4e-5, r=0.35, u_h=1e-4)
    with pytest.raises(ModelError):
        equipment_mounted(spec, "EQ1", 10.0, 0.05, u_s=4e-5, r=1.5)


def _record(factory, seed: int, speed_kmh: float, truth: EffectSpec = SOFT) -> Record:
    v = speed_kmh / 3.6
    u = wheelset_inputs(random_profile(v * T + 40.0, rng=seed), factory.spec.axle_x, v, FS,
                        T)
    rig = TruthRig(factory.plant([truth]), 1 / FS, noise_rms={"acceleration": 0.005},
                     seed=seed)
    return record_from_blocks([rig.process(SignalBlock(factory.plant().input_names, FS, 0,
                                                         u))], source=f"track{seed}")


def test_mount_candidate_fits_a_softening_truth() -> None:
    factory = load_model(VEHICLE)
    train, test = _record(factory, 41, 300.0), _record(factory, 42, 350.0)
    fitted = fit_attachment(factory, "EQ1", {"f_hz": 9.0}, train, test)
    p = fitted.effect.params
    assert "u_s" in p, p
    assert p["f_hz"] == pytest.approx(10.0, rel=0.03)
    assert p["r"] == pytest.approx(0.35, abs=0.07)
    assert p["u_s"] == pytest.approx(4e-5, rel=0.25)
    assert p["n"] >= 10.0 and "n" not in fitted.at_bound  # the sharp knee: not a stop
    assert MOUNT.family(fitted.effect, Facts()) == "softening"
    hard = EffectSpec("EQ1", "elastic_mount", {"f_hz": 10.0, "zeta": 0.05, "u_h": 1e-4,
                                               "m": 3.0})
    assert MOUNT.family(hard, Facts()) == "elastic_attachment"


def test_mount_candidate_fits_a_rounded_knee() -> None:
    factory = load_model(VEHICLE)
    truth = EffectSpec("EQ1", "elastic_mount", {**SOFT.params, "n": 2.0})
    train = _record(factory, 41, 300.0, truth)
    test = _record(factory, 42, 350.0, truth)
    p = fit_attachment(factory, "EQ1", {"f_hz": 9.0}, train, test).effect.params
    assert p["n"] == pytest.approx(2.0, abs=0.8)
    assert p["f_hz"] == pytest.approx(10.0, rel=0.04)
    assert p["r"] == pytest.approx(0.35, abs=0.07)
    assert p["u_s"] == pytest.approx(4e-5, rel=0.25)
