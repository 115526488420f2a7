"""A record's motion on the structure (``modal-twin view MODEL --bag BAG``), known answers."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from modal_twin.cli import main
from modal_twin.excitation import signals
from modal_twin.io.imported import write_imported
from modal_twin.models.building_factory import INPUTS_6DOF
from modal_twin.models.effects import EffectSpec
from modal_twin.models.loading import load_model
from modal_twin.models.sensors import table_channels
from modal_twin.rig.truth import TruthRig
from modal_twin.signal_block import SignalBlock
from modal_twin.viz.motion import displacement_from_acceleration, record_motion, strongest_window

ROOT = Path(__file__).resolve().parents[2]
BUILDING = ROOT / "config" / "structures" / "building.yaml"
FS = 200.0


def test_displacement_from_acceleration_is_the_double_integral() -> None:
    t = np.arange(4000) / FS  # 20 s: whole periods of 0.5, 2 and 3.5 Hz
    x = 0.02 * np.sin(2 * np.pi * 2.0 * t) - 0.004 * np.cos(2 * np.pi * 3.5 * t)
    acc = (-(2 * np.pi * 2.0) ** 2 * 0.02 * np.sin(2 * np.pi * 2.0 * t)
           + (2 * np.pi * 3.5) ** 2 * 0.004 * np.cos(2 * np.pi * 3.5 * t))
    slow = 0.3 + 0.05 * np.sin(2 * np.pi * 0.5 * t)  # offset and content below the cut-off
    d = displacement_from_acceleration(np.vstack([acc + slow, 2 * acc]), FS, 1.0)
    np.testing.assert_allclose(d[0], x, atol=1e-12)
    np.testing.assert_allclose(d[1], 2 * x, atol=1e-12)


def test_strongest_window_finds_the_burst() -> None:
    x = np.zeros((2, 1000))
    x[1, 600:650] = 1.0
    assert strongest_window(x, 50) == slice(600, 650)
    assert strongest_window(x, 5000) == slice(0, 1000)


def test_record_motion_expands_exactly_and_scores_each_sensor() -> None:
    rng = np.random.default_rng(0)
    shapes = rng.normal(size=(3, 10, 3))  # 3 modes on 10 nodes
    where = [(0, 0), (4, 1), (7, 2), (9, 0), (2, 1)]
    at_ch = np.stack([shapes[:, n, a] for n, a in where])  # (5, 3)
    q = rng.normal(size=(3, 400))
    meas = at_ch @ q
    chans = ["S1_x", "S2_y", "S3_z", "S4_x", "S1_y"]
    twin = meas.copy()
    twin[1] *= 0.9  # the twin 10 % low at S2
    mo = record_motion(chans, meas, twin, FS, at_ch, shapes, window_s=1.0, n_frames=50)
    assert mo.dt_s == pytest.approx(4 / FS) and mo.measured.shape == (50, 10, 3)
    k = round(mo.t0_s * FS)
    np.testing.assert_allclose(mo.measured[0], np.einsum("k,knd->nd", q[:, k], shapes),
                               atol=1e-10)
    assert mo.fit == pytest.approx(1.0)
    assert mo.sensor_nrmse == pytest.approx({"S1": 0.0, "S2": 0.1, "S3": 0.0, "S4": 0.0})


def _bag(out: Path, effects: list[EffectSpec]) -> Path:
    plant = load_model(BUILDING).plant(effects)
    rng = np.random.default_rng(5)
    ag = signals.band_limited_random(6, 16.0, FS, f_min_hz=0.2, f_max_hz=15.0, rms=1.0,
                                     rng=rng) * np.array([1.5, 1.5, 0, 0, 0, 0])[:, None]
    blk = TruthRig(plant, 1 / FS).process(SignalBlock(INPUTS_6DOF, FS, 0, ag))
    return write_imported(out, blk, [*table_channels(plant), *plant.channels])


@pytest.fixture(scope="module")
def bags(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("motion")
    return {"nominal": _bag(d / "nominal", []),
            "friction": _bag(d / "friction", [EffectSpec("ESB1", "stick_slip",
                                                         {"mu_s": 0.06, "mu_k": 0.04})])}


def _worst(html_text: str) -> float:
    line = html_text.split("worst: ")[1].split("</div>")[0]
    return float(line.split(",")[0].split()[-2])


def test_view_bag_draws_measured_beside_the_twin(bags: dict[str, Path], tmp_path: Path,
                                                 chromium) -> None:
    from matplotlib.image import imread

    page = tmp_path / "nominal.html"
    assert main(["view", str(BUILDING), "--bag", str(bags["nominal"]), "--html",
                 str(page)]) == 0
    text = page.read_text()
    assert _worst(text) < 1e-3  # the nominal model beside its own response
    assert "(fit 100.0 %)" in text  # the model's modes span its own motion
    friction = tmp_path / "friction.html"
    assert main(["view", str(BUILDING), "--bag", str(bags["friction"]), "--html",
                 str(friction)]) == 0
    assert _worst(friction.read_text()) > 10.0  # the friction the model lacks shows
    dom, console = chromium(friction)
    assert "data-scene-commands" in dom
    assert not [c for c in console if "Uncaught" in c or "rror" in c]
    shot = tmp_path / "motion.png"
    chromium(friction, screenshot=shot)
    img = imread(shot)[..., :3]
    blue = (img[..., 2] > 0.55) & (img[..., 0] < 0.3) & (img[..., 1] > 0.35)
    orange = (img[..., 0] > 0.75) & (img[..., 1] < 0.55) & (img[..., 2] < 0.45)
    assert blue.sum() > 200 and orange.sum() > 200


def test_view_bag_bad_input_is_one_line(bags: dict[str, Path], tmp_path: Path,
                                        capsys: pytest.CaptureFixture) -> None:
    assert main(["view", str(BUILDING), "--bag", str(tmp_path / "none")]) == 2
    assert main(["view", str(BUILDING), "--bag", str(bags["nominal"]), "--modes",
                 str(bags["nominal"] / "channel_map.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"modal-twin view: bag {tmp_path / 'none'} not found",
                   "modal-twin view: give --modes or --bag, not both"]
