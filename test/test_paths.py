"""Paths: resolved after symbolic links, regular files only (a FIFO never blocks), the files
a file names checked too, names that become paths validated, the allowed folders."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from modal_twin.errors import ConfigError, ModalTwinError, OptionError
from modal_twin.paths import check_regular, open_regular, request_roots
from modal_twin.validation import check_name, check_request_path

ROOT = Path(__file__).resolve().parents[1]
BUILDING = ROOT / "config" / "structures" / "building.yaml"
HANG_GUARD_S = 120  # only a guard against a hang, not a speed limit


def run_py(code: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """Run ``code`` in a fresh interpreter (a hang would block the test run itself)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-c", code], cwd=cwd, env=env, text=True,
                          capture_output=True, timeout=HANG_GUARD_S)


@pytest.mark.parametrize("bad", ["x/../../../escaped", "a\nb", ".hidden", "..", "", "a" * 65,
                                 "a b", "ä", "/abs", "a\\b"])
def test_a_name_that_becomes_a_path_is_refused(bad: str) -> None:
    with pytest.raises(OptionError, match="expected letters, digits"):
        check_name(bad, "launch.name")


@pytest.mark.parametrize("good", ["demo", "s1_building-stick.slip", "v0001", "a" * 64])
def test_a_plain_name_passes(good: str) -> None:
    assert check_name(good, "n") == good


def test_the_scenario_name_cannot_move_the_run_folder(tmp_path: Path) -> None:
    from modal_twin.scenario import load_scenario

    p = tmp_path / "s.yaml"
    p.write_text('launch: {name: "x/../../../escaped", '
                 "nodes: [{name: a, executable: rig_node}]}\n")
    with pytest.raises(ConfigError, match=r"key 'launch.name'.*'x/../../../escaped'"):
        load_scenario(p)
    p.write_text('launch: {name: "a\\nb", nodes: [{name: a, executable: rig_node}]}\n')
    with pytest.raises(ConfigError, match=r"key 'launch.name'"):
        load_scenario(p)


def test_the_allowed_folders_are_runs_and_the_model_folders(tmp_path: Path,
                                                            monkeypatch: pytest.MonkeyPatch
                                                            ) -> None:
    monkeypatch.chdir(tmp_path)
    roots = request_roots()
    assert check_request_path(str(BUILDING), "f", roots) == BUILDING.resolve()
    for outside in (ROOT / "README.md", ROOT / "modal_twin" / "cli.py", ROOT / "setup.py"):
        with pytest.raises(OptionError, match="expected a file inside"):
            check_request_path(str(outside), "f", roots)
    (tmp_path / "runs" / "r").mkdir(parents=True)
    (tmp_path / "runs" / "r" / "v.yaml").write_text("a: 1\n")
    (tmp_path / "w.yaml").write_text("a: 1\n")
    assert check_request_path("runs/r/v.yaml", "f", [tmp_path / "runs"]).is_file()
    with pytest.raises(OptionError, match="expected a file inside"):
        check_request_path(str(tmp_path / "w.yaml"), "f", roots)  # the working folder itself


def test_a_symlink_inside_to_a_file_outside_is_refused(tmp_path: Path) -> None:
    inside = tmp_path / "runs"
    inside.mkdir()
    secret = tmp_path / "secret.yaml"
    secret.write_text("a: 1\n")
    (inside / "leak.yaml").symlink_to(secret)
    with pytest.raises(OptionError, match="expected a file inside"):
        check_request_path("leak.yaml", "f", [inside])


def test_a_fifo_is_refused_without_blocking(tmp_path: Path) -> None:
    fifo = tmp_path / "x.yaml"
    os.mkfifo(fifo)
    with pytest.raises(ConfigError, match="expected a regular"):
        check_regular(fifo)
    # opened (O_NONBLOCK, fstat) and refused: a blocking open of a FIFO would never return
    r = run_py("from modal_twin.yaml_files import read_yaml\n"
               "try:\n    read_yaml('x.yaml')\nexcept Exception as e:\n    print(e)\n", tmp_path)
    assert "expected a regular" in r.stdout, r.stderr
    with pytest.raises(ConfigError, match="no such"):
        open_regular(tmp_path / "missing.yaml")


def _version_naming(folder: Path, structure: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    v = folder / "v0001.yaml"
    v.write_text(f"structure: {structure}\nversion: 1\n")
    return v


def test_a_version_naming_a_fifo_structure_is_refused_at_once(tmp_path: Path) -> None:
    from modal_twin.models.versions import read_version

    os.mkfifo(tmp_path / "structure.yaml")
    v = _version_naming(tmp_path / "models", tmp_path / "structure.yaml")
    with pytest.raises(ConfigError, match="expected a regular structure named by"):
        read_version(v)


def test_the_twin_refuses_a_version_whose_structure_lies_outside(tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch
                                                                 ) -> None:
    monkeypatch.chdir(tmp_path)
    from modal_twin.twin.session import TwinSession

    outside = tmp_path / "elsewhere" / "building.yaml"
    outside.parent.mkdir()
    outside.write_text(BUILDING.read_text())
    models = tmp_path / "runs" / "models"
    twin = TwinSession(str(BUILDING), 1000.0, 2.0, models)
    before = (twin.plant, twin.version)
    v = _version_naming(models, outside)
    with pytest.raises(ModalTwinError, match="structure: expected a file inside"):
        twin.load_version(str(v), {}, "v1")
    assert (twin.plant, twin.version) == before
    v.write_text(f"structure: {BUILDING}\nversion: 1\n")  # inside: taken
    assert twin.load_version(str(v), {}, "v1") == "v1"


def test_a_twin_given_a_version_naming_a_fifo_keeps_running(tmp_path: Path) -> None:
    """The FIFO sits inside the allowed folders: refused as not a regular file, at once."""
    models = tmp_path / "runs" / "models"
    models.mkdir(parents=True)
    os.mkfifo(models / "structure.yaml")
    _version_naming(models, models / "structure.yaml")
    code = (f"from modal_twin.twin.session import TwinSession\n"
            f"t = TwinSession({str(BUILDING)!r}, 1000.0, 2.0, 'runs/models')\n"
            f"try:\n    t.load_version('runs/models/v0001.yaml', {{}}, 'v1')\n"
            f"except Exception as e:\n    print('refused:', e)\nprint('version', t.version)\n")
    r = run_py(code, tmp_path)
    assert "refused:" in r.stdout and "regular" in r.stdout, r.stderr
    assert "version v1" not in r.stdout
