"""``modal-twin update STRUCTURE --modes FILE``: the two stages of [004] from the command line.

Known answer: the "identified" modes are the building's own at known moduli (two concrete
grades changed by -10 % and +8 %), written as an identify JSON whose roof channels carry a
user's names (met by location and direction); the update must return those moduli.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from modal_twin.cli import main
from modal_twin.models.building import DEFAULT_BUILDING_YAML, build_building, modal_reduction

E36, E27 = 3.278e10, 2.915e10  # nominal moduli of the structure file (Table 4 of [004])


def modes_json(path: Path, theta: dict[str, float], n: int = 10) -> Path:
    bld = build_building(DEFAULT_BUILDING_YAML)
    red = modal_reduction(bld, 12, theta=theta)
    S = bld.S @ red.Phi
    dofs = []
    for name in red.channel_names:
        loc, _, d = name.rpartition("_")
        ch = f"roof_a_{d}" if loc == "R_P1" else name  # the user's own name
        dofs.append({"channel": ch, "node": 1, "node_label": loc, "direction": d})
    modes = [{"f_hz": float(red.f_hz[k]), "std_f_hz": None, "zeta": float(red.zeta[k]),
              "std_zeta": None, "shape_re": S[:, k].tolist(), "shape_im": [0.0] * S.shape[0]}
             for k in range(n)]
    path.write_text(json.dumps({"method": "model", "dofs": dofs, "modes": modes}))
    return path


def test_update_of_a_structure_file_recovers_the_moduli(tmp_path: Path,
                                                         capsys: pytest.CaptureFixture) -> None:
    truth = {"E_Fc36": 0.90 * E36, "E_Fc27": 1.08 * E27}
    modes = modes_json(tmp_path / "modes.json", truth)
    assert main(["update", str(DEFAULT_BUILDING_YAML), "--modes", str(modes), "--out",
                 str(tmp_path / "v")]) == 0
    out = capsys.readouterr()
    assert "on 10 modes at 42 of 42 channels" in out.err  # roof_a_* met at R_P1
    assert "stage superstructure:" in out.out
    theta = yaml.safe_load((tmp_path / "v" / "v0001.yaml").read_text())["theta"]
    assert theta["E_Fc36"] == pytest.approx(truth["E_Fc36"], rel=1e-3)
    assert theta["E_Fc27"] == pytest.approx(truth["E_Fc27"], rel=1e-3)
    rows = [ln.split() for ln in out.out.splitlines() if ln.split()[:1] and
            ln.split()[0].isdigit()]
    assert max(abs(float(r[3])) for r in rows) > 1.5  # the nominal model was off
    assert max(abs(float(r[6])) for r in rows) < 0.01  # % after


def test_update_of_a_structure_needs_named_channels(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture) -> None:
    modes = modes_json(tmp_path / "modes.json", {})
    doc = json.loads(modes.read_text())
    for d in doc["dofs"]:
        d["channel"] = ""
    modes.write_text(json.dumps(doc))
    assert main(["update", str(DEFAULT_BUILDING_YAML), "--modes", str(modes)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "shapes name their channels" in err[0]


def test_update_table_shows_every_mode_before_and_after(tmp_path: Path,
                                                        capsys: pytest.CaptureFixture) -> None:
    """Moduli -40 % / +40 %: the nominal is so far off that two superstructure modes find no
    model mode inside the pairing windows (they printed ``nan`` before). Known answer:
    each row's df before is the nominal model's own frequency of the printed partner over
    the identified one (``modal_reduction`` at the nominal), every row finite."""
    import numpy as np

    truth = {"E_Fc36": 0.60 * E36, "E_Fc27": 1.40 * E27}
    modes = modes_json(tmp_path / "modes.json", truth)
    assert main(["update", str(DEFAULT_BUILDING_YAML), "--modes", str(modes), "--out",
                 str(tmp_path / "v")]) == 0
    out = capsys.readouterr().out
    assert "nan" not in out
    rows = [ln.split() for ln in out.splitlines() if ln.split()[:1] and
            ln.split()[0].isdigit()]
    assert len(rows) == 10
    f_nom = modal_reduction(build_building(DEFAULT_BUILDING_YAML), 12).f_hz
    starred = 0
    for r in rows:
        j = int(r[2].rstrip("*"))
        starred += r[2].endswith("*")
        # the update solves the full parametric FE model: within 0.01 points of the reduction
        assert float(r[3]) == pytest.approx(100 * (f_nom[j - 1] / float(r[1]) - 1), abs=0.01)
        assert 0.0 <= float(r[4]) <= 1.0
        assert abs(float(r[6])) < 0.01
    assert starred == 2
    worst = max(abs(float(r[3])) for r in rows)
    assert f"before: max |df| {worst:.3f} %" in out
    assert np.isfinite(worst) and worst > 9.0
