"""Scenario S2 (../shared/scenarios): the vehicle's equipment hangs on elastic mounts.

Truth: the trailer car with its 3 t underframe box EQ1 on elastic mounts (10 Hz, 5 %);
nominal model: the box bolted rigidly. Training record: 300 km/h over one realisation of
the German low-interference track; held-out record: 350 km/h over another. The diagnosis
of the nominal model must place the error near mid-car in the carbody-bending band, name
an elastic attachment of EQ1, and the fitted mount must cut the floor-PSD error in 4-15 Hz
and the error of the vertical Sperling index by at least 3x on the held-out record.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from modal_twin.diagnosis.fitting import simulate_record
from modal_twin.diagnosis.pipeline import Diagnosis, diagnose
from modal_twin.diagnosis.record import Record, record_from_blocks
from modal_twin.models.effects import EffectSpec
from modal_twin.models.loading import load_model
from modal_twin.models.ride import psd_band_error, sperling_index
from modal_twin.models.track import random_profile, wheelset_inputs
from modal_twin.rig.truth import TruthRig
from modal_twin.signal_block import SignalBlock

ROOT = Path(__file__).resolve().parents[2]
VEHICLE = ROOT / "config" / "vehicles" / "trailer_car.yaml"
FS = 200.0
T = 20.0
MOUNT = EffectSpec("EQ1", "elastic_mount", {"f_hz": 10.0, "zeta": 0.05})


def make_record(factory, effects: list[EffectSpec], *, speed_kmh: float, seed: int,
                noise: float = 0.005) -> Record:
    spec = factory.spec
    v = speed_kmh / 3.6
    prof = random_profile(v * T + 40.0, rng=seed)
    u = wheelset_inputs(prof, spec.axle_x, v, FS, T)
    truth = TruthRig(factory.plant(effects), 1 / FS, noise_rms={"acceleration": noise},
                     seed=seed)
    return record_from_blocks([truth.process(SignalBlock(factory.plant().input_names, FS, 0,
                                                         u))], source=f"track{seed}")


@pytest.fixture(scope="module")
def case():
    factory = load_model(VEHICLE)
    train = make_record(factory, [MOUNT], speed_kmh=300.0, seed=21)
    test = make_record(factory, [MOUNT], speed_kmh=350.0, seed=22)
    return factory, train, test, diagnose(factory, train, test, n_fit=2)


def _ride_errors(factory, effects: list[EffectSpec], test: Record) -> tuple[float, float]:
    pred = simulate_record(factory.plant(effects), test)[:, test.skip:]
    meas = test.scored
    psd = float(np.mean(psd_band_error(meas, pred, FS, band=(4.0, 15.0)).rel_power_error))
    mid = test.channel_names.index("floor_mid_z")
    wz = abs(sperling_index(pred[mid], FS).W - sperling_index(meas[mid], FS).W)
    return psd, wz


def test_s2_names_the_elastic_mount_of_eq1(case: tuple) -> None:
    _, _, _, d = case
    d: Diagnosis
    assert d.significant
    assert d.best is not None
    assert (d.best.effect.component, d.best.effect.law) == ("EQ1", "elastic_mount")
    assert d.best.effect.params["f_hz"] == pytest.approx(10.0, rel=0.05)
    assert d.best.effect.params["zeta"] == pytest.approx(0.05, rel=0.3)
    mounts = d.candidates.get("mount", ())
    assert mounts and mounts[0].component == "EQ1"
    # where: the carbody-bending band and the middle of the car, not the pivots
    worst = d.where.worst("location", 1)[0]
    assert "pivot" not in worst.key
    assert "elastic_mount" in d.format()


def test_s2_floor_psd_and_sperling_errors_fall_3x(case: tuple) -> None:
    factory, _, test, d = case
    assert d.best is not None
    psd0, wz0 = _ride_errors(factory, [], test)
    psd1, wz1 = _ride_errors(factory, [d.best.effect], test)
    print(f"S2 held-out: floor PSD 4-15 Hz relative error {psd0:.3f} -> {psd1:.3f}; "
          f"Sperling Wz error {wz0:.4f} -> {wz1:.4f}")
    assert psd0 >= 3.0 * psd1
    assert wz0 >= 3.0 * wz1


def test_s2_control_rigid_truth_reports_nothing(case: tuple) -> None:
    factory, _, _, _ = case
    train = make_record(factory, [], speed_kmh=300.0, seed=23)
    test = make_record(factory, [], speed_kmh=350.0, seed=24)
    d = diagnose(factory, train, test, n_fit=1)
    assert not d.significant, d.summary
    assert d.best is None


def test_own_worn_secondary_dampers(case: tuple) -> None:
    """Own scenario (suspension deterioration, sec. 1 of [002]): the secondary vertical
    dampers at 25 % of their nominal damping; the nominal model is not told."""
    factory, _, _, _ = case
    worn = factory.with_theta({"c_secondary": 0.25 * factory.parameters()["c_secondary"]})

    def rec(speed_kmh: float, seed: int) -> Record:
        v = speed_kmh / 3.6
        u = wheelset_inputs(random_profile(v * T + 40.0, rng=seed), factory.spec.axle_x, v,
                            FS, T)
        rig = TruthRig(worn.plant(), 1 / FS, noise_rms={"acceleration": 0.005}, seed=seed)
        return record_from_blocks([rig.process(SignalBlock(factory.plant().input_names, FS,
                                                           0, u))])

    train, test = rec(300.0, 31), rec(350.0, 32)
    d = diagnose(factory, train, test, n_fit=2)
    assert d.best is not None
    assert (d.best.effect.component, d.best.effect.law) == ("c_secondary", "damping")
    assert d.best.effect.params["c_secondary"] == pytest.approx(1.0e4, rel=0.02)
    assert d.best.error_ratio >= 3.0
    # the carbody's rigid modes lose their damping: the modal view shows it
    assert d.modal is not None
