from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "modal_twin.cli", *args], capture_output=True,
                          text=True, timeout=120, cwd=ROOT)


def test_model_info_table_and_json() -> None:
    out = _cli("model", "info", "config/structures/building.yaml")
    assert out.returncode == 0, out.stderr
    assert "total mass 686.00 t" in out.stdout
    d = json.loads(_cli("model", "info", "config/structures/building.yaml", "--json").stdout)
    f = [m["f_hz"] for m in d["modes"][:3]]
    assert all(0.66 < x < 0.73 for x in f)  # isolation modes, Table 2 of [004]
    assert {m["direction"] for m in d["modes"][:3]} == {"x", "y", "torsion"}


def test_model_info_bad_file(tmp_path: Path) -> None:
    bad = tmp_path / "s.yaml"
    bad.write_text("name: x\nmaterials: {C: {E: -1.0, nu: 0.2}}\n")
    out = _cli("model", "info", str(bad))
    assert out.returncode == 2
    assert "Traceback" not in out.stderr and str(bad) in out.stderr


def test_a_negative_number_list_is_an_option_value() -> None:
    from modal_twin import cli

    argv = ["update", "m.yaml", "--modes", "x.json", "--bounds", "-0.7,1.5", "-q"]
    assert cli._negative_lists_joined(argv) == ["update", "m.yaml", "--modes", "x.json",
                                                "--bounds=-0.7,1.5", "-q"]
    a = cli._parser().parse_args(cli._negative_lists_joined(argv))
    assert a.bounds == "-0.7,1.5"
    # a single negative number and an option after an option stay as they were
    assert cli._negative_lists_joined(["--f-min", "-5", "--x", "-y"]) == \
        ["--f-min", "-5", "--x", "-y"]
