"""Truth rig vs nominal twin on the building: where the error goes, and that it is real."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from modal_twin.errors import ConfigError, OptionError, SignalError
from modal_twin.excitation import signals
from modal_twin.models.building_factory import INPUTS_6DOF
from modal_twin.models.effects import EffectSpec
from modal_twin.models.loading import load_model
from modal_twin.models.rig_file import load_rig
from modal_twin.rig.truth import TruthRig, rig_channels
from modal_twin.signal_block import SignalBlock
from modal_twin.twin.runner import TwinRunner

ROOT = Path(__file__).resolve().parents[2]
BUILDING = ROOT / "config" / "structures" / "building.yaml"


def drive(scale: float, seconds: float = 20.0, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    ag = signals.band_limited_random(6, seconds, 1000.0, f_min_hz=0.2, f_max_hz=20.0,
                                     rms=1.0, rng=rng)
    return ag * (scale * np.array([1.0, 1.0, 0.3, 0, 0, 0]))[:, None]


def run(truth_effects: list[EffectSpec], ag: np.ndarray, noise: dict[str, float] | None = None
        ) -> TwinRunner:
    truth = TruthRig(load_model(BUILDING).plant(truth_effects), 1e-3, noise_rms=noise)
    twin = TwinRunner(load_model(BUILDING).plant(), 1000.0, window_s=ag.shape[1] / 1000.0)
    for k in range(0, ag.shape[1], 100):
        twin.step(truth.process(SignalBlock(INPUTS_6DOF, 1000.0, k, ag[:, k:k + 100])))
    return twin


def test_nominal_truth_gives_zero_error_and_noise_floor() -> None:
    twin = run([], drive(1.0, 5.0))
    m = twin.metrics()
    assert m is not None
    assert np.nanmax(m.residual_pct) < 1e-6  # same model both sides: identical
    twin = run([], drive(1.0, 5.0), noise={"acceleration": 0.002})
    m = twin.metrics()
    acc = [i for i, c in enumerate(twin.compare or []) if c.startswith("F")]
    # residual = noise only: 0.002 / RMS(acc) within 20 %
    np.testing.assert_allclose(m.residual_pct[acc] / 100,  # type: ignore[union-attr]
                               0.002 / m.rms_measured[acc], rtol=0.2)  # type: ignore[union-attr]


def test_stick_slip_error_is_at_esb1_and_grows_with_amplitude() -> None:
    s1 = [EffectSpec("ESB1", "stick_slip", {"mu_s": 0.06, "mu_k": 0.04})]
    low = run(s1, drive(0.25)).metrics()
    high_twin = run(s1, drive(1.5))
    high = high_twin.metrics()
    assert low is not None and high is not None
    names = high_twin.compare or []
    assert np.nanmax(low.residual_pct[:42]) < 3.0  # sticking: nothing to see at low level
    worst = names[int(np.nanargmax(high.residual_pct))]
    assert worst.startswith("ESB1_f")  # the device that slides
    i = names.index("F0_C1_x")  # base corner over ESB1
    assert high.residual_pct[i] > 10 * low.residual_pct[i]
    z = [k for k, n in enumerate(names[:42]) if n.endswith("_z")]
    x = [k for k, n in enumerate(names[:42]) if n.endswith("_x")]
    assert np.mean(high.residual_pct[z]) < 0.2 * np.mean(high.residual_pct[x])


def test_channel_map_and_bad_input(tmp_path: Path) -> None:
    rig = load_rig(ROOT / "config" / "rigs" / "s1_stick_slip.yaml")
    chans = rig_channels(rig)
    assert len(chans) == 6 + 42 + 24
    acc = next(c for c in chans if c.name == "F0_C1_x")
    assert (acc.quantity, acc.unit, acc.location, acc.direction) == (
        "acceleration", "m/s^2", "F0_C1", "x")
    assert acc.sensitivity == pytest.approx(0.10197)
    with pytest.raises(OptionError, match="unknown component 'ESB9'"):
        load_model(BUILDING).plant([EffectSpec("ESB9", "stick_slip", {})])
    with pytest.raises(OptionError, match="unknown effect law 'magic'"):
        load_model(BUILDING).plant([EffectSpec("RB1", "magic", {})])
    with pytest.raises(OptionError, match=r"unknown parameters \['colour'\]"):
        load_model(BUILDING).plant([EffectSpec("RB1", "bilinear", {"colour": 1.0})])
    truth = TruthRig(load_model(BUILDING).plant(), 1e-3)
    with pytest.raises(SignalError, match=r"lacks channels \['arz'\]"):
        truth.process(SignalBlock(INPUTS_6DOF[:5], 1000.0, 0, np.zeros((5, 10))))
    twin = TwinRunner(load_model(BUILDING).plant(), 1000.0)
    with pytest.raises(SignalError, match=r"no channel that drives the model.s inputs"):
        twin.step(SignalBlock(("x",), 1000.0, 0, np.zeros((1, 10))))
    bad = tmp_path / "rig.yaml"
    bad.write_text("structure: nowhere.yaml\n")
    with pytest.raises(ConfigError, match="key 'structure': no such file"):
        load_rig(bad)
    bad.write_text(f"structure: {BUILDING}\neffects: [{{component: RB1}}]\n")
    with pytest.raises(ConfigError, match=r"key 'effects\[0\]'"):
        load_rig(bad)
    bad.write_text(f"structure: {BUILDING}\nnoise_rms: {{acceleration: -1}}\n")
    with pytest.raises(ConfigError, match=r"noise_rms.acceleration': expected a number >= 0"):
        load_rig(bad)
