"""Test geometry (UFF nodes and trace lines) as a scene, and identified modes on it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from modal_twin.cli import main
from modal_twin.commands.view import load_measured_geometry
from modal_twin.errors import ConfigError
from modal_twin.viz.measured_geometry import MeasuredGeometry, geometry_from_uff, modes_on_nodes

UFF = Path(__file__).resolve().parents[3] / "shared" / "realdata" / "uff"
SQUARE = {"nodes": {"1": [0, 0, 0], "2": [1, 0, 0], "3": [1, 1, 0], "4": [0, 1, 0],
                    "10": [0, 0, 2]},
          "trace_lines": [{"nodes": [1, 2, 3, 0, 4, 1, 9]}, {"nodes": [2, 1]}]}


def test_trace_lines_become_edges_and_pen_up_breaks_them() -> None:
    geom, ids = geometry_from_uff(SQUARE, "square", ["3", "77"])
    assert ids == ["1", "2", "3", "4", "10"]  # numeric order
    edges = {(ids[a], ids[b]) for a, b in geom.edges}
    assert edges == {("1", "2"), ("2", "3"), ("1", "4")}  # 3-0-4 lifts the pen; 9 unknown
    assert list(geom.sensors) == ["3"] and geom.sensors["3"] == pytest.approx([1, 1, 0])
    with pytest.raises(ConfigError, match="no nodes"):
        geometry_from_uff({"nodes": {}}, "empty")


def test_modes_are_placed_at_their_nodes_and_directions() -> None:
    geom, ids = geometry_from_uff(SQUARE, "square")
    mg = MeasuredGeometry(geom, ids, {"acc_a": ("4", "-y")})
    shapes = np.array([[1.0, 0.5], [2.0, 0.0], [4.0, 0.0], [-3.0, 1.0]])  # 4 entries, 2 modes
    dofs = [{"channel": "c1", "node_label": "2", "direction": "z"},
            {"channel": "c2", "node_label": "10", "direction": "x"},
            {"channel": "c3", "node_label": "10", "direction": "x"},  # same DOF: averaged
            {"channel": "acc_a", "node_label": "?", "direction": "?"}]  # from the map
    modes = modes_on_nodes(mg, [3.0, 5.0], [0.01, 0.02], shapes, dofs)
    # real_shapes turns each mode so that its largest entry is real and positive
    first = shapes[:, 0] * np.sign(shapes[np.argmax(np.abs(shapes[:, 0])), 0])
    want = np.zeros((5, 3))
    want[1, 2], want[4, 0], want[3, 1] = first[0], (first[1] + first[2]) / 2, -first[3]
    np.testing.assert_allclose(modes.shapes[0], want, atol=1e-12)
    assert "4 of 4 channels at nodes" in modes.labels[0]
    with pytest.raises(ConfigError, match="none of the 1 shape entries"):
        modes_on_nodes(mg, [1.0], [0.0], np.ones((1, 1)), [{"node_label": "99"}])


@pytest.mark.skipif(not UFF.is_dir(), reason="../shared/realdata/uff absent")
def test_view_of_a_real_test_geometry_and_its_identified_modes(tmp_path: Path,
                                                               chromium) -> None:
    geo = UFF / "geometry_testlab_15_18_82_161_164.uff"
    page = tmp_path / "geometry.html"
    assert main(["-q", "view", str(geo), "--html", str(page)]) == 0
    assert "test geometry, 36 nodes" in page.read_text()
    bag = tmp_path / "bag"
    assert main(["-q", "import", str(UFF / "accel_4ch_3200hz_uff58b.uff"), str(geo),
                 "--out", str(bag)]) == 0
    mg = load_measured_geometry(bag)
    assert sorted(mg.geom.sensors) == ["1", "2", "3"]  # the record's channels sit at 1, 2, 3
    assert main(["-q", "identify", str(bag), "--out", str(tmp_path / "id")]) == 0
    modes_json = tmp_path / "id" / "modes.json"
    n_modes = len(json.loads(modes_json.read_text())["modes"])
    out = tmp_path / "modes.html"
    assert main(["-q", "view", str(bag), "--modes", str(modes_json), "--html", str(out)]) == 0
    text = out.read_text()
    assert text.count("(4 of 4 channels at nodes)") == n_modes > 0
    dom, console = chromium(out)
    assert "data-scene-commands" in dom
    assert not [c for c in console if "Uncaught" in c or "rror" in c]


def test_an_unmeasured_entry_is_left_out_of_its_mode_only() -> None:
    """A mode merged from some roving setups has NaN where none of them measured: that
    entry is left out of its mode (the node's DOF stays at rest, the channel measured at
    the same DOF alone sets it), the other mode keeps both entries' mean."""
    geom, ids = geometry_from_uff(SQUARE, "square")
    mg = MeasuredGeometry(geom, ids, {})
    shapes = np.array([[1.0, 0.5], [2.0, np.nan], [4.0, 3.0], [np.nan, 1.0]])
    dofs = [{"channel": "c1", "node_label": "2", "direction": "z"},
            {"channel": "c2", "node_label": "10", "direction": "x"},
            {"channel": "c3", "node_label": "10", "direction": "x"},  # same DOF as c2
            {"channel": "c4", "node_label": "4", "direction": "y"}]
    modes = modes_on_nodes(mg, [3.0, 5.0], [0.01, 0.02], shapes, dofs)
    assert np.isfinite(modes.shapes).all()
    i2, i10, i4 = ids.index("2"), ids.index("10"), ids.index("4")
    assert modes.shapes[0, i10, 0] == pytest.approx(3.0)  # (2 + 4) / 2
    assert modes.shapes[1, i10, 0] == pytest.approx(3.0)  # c3 alone: c2 not measured
    assert modes.shapes[0, i4, 1] == 0.0 and modes.shapes[1, i4, 1] == pytest.approx(1.0)
    assert modes.shapes[1, i2, 2] == pytest.approx(0.5)
