"""The HTML report: every section from synthetic data, decoded in headless Chromium."""

from __future__ import annotations

import html
import re
from pathlib import Path

import numpy as np
import pytest

from modal_twin.cli import main
from modal_twin.models.effects import EffectSpec
from modal_twin.models.versions import ModelVersion, write_version
from modal_twin.viz.report import RecordData, RunData, render_report, write_report

ROOT = Path(__file__).resolve().parents[2]
BUILDING = ROOT / "config" / "structures" / "building.yaml"

# appended to a copy of the page: counts the images and those that did not decode
_PROBE = """<script>
const imgs = Array.from(document.images);
document.body.dataset.probe = "pending";
const done = () => imgs.every(i => i.complete);
const report = () => {
  const bad = imgs.filter(i => !(i.naturalWidth > 0)).length;
  document.body.dataset.probe = imgs.length + "/" + bad;
};
const poll = setInterval(() => { if (done()) { clearInterval(poll); report(); } }, 50);
</script>"""


def _synthetic(versions: list[ModelVersion]) -> RunData:
    from test_figures import _diagram

    rng = np.random.default_rng(1)
    names = (*(f"F{k}_C1_{d}" for k in range(5) for d in "xyz"), "ESB1_dx", "ESB1_fx")
    t = np.linspace(0.0, 20.0, 4000)
    u = 0.01 * np.sin(2 * np.pi * 0.7 * t)
    f_hz = np.linspace(0.2, 20.0, 200)
    H = 1.0 / (1.0 - (f_hz / 3.0) ** 2 + 0.1j * f_hz / 3.0)
    rec = RecordData("2_train_random", names, rng.uniform(0.1, 30.0, len(names)),
                     "building@nominal#v0", {}, {"ESB1 x": (u, 8e4 * np.tanh(200 * u))},
                     {"ESB1 x": (u, np.gradient(u, t), 8e4 * np.tanh(200 * u))})
    return RunData(
        "synthetic run", [rec], versions, scene_html="<html><body>scene</body></html>",
        stabilization=_diagram(), selected_f_hz=np.array([1.0]),
        modes={"f_id_hz": [1.0, 2.0], "zeta_id": [0.02, 0.03], "f_model_hz": [1.05, 2.0],
               "mac": [0.99, 0.6]},
        mac=(np.eye(2), ["id 1", "id 2"], ["model 1", "model 2"]),
        frf=(f_hz, np.vstack([H, 2 * H]), ["F1_C1_x", "F2_C1_x"], np.vstack([H, H])))


@pytest.fixture
def versions(tmp_path: Path) -> list[ModelVersion]:
    folder = tmp_path / "run" / "models"
    v0 = write_version(folder, ModelVersion(BUILDING, note="nominal",
                                            errors={"F0_C1_x": 30.0, "ESB1_dx": 20.0}))
    v1 = write_version(folder, ModelVersion(
        BUILDING, note="added stick_slip at ESB1", errors={"F0_C1_x": 0.1, "ESB1_dx": 0.2},
        effects=(EffectSpec("ESB1", "stick_slip", {"Fk": 7e4}),)))
    return [v0, v1]


def test_every_section_present(versions: list[ModelVersion]) -> None:
    page = render_report(_synthetic(versions))
    for section in ("scene", "identification", "frf", "where", "evidence", "hysteresis",
                    "history"):
        assert f'<section id="{section}">' in page
    assert len(re.findall(r'<img alt="[^"]*" src="data:image/png;base64,', page)) == 7
    assert "http://" not in page and "https://" not in page  # nothing fetched
    assert "stick_slip at ESB1" in page


def test_empty_run_has_no_sections() -> None:
    page = render_report(RunData("nothing"))
    assert "<section" not in page and "<h1>nothing</h1>" in page


