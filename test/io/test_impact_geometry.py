"""The launched impact test's FRFs and modes carry the measured points' geometry.

The acquisition node in impact mode (``impact_tracking_frame``) reads its rig file
(``config/rigs/tracking_frame_hammer.yaml``: the frame file of the tracking frame) and writes
``impact/frf.uff`` with the geometry :func:`structure_geometry` gives for its hammer test's
channels. Known answer: the shipped frame (half width 0.3 m, height 0.5 m, 3 elements per
half base / arm / half axis) puts base node 100 + i at x = -0.3 + 0.1 i, arm nodes 200 + i /
300 + i at x = -/+0.3, z = i / 6, axis node 400 + i at x = -0.3 + 0.1 i, z = 0.5 (y = 0);
the trace line goes round the frame through the measured nodes.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy import linalg

ROOT = Path(__file__).resolve().parents[2]
RIG = ROOT / "config" / "rigs" / "tracking_frame_hammer.yaml"
FRAME = ROOT / "config" / "structures" / "tracking_frame.yaml"
AROUND = [101, 105, 301, 303, 405, 404, 402, 401, 203, 201, 101]


def expected(n: int) -> list[float]:
    member, i = divmod(n, 100)
    x = {1: -0.3 + 0.1 * i, 2: -0.3, 3: 0.3, 4: -0.3 + 0.1 * i}[member]
    z = {1: 0.0, 2: i * 0.5 / 3, 3: i * 0.5 / 3, 4: 0.5}[member]
    return [x, 0.0, z]


def test_the_frame_file_keeps_its_nodes_and_outline_through_npz(tmp_path: Path) -> None:
    from modal_twin.models.matrix_model import load_matrix_model, sparse_members
    from modal_twin.models.tracking_frame import frame_matrices, frame_outline

    mm = load_matrix_model(FRAME)
    assert mm.node_xyz is not None and mm.trace_nodes is not None
    np.testing.assert_array_equal(mm.node_xyz, frame_matrices()["node_xyz"])
    assert mm.trace_nodes.tolist() == frame_outline()
    for row in mm.node_xyz:
        np.testing.assert_allclose(row[1:], expected(int(row[0])), atol=1e-12)
    np.savez(tmp_path / "m.npz", **sparse_members(mm.to_arrays()))
    back = load_matrix_model(tmp_path / "m.npz")
    assert back.node_xyz is not None and back.trace_nodes is not None
    np.testing.assert_array_equal(back.node_xyz, mm.node_xyz)
    assert back.trace_nodes.tolist() == frame_outline()


def test_the_rigs_channels_carry_their_nodes_positions() -> None:
    """The channel map the acquisition publishes (and the bag records) places every force
    and accelerometer at its node, so ``impact`` of the run's bag has the nodes too."""
    from modal_twin.acquisition.hammer_test import hammer_channels
    from modal_twin.io.impact_files import channel_geometry, structure_geometry
    from modal_twin.models.rig_file import load_rig
    from modal_twin.models.sensors import rig_channels

    rig = load_rig(RIG)
    chans = rig_channels(rig)
    for c in chans:
        np.testing.assert_allclose(c.position_m, expected(int(c.node)), atol=1e-12)
    forces, resp = hammer_channels(chans)
    assert [c.name for c in forces] == ["table_force_402_z", "table_force_203_x"]
    geo = channel_geometry([*resp, *forces])
    full = structure_geometry(rig.structure, [*forces, *resp])
    assert geo is not None and full is not None
    assert geo["nodes"].keys() == full["nodes"].keys()
    for n, v in geo["nodes"].items():
        np.testing.assert_allclose(v, full["nodes"][n], atol=1e-12)


def test_bad_node_coordinates_are_refused_by_name() -> None:
    from modal_twin.errors import ShapeError
    from modal_twin.models.matrix_model import matrix_model_from_arrays

    a = {"M": np.eye(2), "K": np.eye(2), "dofs": np.array(["1:x", "2:x"])}
    with pytest.raises(ShapeError, match="node_xyz"):
        matrix_model_from_arrays({**a, "node_xyz": np.array([[1, 0.0, np.nan, 0.0]])})
    with pytest.raises(ShapeError, match="node_xyz"):
        matrix_model_from_arrays({**a, "node_xyz": np.zeros((2, 3))})
    with pytest.raises(ShapeError, match="trace_nodes"):
        matrix_model_from_arrays({**a, "trace_nodes": np.array([1.5, 2.0])})


