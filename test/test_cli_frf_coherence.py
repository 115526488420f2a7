"""``export frf`` writes each output's multiple coherence; ``identify`` of the file says why
it finds no mode when the inputs explain too little of the response.

Known answers: the two-storey shear frame of ``test_cli_own_data`` driven by a measured white
base motion and, with ``unmeasured = u``, by another white base motion of ``u`` times its
RMS that the record lacks: the measured input explains ``1 / (1 + u^2)`` of every response's
power, so the multiple coherence is 1 (u = 0; PolyMAX on the FRFs gives the closed-form
frequencies) or 1 / 26 (u = 5; no mode, and the line says 0.04 and why; the estimate over
10 averages of one input is biased up by about 1 / 10, taken off). The real Hayward record
(ground motion at six support channels) gives no mode from its FRFs and the same line.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from test_cli_own_data import exact_f_hz, shear_frame_csv

from modal_twin.cli import main

MAP = "channels:\n  - {name: ground, role: input}\n" \
      "  - {name: floor1, node: '1', direction: x}\n" \
      "  - {name: floor2, node: '2', direction: x}\n"


def _frf_file(tmp_path: Path, unmeasured: float) -> Path:
    csv = shear_frame_csv(tmp_path / "frame.csv", unmeasured=unmeasured)
    (tmp_path / "map.yaml").write_text(MAP)
    assert main(["import", str(csv), "--map", str(tmp_path / "map.yaml"),
                 "--out", str(tmp_path / "bag")]) == 0
    out = tmp_path / "frf.uff"
    assert main(["export", "frf", str(tmp_path / "bag"), "--out", str(out)]) == 0
    return out


def test_coherent_frfs_give_the_frame_modes_and_carry_their_coherence(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    import pyuff

    from modal_twin.io.impact_files import read_frf_coherence, read_frf_matrix
    from modal_twin.io.uff import read_uff

    frf = _frf_file(tmp_path, 0.0)
    sets = pyuff.UFF(str(frf)).read_sets()
    assert [int(s["func_type"]) for s in sets] == [4, 4, 6, 6]
    assert [s["id1"].strip() for s in sets[2:]] == ["multiple coherence 1x",
                                                    "multiple coherence 2x"]
    uff = read_uff(frf)
    f, _, outs, _ = read_frf_matrix(frf, uff)
    got = read_frf_coherence(uff, outs, f)
    assert got is not None
    coh, n_avg, n_in = got
    # 12000 samples, 1 input: identify's Welch blocks (2048 samples, 10 averages)
    assert (coh.shape, n_avg, n_in) == ((2, f.size), 10, 1)
    assert f[1] == pytest.approx(100.0 / 2048)
    band = (f > 1.0) & (f < 20.0)
    assert np.median(coh[:, band]) > 0.95
    assert main(["identify", str(frf), "--f-max", "20", "--out", str(tmp_path / "id")]) == 0
    doc = json.loads((tmp_path / "id" / "modes.json").read_text())
    np.testing.assert_allclose([m["f_hz"] for m in doc["modes"]], exact_f_hz(), rtol=0.01)
    capsys.readouterr()


def test_incoherent_frfs_say_why_no_mode_is_found(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture) -> None:
    frf = _frf_file(tmp_path, 5.0)
    capsys.readouterr()
    assert main(["identify", str(frf), "--f-max", "20"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith("warning: no mode found in ")
    assert "below 0.8" in err[0] and "output-only (modal-twin identify BAG)" in err[0]
    said = float(err[0].split("multiple coherence in the band is ")[1].split(" ")[0])
    assert said == pytest.approx(1 / (1 + 5.0**2), abs=0.02)


def test_a_frf_file_without_coherence_says_so(tmp_path: Path,
                                              capsys: pytest.CaptureFixture) -> None:
    from modal_twin.io.uff import write_uff58_frf

    f = np.linspace(0.0, 50.0, 401)
    H = np.random.default_rng(3).standard_normal((2, 1, f.size)) * (1 + 0j)  # no poles
    write_uff58_frf(tmp_path / "noise.uff", f, H, [(1, 1), (2, 1)], [(3, 1)])
    assert main(["identify", str(tmp_path / "noise.uff")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["warning: no mode found in 0.125-20 Hz: no column of PolyMAX poles is "
                   "stable (the file holds no coherence to tell why); try another band "
                   "(--f-max)"]


def test_hayward_frfs_say_the_ground_motion_is_too_incoherent(
        shared_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    rec = shared_dir / "realdata" / "earthquakes" / "csmip58658_hayward_bridge_2021-04-26.zip"
    if not rec.exists():
        pytest.skip(f"{rec} absent")
    root = Path(__file__).resolve().parents[1]
    assert main(["import", str(rec), "--map",
                 str(root / "config" / "channel_maps" / "csmip58658_hayward.yaml"),
                 "--out", str(tmp_path / "bag")]) == 0
    assert main(["export", "frf", str(tmp_path / "bag"), "--out", str(tmp_path / "f.uff")]) == 0
    capsys.readouterr()
    assert main(["identify", str(tmp_path / "f.uff")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "over 24 averages of 6 inputs), below 0.8" in err[0], err
