"""``modal-twin model info`` on the vehicle file (the building's path is in test/test_cli.py)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "modal_twin.cli", *args], capture_output=True,
                          text=True, timeout=120, cwd=ROOT)


def test_vehicle_model_info_table_and_json() -> None:
    out = _cli("model", "info", "config/vehicles/trailer_car.yaml")
    assert out.returncode == 0, out.stderr
    assert "total mass 46.23 t" in out.stdout and "free-free carbody 8.73" in out.stdout
    d = json.loads(_cli("model", "info", "config/vehicles/trailer_car.yaml", "--json").stdout)
    assert [m["part"] for m in d["modes"][:2]] == ["carbody", "carbody"]
    assert 0.8 < d["modes"][0]["f_hz"] < 1.5


def test_vehicle_model_info_bad_file(tmp_path: Path) -> None:
    bad = tmp_path / "car.yaml"
    bad.write_text("carbody: {length: 25.0}\n")
    out = _cli("model", "info", str(bad))
    assert out.returncode == 2
    assert "Traceback" not in out.stderr and "bogie: missing" in out.stderr
