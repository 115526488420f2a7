"""Carbody modal damping per flexible mode (``zeta_cb_<k>``) and its candidate (issue 20, item 7).

Known answers: modal damping adds linearly to a lightly coupled mode, so raising the first
bending mode's ratio from 2 % to 5 % raises the coupled 8.7 Hz bending mode's ratio by
0.03 and leaves the second bending mode (24.9 Hz) at 2 %; a record of a car whose first
bending mode is damped at 5 % puts ``zeta_cb_1`` first among the screened parameters and
its fit recovers 0.05.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from modal_twin.diagnosis.parameters import fit_parameter, screen_parameters
from modal_twin.diagnosis.record import Record, record_from_blocks
from modal_twin.models.loading import load_model
from modal_twin.models.track import random_profile, wheelset_inputs
from modal_twin.models.vehicle import assemble_vehicle
from modal_twin.models.vehicle_factory import VehicleFactory
from modal_twin.rig.truth import TruthRig
from modal_twin.signal_block import SignalBlock

ROOT = Path(__file__).resolve().parents[2]
VEHICLE = ROOT / "config" / "vehicles" / "trailer_car.yaml"
FS = 200.0
T = 16.0


def _mode(vm, f_hz: float) -> tuple[float, float]:
    f, zeta, _ = vm.damped_modes()
    j = int(np.argmin(np.abs(f - f_hz)))
    return float(f[j]), float(zeta[j])


def test_zeta_cb_1_damps_the_first_bending_mode_only() -> None:
    spec = load_model(VEHICLE).spec
    nominal = assemble_vehicle(spec)
    raised = assemble_vehicle(spec, theta={"zeta_cb_1": 0.05})
    f1, z1 = _mode(nominal, 8.7)
    f1r, z1r = _mode(raised, 8.7)
    assert f1r == pytest.approx(f1, rel=1e-3)
    assert z1r - z1 == pytest.approx(0.03, abs=0.002)
    _, z2 = _mode(nominal, 24.9)
    _, z2r = _mode(raised, 24.9)
    assert z2 == pytest.approx(0.02, abs=5e-4)
    assert z2r == pytest.approx(z2, abs=1e-6)


def test_zeta_cb_parameters_default_to_the_carbody_ratio() -> None:
    f = VehicleFactory(VEHICLE)
    p = f.parameters()
    assert [p[f"zeta_cb_{k}"] for k in (1, 2, 3)] == [p["zeta_carbody"]] * 3
    info = f.parameter_info("zeta_cb_1")
    assert (info.kind, info.place, info.family) == ("damping", "carbody", "modal_damping")
    assert f.with_theta({"zeta_cb_2": 0.04}).parameters()["zeta_cb_2"] == 0.04
    # the car's ratio still moves the modes nobody set
    assert f.with_theta({"zeta_carbody": 0.03}).parameters()["zeta_cb_1"] == 0.03


def _record(factory, seed: int, speed_kmh: float) -> Record:
    v = speed_kmh / 3.6
    u = wheelset_inputs(random_profile(v * T + 40.0, rng=seed), factory.spec.axle_x, v, FS,
                        T)
    truth = TruthRig(factory.with_theta({"zeta_cb_1": 0.05}).plant(), 1 / FS,
                     noise_rms={"acceleration": 0.005}, seed=seed)
    return record_from_blocks([truth.process(SignalBlock(factory.plant().input_names, FS, 0,
                                                         u))], source=f"track{seed}")


def test_candidate_recovers_a_first_bending_damping_of_5_percent() -> None:
    factory = load_model(VEHICLE)
    train, test = _record(factory, 31, 300.0), _record(factory, 32, 350.0)
    cands = screen_parameters(factory, train)
    assert cands[0].name == "zeta_cb_1", [(c.name, round(c.gain, 3)) for c in cands[:4]]
    fitted = fit_parameter(factory, cands[0], train, test)
    assert fitted.effect.law == "damping"
    assert fitted.effect.params["zeta_cb_1"] == pytest.approx(0.05, rel=0.03)
