"""The twin node's work on the 3D car (issue 23, item 7): frames of the track in, residual out."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from modal_twin.acquisition.continuity import Verdict
from modal_twin.models.loading import load_model
from modal_twin.models.track3d import random_track_3d, track_inputs_3d
from modal_twin.rig.truth import TruthRig
from modal_twin.signal_block import SignalBlock
from modal_twin.twin.session import TwinSession

ROOT = Path(__file__).resolve().parents[2]
CAR3D = str(ROOT / "config" / "vehicles" / "trailer_car_3d.yaml")
FS = 200.0


def _frames(theta: dict[str, float], seconds: float = 4.0, block: int = 100
            ) -> list[SignalBlock]:
    """Noise-free frames of the 3D car (with ``theta``) over a random track at its speed."""
    factory = load_model(CAR3D, theta=theta)
    plant = factory.plant()
    v = factory.spec.speed
    u = track_inputs_3d(random_track_3d(v * seconds + 60.0, rng=4), factory.spec.axle_x, v,
                        FS, seconds, start_m=30.0)
    rig = TruthRig(plant, 1.0 / FS, seed=1, noise_rms={"acceleration": 0.0,
                                                       "displacement": 0.0, "force": 0.0})
    return [rig.process(SignalBlock(plant.input_names, FS, k, u[:, k:k + block],
                                    stamp_ns=10**18 + k * 5 * 10**6))
            for k in range(0, u.shape[1], block)]


def _worst(twin: TwinSession, frames: list[SignalBlock], channel: str) -> float:
    """Largest residual of ``channel`` over the frames, relative to its measured peak."""
    res, meas = [], []
    for b in frames:
        v, step = twin.frame(b)
        assert v.verdict is not Verdict.NONFINITE and step is not None
        i = step.residual.channel_names.index(channel)
        res.append(step.residual.data[i])
        meas.append(b.select([channel]).data[0])
    return float(np.abs(np.concatenate(res)).max() / np.abs(np.concatenate(meas)).max())


def test_the_3d_car_beside_its_own_response_leaves_no_residual(tmp_path: Path) -> None:
    twin = TwinSession(CAR3D, FS, 2.0, tmp_path)
    assert "floor_front_y" in twin.plant.channel_names
    assert _worst(twin, _frames({}), "floor_front_y") <= 1e-6


def test_a_worn_yaw_damper_shows_until_its_version_is_loaded(tmp_path: Path) -> None:
    c = 0.3 * load_model(CAR3D).parameters()["c_yaw_damper_1L"]
    worn = _frames({"c_yaw_damper_1L": c})
    twin = TwinSession(CAR3D, FS, 2.0, tmp_path)
    assert _worst(twin, worn, "floor_front_y") > 0.05  # the nominal car misses it
    assert twin.load_version("", {"c_yaw_damper_1L": c}, "worn") == "worn"
    assert _worst(twin, worn, "floor_front_y") <= 1e-6  # a replay from the start: from rest
