"""Identified modes on the structure: pairing by MAC and SEREP expansion (known answers)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from modal_twin.cli import main
from modal_twin.errors import ShapeError
from modal_twin.viz.mode_pairs import (
    channel_nodes,
    expand_shapes,
    pair_by_mac,
    real_shapes,
    sampled_shapes,
)
from modal_twin.viz.scene import building_geometry, building_modes

ROOT = Path(__file__).resolve().parents[2]
BUILDING = ROOT / "config" / "structures" / "building.yaml"


@pytest.fixture(scope="module")
def scene() -> tuple:
    geom = building_geometry(BUILDING)
    basis = building_modes(BUILDING, 12)
    channels = [f"{s}_{a}" for s in sorted(geom.sensors) for a in "xy"]
    where = channel_nodes(channels, geom.node_xyz, geom.sensors)
    return geom, basis, channels, where


def test_model_modes_seen_as_identified_come_back_exactly(scene: tuple) -> None:
    _, basis, _, where = scene
    at_ch = sampled_shapes(basis.shapes, where)
    # "identified": modes 5, 2, 7 of the model at the channels, complex with a phase
    pick = [4, 1, 6]
    ident = at_ch[:, pick] * np.exp(1j * 0.7)
    pairs = pair_by_mac(ident, at_ch)
    assert [j for _, j, _ in pairs] == pick  # the permutation is recovered
    assert all(m == pytest.approx(1.0, abs=1e-9) for *_, m in pairs)
    real = real_shapes(ident)
    expanded = expand_shapes(real, at_ch, basis.shapes)
    for k, j in enumerate(pick):  # the whole-structure shape, up to its scale
        a, b = expanded[k].ravel(), basis.shapes[j].ravel()
        scale = (a @ b) / (b @ b)
        np.testing.assert_allclose(a, scale * b, atol=1e-8 * np.abs(a).max())


def test_unmeasured_entries_are_left_out_of_pairing_and_expansion(scene: tuple) -> None:
    """Modes merged from roving setups carry NaN where no setup that saw them measured:
    the pairing (MAC over the measured entries) and the SEREP expansion (a least-squares
    fit over the measured rows) still recover the model's modes exactly."""
    _, basis, _, where = scene
    at_ch = sampled_shapes(basis.shapes, where)
    pick = [4, 1, 6]
    ident = at_ch[:, pick] * np.exp(1j * 0.7)
    ident[[0, 3], 0] = np.nan  # two channels not measured for the first mode
    ident[5, 2] = np.nan
    pairs = pair_by_mac(ident, at_ch)
    assert [j for _, j, _ in pairs] == pick
    assert all(m == pytest.approx(1.0, abs=1e-9) for *_, m in pairs)
    real = real_shapes(ident)
    assert np.isnan(real[[0, 3], 0]).all() and np.isfinite(real[:, 1]).all()
    expanded = expand_shapes(real, at_ch, basis.shapes)
    assert np.isfinite(expanded).all()
    for k, j in enumerate(pick):
        a, b = expanded[k].ravel(), basis.shapes[j].ravel()
        scale = (a @ b) / (b @ b)
        np.testing.assert_allclose(a, scale * b, atol=1e-8 * np.abs(a).max())


def test_real_shapes_turn_the_largest_entry_real() -> None:
    s = np.array([[1.0 + 1.0j], [-2.0 - 2.0j], [0.5j]])
    r = real_shapes(s)[:, 0]
    # the largest entry turned onto +real; the one in phase opposition stays opposite; the
    # one 45 deg off keeps its projection, 0.5 cos(225 deg)
    np.testing.assert_allclose(r, [-np.sqrt(2), 2 * np.sqrt(2), 0.5 * np.cos(np.radians(225))],
                               atol=1e-12)


def test_a_channel_of_no_sensor_is_refused(scene: tuple) -> None:
    geom = scene[0]
    with pytest.raises(ShapeError, match=r"'roof_x'.*sensor"):
        channel_nodes(["roof_x"], geom.node_xyz, geom.sensors)


def test_view_modes_writes_a_scene_with_the_pairs(scene: tuple, tmp_path: Path,
                                                  capsys: pytest.CaptureFixture) -> None:
    _, basis, channels, where = scene
    at_ch = sampled_shapes(basis.shapes, where)
    modes = [{"f_hz": float(basis.f_hz[j]) * 1.02, "zeta": 0.03,
              "shape_re": at_ch[:, j].tolist(), "shape_im": [0.0] * len(channels)}
             for j in (0, 3)]
    path = tmp_path / "modes.json"
    path.write_text(json.dumps({"modes": modes, "dofs": [{"channel": c} for c in channels]}))
    out = tmp_path / "scene.html"
    assert main(["view", str(BUILDING), "--modes", str(path), "--html", str(out)]) == 0
    page = out.read_text()
    assert "identified 1:" in page and "| model 1:" in page and "MAC 1.000" in page
    assert "identified 2:" in page and "| model 4:" in page
    assert main(["view", str(BUILDING), "--modes", str(tmp_path / "none.json")]) == 2
    assert "not found" in capsys.readouterr().err
