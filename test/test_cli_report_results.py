"""``report`` on the result folders of ``update --out`` (and any folder: progress, one line).

Known answer: the two-storey shear frame of ``test_cli_own_data``, identified from its
record (frequencies within 1 % of the closed form), against the frame as a matrix model with
both storeys at half their stiffness: every model frequency is ``sqrt(0.5)`` of the truth,
so each mode is 29.3 % low before the update, outside the pairing windows (10 %): the
nominal leaves both unmatched, and the JSON and the report show them at their nearest
partner, 29.3 % off, instead of hiding them as null.
"""

from __future__ import annotations

import json
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from test_cli_own_data import exact_f_hz, matrix_model_npz, shear_frame_csv

from modal_twin.cli import main

MAP = ("channels:\n  - {name: ground, role: input}\n"
       "  - {name: floor1, node: '1', direction: x}\n"
       "  - {name: floor2, node: '2', direction: x}\n")


@pytest.fixture(scope="module")
def updated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("upd")
    csv = shear_frame_csv(d / "frame.csv")
    (d / "map.yaml").write_text(MAP)
    assert main(["import", str(csv), "--map", str(d / "map.yaml"), "--out", str(d / "bag")]) == 0
    assert main(["identify", str(d / "bag"), "--out", str(d / "id")]) == 0
    npz = matrix_model_npz(d / "frame.npz", scale=0.5)
    assert main(["update", str(npz), "--modes", str(d / "id" / "modes.json"),
                 "--bounds=-0.7,1.5", "--out", str(d / "model")]) == 0
    return d


def test_the_update_json_shows_unmatched_modes_at_their_nearest_partner(updated: Path
                                                                         ) -> None:
    doc = json.loads((updated / "model" / "update_v1.json").read_text())
    assert doc["unmatched_before"] == [True, True]
    assert doc["model_before"] == [1, 2]
    f_id = np.array(doc["f_id_hz"])
    np.testing.assert_allclose(f_id, exact_f_hz(), rtol=0.01)
    # the nominal's modes are sqrt(0.5) x the truth's: each about 29.3 % low
    np.testing.assert_allclose(doc["df_pct_before"], 100 * (np.sqrt(0.5) - 1), atol=1.0)
    assert doc["unmatched_after"] == [False, False]
    assert max(abs(v) for v in doc["df_pct_after"]) < 1.0


def test_report_of_an_update_folder_shows_the_table(updated: Path,
                                                    capsys: pytest.CaptureFixture) -> None:
    capsys.readouterr()
    assert main(["report", str(updated / "model")]) == 0
    page = (updated / "model" / "report.html").read_text()
    assert "<h2>Model update</h2>" in page
    doc = json.loads((updated / "model" / "update_v1.json").read_text())
    for k in range(2):
        row = page.split(f"<tr><td>{k + 1}</td><td>")[1].split("</tr>")[0]
        cells = [c.split("<")[0] for c in row.split("<td>")]
        assert cells[1] == f"{k + 1}*"  # unmatched before: its nearest partner
        assert float(cells[2]) == pytest.approx(doc["df_pct_before"][k], abs=1e-3)
        assert float(cells[2]) < -28.0


def test_report_says_its_progress_over_the_whole_folder(tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch
                                                        ) -> None:
    """The reading of a folder runs inside the step ``report: <folder>`` (said after 2 s)."""
    import modal_twin.commands.report as rep

    open_steps: list[str] = []
    seen: dict[str, list[str]] = {}

    @contextmanager
    def fake_step(desc: str, **_: Any) -> Any:
        open_steps.append(desc)
        try:
            yield
        finally:
            open_steps.pop()

    def fake_data(rd: Path, n_modes: int) -> Any:
        seen["reading"] = list(open_steps)
        from modal_twin.viz.report import RunData

        return RunData("t", notes=["n"], sections=[("x", "X", "<p>x</p>")])

    monkeypatch.setattr(rep, "step", fake_step)
    monkeypatch.setattr(rep, "_folder_data", fake_data)
    rep.make_report(tmp_path, tmp_path / "r.html")
    assert seen["reading"] == [f"report: {tmp_path.name}"]


def test_report_of_a_folder_with_nothing_names_what_is_missing(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    (tmp_path / "notes.txt").write_text("hello")
    assert main(["report", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "nothing to report" in err[0]
    assert "no update result (update_v*.json) and no campaign (campaign.json)" in err[0]
    assert not (tmp_path / "report.html").exists()
