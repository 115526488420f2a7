"""The loop without ROS: simulated test -> identification -> updating -> twin error falls."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.signal as sig

from modal_twin.identification import n4sid, select_modes, stabilization_diagram
from modal_twin.models.building import DEFAULT_BUILDING_YAML
from modal_twin.models.building_factory import INPUTS_6DOF
from modal_twin.models.loading import load_model
from modal_twin.signal_block import SignalBlock
from modal_twin.twin.runner import TwinRunner
from modal_twin.twin.simulator import simulate
from modal_twin.updating.run import update_model

FS = 50.0


def test_identify_update_and_the_twin_error_falls(tmp_path: Path) -> None:
    truth = {"E_Fc36": 3.278e10 * 0.85, "E_Fc27": 2.915e10 * 1.12, "E_Fc21": 2.585e10 * 0.88}
    plant = load_model(DEFAULT_BUILDING_YAML, theta=truth).plant()
    rng = np.random.default_rng(4)
    b, a = sig.butter(4, 20.0, fs=FS)
    ag = np.zeros((6, int(200 * FS)))
    ag[:3] = sig.lfilter(b, a, rng.standard_normal((3, ag.shape[1])), axis=1)
    meas = plant.measure(simulate(plant.system, ag, 1 / FS))
    acc = meas[:42] + 0.02 * meas[:42].std(axis=1, keepdims=True) * rng.standard_normal(
        (42, ag.shape[1]))
    sw = n4sid(ag[:3], acc, FS, orders=np.arange(20, 62, 4), f_min_hz=4.0)
    mm = select_modes(stabilization_diagram(sw), f_range_hz=(0.3, 21.0))
    upd = update_model(DEFAULT_BUILDING_YAML, mm, plant.channel_names[:42], tmp_path / "m")
    assert upd.version.version == 1

    def twin_error(model: Path) -> float:
        twin = TwinRunner(load_model(model).plant(), FS, window_s=200.0)
        frame = SignalBlock((*(f"table_{n}" for n in INPUTS_6DOF), *plant.channel_names[:42]),
                            FS, 0, np.vstack([ag, acc]))
        twin.step(frame)
        m = twin.metrics()
        assert m is not None
        return float(np.mean(m.residual_pct))

    before = twin_error(Path(DEFAULT_BUILDING_YAML))
    after = twin_error(upd.version.path)  # type: ignore[arg-type]
    assert after < 0.5 * before, (before, after)
