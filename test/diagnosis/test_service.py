"""The diagnosis node's work without ROS: window, split, diagnose, add (known answers)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from modal_twin.diagnosis.service import DiagnosisService
from modal_twin.errors import ModalTwinError
from modal_twin.excitation import signals
from modal_twin.models.building_factory import INPUTS_6DOF
from modal_twin.models.loading import load_model
from modal_twin.rig.truth import TruthRig
from modal_twin.signal_block import SignalBlock

ROOT = Path(__file__).resolve().parents[2]
BUILDING = ROOT / "config" / "structures" / "building.yaml"


def _frames(seconds: float, seed: int, block: int = 250) -> list[SignalBlock]:
    """Frames of the nominal building (nothing hidden), 1 kHz, through a noisy truth rig."""
    rig = TruthRig(load_model(BUILDING).plant(), 1e-3, seed=seed,
                   noise_rms={"acceleration": 0.002, "displacement": 1e-5, "force": 100.0})
    ag = signals.band_limited_random(6, seconds, 1000.0, f_min_hz=0.2, f_max_hz=20.0, rms=1.0,
                                     rng=np.random.default_rng(seed))
    ag *= np.array([1.0, 1.0, 0.3, 0.0, 0.0, 0.0])[:, None]
    return [rig.process(SignalBlock(INPUTS_6DOF, 1000.0, k, ag[:, k:k + block],
                                    stamp_ns=10**18 + k * 10**6))
            for k in range(0, ag.shape[1], block)]


@pytest.fixture(scope="module")
def service(tmp_path_factory: pytest.TempPathFactory) -> DiagnosisService:
    s = DiagnosisService(BUILDING, tmp_path_factory.mktemp("models"), buffer_s=60.0,
                         train_fraction=0.6, n_fit=1)
    for b in _frames(8.0, seed=5):
        s.add_frame(b)
    return s


def test_window_splits_by_the_training_fraction(service: DiagnosisService) -> None:
    train, test = service.records(0.0)
    assert train.n_samples == 4800  # 60 % of 8 s at 1 kHz
    # the held-out part is simulated from the start (warm-up) and scored on its 3.2 s
    assert (test.skip, test.scored.shape[1]) == (4800, 3200)
    train5, test5 = service.records(5.0)  # the last 5 s only
    assert (train5.n_samples, test5.scored.shape[1]) == (3000, 2000)


def test_nominal_structure_is_clean_and_nothing_is_added(service: DiagnosisService) -> None:
    d = service.diagnose(0.0)
    assert not d.significant and "nothing significant" in d.summary
    with pytest.raises(ModalTwinError, match="nothing to add: nothing significant"):
        service.add()
    assert not list(service.versions_dir.glob("*.yaml"))  # nothing half-written


def test_empty_window_is_refused(tmp_path: Path) -> None:
    empty = DiagnosisService(BUILDING, tmp_path, buffer_s=10.0, train_fraction=0.6, n_fit=1)
    with pytest.raises(ModalTwinError, match="no measurement frames"):
        empty.diagnose(0.0)