def test_report_renders_in_chromium(versions: list[ModelVersion], tmp_path: Path,
                                    chromium) -> None:
    out = write_report(_synthetic(versions), tmp_path / "report.html")
    probe = tmp_path / "probe.html"
    probe.write_text(out.read_text().replace("</body>", _PROBE + "</body>"))
    dom, console = chromium(probe, budget_ms=60000)
    assert 'data-probe="7/0"' in dom  # 7 images, none undecoded
    assert not [c for c in console if "Uncaught" in c or "rror" in c]
    shot = tmp_path / "report.png"
    chromium(out, screenshot=shot, size="1200,3000")
    from matplotlib.image import imread

    img = imread(shot)[..., :3]
    assert img.std() > 0.05  # not a blank page


def test_report_command_on_a_run_folder(versions: list[ModelVersion], tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    run = tmp_path / "run"
    assert main(["--quiet", "report", str(run), "--n-modes", "2"]) == 0
    page = (run / "report.html").read_text()
    assert '<section id="history">' in page and '<section id="scene">' in page
    assert "ESB1 (stick_slip)" in page  # the scene's caption names the blamed place
    assert capsys.readouterr().out.strip() == f"report: {run / 'report.html'}"
    assert main(["report", str(tmp_path / "missing")]) == 2


def test_view_html(tmp_path: Path) -> None:
    out = tmp_path / "scene.html"
    assert main(["--quiet", "view", str(BUILDING), "--n-modes", "1", "--html", str(out)]) == 0
    page = out.read_text()
    assert "MeshCat.Viewer" in page and "mode 1:" in page


def test_model_loops_drive_the_model_device_with_the_measured_drift() -> None:
    from modal_twin.commands.report import model_loops
    from modal_twin.diagnosis.record import Record
    from modal_twin.models.devices import BilinearHysteretic, CubicSpring

    fs = 200.0
    t = np.arange(0.0, 10.0, 1.0 / fs)
    u = np.vstack([0.02 * np.sin(2 * np.pi * 0.5 * t), 0.01 * np.sin(2 * np.pi * 0.8 * t)])
    rec = Record(fs, ("ax",), np.zeros((1, t.size)), ("ESB1_dx", "ESB1_dy", "F0_C1_x"),
                 np.vstack([u, np.zeros(t.size)]), "t")
    # a cubic spring without damping: the closed form of its force on the drift
    got = model_loops(rec, {"ESB1": CubicSpring(1e6, 5e8, [0.0, 0.0]),
                            "RB9": BilinearHysteretic(1e6, 2e5, 0.01, [0.0, 0.0])})
    assert set(got) == {"ESB1 x", "ESB1 y"}  # RB9 has no measured drift here
    for i, a in enumerate("xy"):
        np.testing.assert_array_equal(got[f"ESB1 {a}"][0], u[i])
        np.testing.assert_allclose(got[f"ESB1 {a}"][1], 1e6 * u[i] + 5e8 * u[i] ** 3,
                                   rtol=1e-12)


def test_report_shows_the_heldout_record_beside_both_versions(tmp_path: Path) -> None:
    """Known answer: the record is the S1 truth; v1 carries exactly its friction, so the
    green twin (v1) matches to round-off where the orange one (v0) is far off."""
    from test_motion import _bag

    from modal_twin.commands.report import make_report

    friction = EffectSpec("ESB1", "stick_slip", {"mu_s": 0.06, "mu_k": 0.04})
    run = tmp_path / "run"
    write_version(run / "models", ModelVersion(BUILDING, note="nominal"))
    write_version(run / "models", ModelVersion(BUILDING, note="friction",
                                               effects=(friction,)))
    _bag(run / "3_heldout_quake" / "bag", [friction])
    page = make_report(run).read_text()
    assert '<section id="record">' in page
    text = html.unescape(re.sub(r"<[^>]+>", " ", html.unescape(page)))
    worst = {m.group(1): float(m.group(2)) for m in
             re.finditer(r"(orange|green): v\d, worst: \S+ ([\d.]+) %", text)}
    assert worst["orange"] > 10.0 and worst["green"] < 1e-3
