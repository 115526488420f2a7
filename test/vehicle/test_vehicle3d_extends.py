"""A 3D vehicle file that ``extends`` another (``config/vehicles/trailer_car_3d_shell.yaml``).

Known answer: the shell file is trailer_car_3d.yaml with ``carbody.model: shell`` and its
own name, every other number the base's; a base outside the file's folder is refused in one
ConfigError naming the key.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from modal_twin.errors import ConfigError
from modal_twin.models.vehicle3d_spec import load_vehicle3d

VEHICLES = Path(__file__).resolve().parents[2] / "config" / "vehicles"


def test_the_shell_car_file_is_the_3d_car_with_the_shell_carbody() -> None:
    base = load_vehicle3d(VEHICLES / "trailer_car_3d.yaml")
    shell = load_vehicle3d(VEHICLES / "trailer_car_3d_shell.yaml")
    assert base.carbody_model == "rigid"
    assert shell.carbody_model == "shell" and shell.name == "trailer_car_3d_shell"
    assert replace(shell, carbody_model="rigid", name=base.name, source=base.source) == base


def test_a_section_is_updated_key_by_key_and_a_base_elsewhere_is_refused(
        tmp_path: Path) -> None:
    text = (VEHICLES / "trailer_car_3d.yaml").read_text()
    (tmp_path / "base.yaml").write_text(text)
    (tmp_path / "soft.yaml").write_text(
        "kind: vehicle3d\nextends: base.yaml\nyaw_damper: {c: 75000.0}\n")
    soft = load_vehicle3d(tmp_path / "soft.yaml")
    base = load_vehicle3d(tmp_path / "base.yaml")
    assert soft.name == "soft" and soft.values["yaw_damper"]["c"] == 75000.0
    assert soft.values["yaw_damper"]["k_series"] == base.values["yaw_damper"]["k_series"]
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "away.yaml").write_text("kind: vehicle3d\nextends: ../base.yaml\n")
    with pytest.raises(ConfigError, match="extends: expected the name of a vehicle file"):
        load_vehicle3d(tmp_path / "sub" / "away.yaml")
