from __future__ import annotations

from pathlib import Path

import numpy as np

from modal_twin.diagnosis.modal_view import modal_view, model_modes
from modal_twin.diagnosis.record import record_from_blocks
from modal_twin.excitation import signals
from modal_twin.models.building import build_building, modal_reduction
from modal_twin.models.building_factory import INPUTS_6DOF, BuildingFactory
from modal_twin.rig.truth import TruthRig
from modal_twin.signal_block import SignalBlock

BUILDING = Path(__file__).resolve().parents[2] / "config" / "structures" / "building.yaml"


def test_model_modes_equal_the_modal_reduction() -> None:
    plant = BuildingFactory(BUILDING).plant()
    f, zeta, shapes = model_modes(plant, list(range(42)))
    red = modal_reduction(build_building(BUILDING))
    # |lambda| of the damped system vs the undamped modes: non-proportional device damping
    # (8 % in the isolation modes) moves those by 0.4 %, the rest by < 1e-3
    np.testing.assert_allclose(f[:3], red.f_hz[:3], rtol=5e-3)
    np.testing.assert_allclose(f[3:9], red.f_hz[3:9], rtol=1e-3)
    assert shapes.shape == (42, f.size)
    assert np.all((zeta > 0) & (zeta < 0.2))


def test_modal_view_shows_a_stiffness_error_in_the_superstructure_modes() -> None:
    truth = BuildingFactory(BUILDING, theta={"E_Fc27": 2.915e10 * 0.8}).plant()
    rig = TruthRig(truth, 1e-3, noise_rms={"acceleration": 0.002}, seed=2)
    rng = np.random.default_rng(2)
    ag = signals.band_limited_random(6, 60.0, 1000.0, f_min_hz=0.2, f_max_hz=20.0, rms=1.0,
                                     rng=rng) * np.array([0.5, 0.5, 0.2, 0, 0, 0])[:, None]
    rec = record_from_blocks([rig.process(SignalBlock(INPUTS_6DOF, 1000.0, 0, ag))])
    view = modal_view(BuildingFactory(BUILDING).plant(), rec)
    iso = view.f_id_hz < 1.0
    assert iso.sum() == 3
    df = view.f_model_hz / view.f_id_hz - 1
    assert np.nanmax(np.abs(df[iso])) < 0.01  # the isolation modes are right
    sup = (view.f_id_hz > 4.0) & (view.f_id_hz < 10.0)
    assert np.all(df[sup] > 0.03)  # the nominal model is too stiff above
    assert np.all(view.mac[sup] > 0.9)