def _frame_accelerance(f: np.ndarray, outs: list[str], ins: list[str]) -> np.ndarray:
    """Accelerance of the nominal frame (its 30 lowest modes, 2 % modal damping)."""
    from modal_twin.models.tracking_frame import frame_matrices

    m = frame_matrices()
    w2, phi = linalg.eigh(m["K0"], m["M"])
    w, phi = np.sqrt(w2[:30]), phi[:, :30]
    dofs = [str(d) for d in m["dofs"]]
    o, i = [dofs.index(v) for v in outs], [dofs.index(v) for v in ins]
    s = 2j * np.pi * f
    modal = s**2 / (s**2 + 0.04 * w[:, None] * s + w[:, None] ** 2)
    return np.einsum("or,ir,rf->oif", phi[o], phi[i], modal)


def test_the_impact_nodes_frf_file_and_modes_carry_the_geometry(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    import pyuff

    from modal_twin.acquisition.hammer_test import HammerResult, HammerTest
    from modal_twin.acquisition.impact import ImpactFRF
    from modal_twin.cli import main
    from modal_twin.io.impact_files import structure_geometry, write_hammer_result
    from modal_twin.models.rig_file import load_rig
    from modal_twin.models.sensors import rig_channels

    # the node's own steps: the rig's channels, its hammer test, the geometry it writes
    rig = load_rig(RIG)
    test = HammerTest(rig_channels(rig), block_s=1.6)
    geo = structure_geometry(rig.structure, [*test.inputs, *test.outputs])
    measured = sorted({int(c.node) for c in (*test.inputs, *test.outputs)})
    assert measured == [101, 105, 201, 203, 301, 303, 401, 402, 404, 405]
    assert geo is not None
    assert sorted(map(int, geo["nodes"])) == measured
    for n, v in geo["nodes"].items():
        np.testing.assert_allclose(v, expected(int(n)), atol=1e-12)
    assert [ln["nodes"] for ln in geo["trace_lines"]] == [AROUND]

    f = np.arange(1, 1001) * 0.625  # the scenario's 1.6 s blocks
    outs = [f"{c.node}:{c.direction}" for c in test.outputs]
    ins = [f"{c.node}:{c.direction}" for c in test.inputs]
    H = _frame_accelerance(f, outs, ins)
    one = np.ones((len(outs), f.size))
    per = tuple(ImpactFRF(f, H[:, k], H[:, k], H[:, k], H[:, k], one, "H1", 3, None)
                for k in range(len(ins)))
    res = HammerResult(f, H, np.ones(H.shape), test.inputs, test.outputs, per, "H1", 1.6)
    frf, _ = write_hammer_result(tmp_path / "impact", res, geometry=geo)
    u = pyuff.UFF(str(frf))
    assert [int(t) for t in u.get_set_types()][:3] == [164, 15, 82]
    nodes, trace = u.read_sets(1), u.read_sets(2)
    assert [int(v) for v in nodes["node_nums"]] == measured
    np.testing.assert_allclose(np.column_stack([nodes["x"], nodes["y"], nodes["z"]]),
                               [expected(n) for n in measured], atol=1e-6)
    assert [int(v) for v in trace["nodes"]] == AROUND

    # README: identify the FRF file, export the modes as UFF 55, import them back
    assert main(["identify", str(frf), "--f-max", "420", "--out", str(tmp_path / "id")]) == 0
    doc = json.loads((tmp_path / "id" / "modes.json").read_text())
    assert len(doc["modes"]) == 7
    assert sorted(map(int, doc["geometry"]["nodes"])) == measured
    for n, v in doc["geometry"]["nodes"].items():
        np.testing.assert_allclose(v, expected(int(n)), atol=1e-6)
    uff = tmp_path / "modes.uff"
    assert main(["export", "modes", str(tmp_path / "id" / "modes.json"), "--out",
                 str(uff)]) == 0
    types = [int(t) for t in pyuff.UFF(str(uff)).get_set_types()]
    assert types[:3] == [164, 15, 82] and types.count(55) == 7
    assert main(["import", str(uff), "--out", str(tmp_path / "imp")]) == 0
    again = json.loads((tmp_path / "imp" / "modes_modes.json").read_text())
    assert sorted(map(int, again["geometry"]["nodes"])) == measured
    assert [ln["nodes"] for ln in again["geometry"]["trace_lines"]] == [AROUND]
    capsys.readouterr()
