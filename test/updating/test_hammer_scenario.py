"""The hammer scenario of a tracking frame ([000]) from the test to the updated model.

Known answer: the scenario's truth is the nominal frame with its arm-foot contact stiffness
35 % lower and its bearing stiffness 25 % higher. The simulated roving-hammer test (noise,
one bounce in three hits) goes through the impact processing, PolyMAX + LSFD and the
bounded Gauss-Newton update; the contact stiffnesses come back within 2 % (theta within
0.02), the identified frequencies within 0.5 % of the truth's, and FOM (Eq. (1) of [000])
and MAC improve.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy import linalg

from modal_twin.cli import main
from modal_twin.models.tracking_frame import JOINTS, frame_matrices

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "config" / "hammer_tests" / "tracking_frame.yaml"


def test_frame_joints_enter_as_relative_stiffness_changes() -> None:
    nom, soft = frame_matrices(), frame_matrices(theta={"feet": -0.5})
    np.testing.assert_allclose(soft["K0"], nom["K0"] - 0.5 * nom["K_feet"])
    assert np.allclose(nom["K0"], nom["K0"].T) and np.allclose(nom["M"], nom["M"].T)
    assert np.linalg.eigvalsh(nom["K0"]).min() > 0  # held at the base centre
    # total mass: beams (rho A L) plus the instrument and the motor
    rho, w, h = 7850.0, 0.3, 0.5
    beams = rho * (1.1e-3 * 2 * w + 2 * 8.0e-4 * h + 6.0e-4 * 2 * w)
    x = np.array([lab.endswith(":x") for lab in nom["dofs"]], dtype=float)
    # the held node's row and column leave the consistent mass [[2, 1], [1, 2]] / 6 of
    # its two base elements (length w / 3): 2 x (2 x 1/2 - 1/3) = 4/3 of one element's mass
    held = 4.0 / 3.0 * rho * 1.1e-3 * w / 3
    assert float(x @ nom["M"] @ x) == pytest.approx(beams + 6.0 + 2.5 - held, rel=1e-9)


def test_hammer_scenario_recovers_the_contact_stiffnesses(tmp_path: Path,
                                                          capsys: pytest.CaptureFixture) -> None:
    assert main(["hammer", str(SCENARIO), "--out", str(tmp_path)]) == 0
    text = capsys.readouterr().out
    assert "6 hits averaged, 2 rejected" in text and "double hit" in text
    rep = json.loads((tmp_path / "update.json").read_text())
    truth = yaml.safe_load(SCENARIO.read_text())["truth"]["theta"]
    for j in JOINTS:
        assert rep["theta"][j] == pytest.approx(truth[j], abs=0.02), j
    true = frame_matrices(theta=truth)
    wn = np.sqrt(linalg.eigh(true["K0"], true["M"], eigvals_only=True)) / (2 * np.pi)
    f_true = wn[(wn > 10.0) & (wn < 420.0)]
    np.testing.assert_allclose(rep["f_test_hz"], f_true, rtol=0.005)
    np.testing.assert_allclose(rep["zeta_test"], 0.015, atol=0.002)
    assert rep["fom_after"] < rep["fom_before"] / 100
    assert min(rep["mac_after"]) > 0.99 and max(np.abs(rep["df_pct_after"])) < 0.5
    assert max(np.abs(np.nan_to_num(rep["df_pct_before"]))) > 15  # the nominal is far off
    # the written modes update the written nominal model through `update` the same way
    assert main(["update", str(tmp_path / "nominal.npz"), "--modes",
                 str(tmp_path / "modes.json"), "--bounds=-0.7,1.5", "--prior-weight", "0",
                 "--out", str(tmp_path / "v")]) == 0
    again = json.loads((tmp_path / "v" / "update_v1.json").read_text())
    np.testing.assert_allclose(again["theta"], [rep["theta"][j] for j in sorted(JOINTS)],
                               atol=1e-3)


def test_hammer_outputs_carry_the_measured_points_geometry(tmp_path: Path) -> None:
    """test.uff, frf.uff and modes.json carry the measured nodes at the model's coordinates.

    Known answer: the shipped frame (half width 0.3 m, height 0.5 m, 3 elements per half
    base / arm / half axis) puts base node 100 + i at x = -0.3 + 0.1 i, arm nodes 200 + i /
    300 + i at x = -/+0.3, z = i / 6, axis node 400 + i at x = -0.3 + 0.1 i, z = 0.5 (y = 0).
    """
    import pyuff

    from modal_twin.io.uff import read_uff55

    out = tmp_path / "h"
    assert main(["hammer", str(SCENARIO), "--out", str(out)]) == 0
    test = yaml.safe_load(SCENARIO.read_text())["test"]
    measured = sorted({int(lab.split(":")[0]) for lab in test["hit"] + test["responses"]})

    def expected(n: int) -> list[float]:
        member, i = divmod(n, 100)
        x = {1: -0.3 + 0.1 * i, 2: -0.3, 3: 0.3, 4: -0.3 + 0.1 * i}[member]
        z = {1: 0.0, 2: i * 0.5 / 3, 3: i * 0.5 / 3, 4: 0.5}[member]
        return [x, 0.0, z]

    model = {int(r[0]): r[1:] for r in frame_matrices()["node_xyz"]}
    for name in ("test.uff", "frf.uff"):
        u = pyuff.UFF(str(out / name))
        types = [int(t) for t in u.get_set_types()]
        assert types[:3] == [164, 15, 82], name
        units, nodes, trace = (u.read_sets(k) for k in range(3))
        assert int(units["units_code"]) == 1 and units["length"] == pytest.approx(1.0)  # SI, m
        assert [int(v) for v in nodes["node_nums"]] == measured
        xyz = np.column_stack([nodes["x"], nodes["y"], nodes["z"]])
        np.testing.assert_allclose(xyz, [model[n] for n in measured], atol=1e-6)
        np.testing.assert_allclose(xyz, [expected(n) for n in measured], atol=1e-6)
        # around the frame: base, right arm up, axis right to left, left arm down, closed
        assert [int(v) for v in trace["nodes"]] == [101, 105, 301, 303, 405, 404, 402, 401,
                                                    203, 201, 101]
    doc = json.loads((out / "modes.json").read_text())
    assert sorted(map(int, doc["geometry"]["nodes"])) == measured
    for n, v in doc["geometry"]["nodes"].items():
        np.testing.assert_allclose(v, expected(int(n)), atol=1e-12)
    # export modes: UFF 55 with the geometry, read back by pyuff and re-imported
    uff = tmp_path / "modes.uff"
    assert main(["export", "modes", str(out / "modes.json"), "--out", str(uff)]) == 0
    back = read_uff55(uff)
    assert sorted(map(int, back["geometry"]["nodes"])) == measured
    for n, v in back["geometry"]["nodes"].items():
        np.testing.assert_allclose(v, expected(int(n)), atol=1e-6)
    assert back["geometry"]["trace_lines"][0]["nodes"][0] == 101
    shapes = np.array([np.asarray(m["shape_re"]) + 1j * np.asarray(m["shape_im"])
                       for m in doc["modes"]]).T
    np.testing.assert_allclose(back["f_hz"], [m["f_hz"] for m in doc["modes"]], rtol=1e-5)
    names = [d["channel"] for d in doc["dofs"]]
    assert [c[0] for c in back["channels"]] == names
    np.testing.assert_allclose(back["channel_shapes"], shapes,
                               atol=1e-4 * np.abs(shapes).max())
    assert main(["import", str(uff), "--out", str(tmp_path / "imp")]) == 0
    again = json.loads((tmp_path / "imp" / "modes_modes.json").read_text())
    assert sorted(map(int, again["geometry"]["nodes"])) == measured
    # identify on the written FRF file keeps the file's geometry in its modes.json
    assert main(["identify", str(out / "frf.uff"), "--out", str(tmp_path / "id")]) == 0
    ident = json.loads((tmp_path / "id" / "modes.json").read_text())
    assert ident["geometry"]["nodes"] == {k: pytest.approx(v, abs=1e-6)
                                          for k, v in doc["geometry"]["nodes"].items()}
    # the same by separate commands: import keeps test.uff's geometry, impact writes it
    assert main(["import", str(out / "test.uff"), "--out", str(tmp_path / "bag")]) == 0
    assert main(["impact", str(tmp_path / "bag"), "--block-s", "4",
                 "--out", str(tmp_path / "frf")]) == 0
    u = pyuff.UFF(str(tmp_path / "frf" / "frf.uff"))
    assert [int(t) for t in u.get_set_types()][:3] == [164, 15, 82]
    nodes = u.read_sets(1)
    assert [int(v) for v in nodes["node_nums"]] == measured
    np.testing.assert_allclose(np.column_stack([nodes["x"], nodes["y"], nodes["z"]]),
                               [expected(n) for n in measured], atol=1e-6)
