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
