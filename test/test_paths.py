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


# -- outputs: only what the project wrote is embedded; nothing overwritten silently ---------

def _png(tmp: Path, name: str, text: str) -> bytes:
    """A real PNG whose pixels do not matter, with ``text`` in a tEXt chunk."""
    import zlib

    def chunk(kind: bytes, data: bytes) -> bytes:
        return (len(data).to_bytes(4, "big") + kind + data
                + zlib.crc32(kind + data).to_bytes(4, "big"))

    data = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", bytes([0, 0, 0, 1, 0, 0, 0, 1, 8, 0, 0, 0, 0]))
            + chunk(b"tEXt", b"c\x00" + text.encode()) + chunk(b"IDAT", zlib.compress(b"\x00\x00"))
            + chunk(b"IEND", b""))
    (tmp / name).write_bytes(data)
    return data


def test_the_report_embeds_only_the_projects_figures(tmp_path: Path) -> None:
    import base64

    run = tmp_path / "run"
    run.mkdir()
    own = _png(run, "force_state_ESB1_stick_slip.png", "OWN-FIGURE")
    secret = _png(tmp_path, "secret.png", "SECRET-MARKER")
    (tmp_path / "secret.txt").write_text("SECRET-MARKER\n")
    (run / "leak.png").symlink_to(tmp_path / "secret.txt")  # an unknown name
    (run / "force_state_leak_x.png").symlink_to(tmp_path / "secret.png")  # a known one, linked
    os.mkfifo(run / "x.png")
    os.mkfifo(run / "force_state_fifo_x.png")
    (run / "force_state_text_x.png").write_text("SECRET-MARKER, not a PNG\n")
    r = run_py(f"import sys; from modal_twin.cli import main; "
               f"sys.exit(main(['--quiet', 'report', {str(run)!r}]))", tmp_path)
    assert r.returncode == 0, r.stderr
    page = (run / "report.html").read_text()
    assert base64.b64encode(own).decode() in page  # the diagnosis's figure is there
    assert base64.b64encode(secret).decode() not in page
    assert "SECRET-MARKER" not in page
    for name in ("force_state_leak_x.png", "force_state_fifo_x.png", "force_state_text_x.png"):
        assert f"left out {name}" in page
    assert "left out leak.png" not in page and "left out x.png" not in page  # not looked at


def test_the_report_skips_a_bag_behind_a_link(tmp_path: Path) -> None:
    from modal_twin.commands.report import own_bags

    run = tmp_path / "run"
    (run / "a" / "bag").mkdir(parents=True)
    (run / "a" / "bag" / "metadata.yaml").write_text("x\n")
    (tmp_path / "elsewhere" / "bag").mkdir(parents=True)
    (run / "b").symlink_to(tmp_path / "elsewhere")
    (run / "c" / "bag").mkdir(parents=True)
    os.mkfifo(run / "c" / "bag" / "part.mcap")
    notes: list[str] = []
    assert own_bags(run, notes) == [run / "a" / "bag"]
    assert len(notes) == 2


@pytest.mark.parametrize("argv", [
    ["export", "model", str(BUILDING), "--out", "{out}.npz"],
    ["view", str(BUILDING), "--n-modes", "1", "--html", "{out}.html"],
    ["report", "{run}", "--out", "{out}.html"],
    ["effects", "history", "{run}", "--png", "{out}.png"],
])
def test_outputs_are_never_overwritten_without_force(tmp_path: Path, argv: list[str],
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    from modal_twin.cli import main

    (tmp_path / "run").mkdir()
    _png(tmp_path / "run", "force_state_ESB1_x.png", "A")  # something to report (else exit 2)
    out = tmp_path / "out"
    args = [a.format(out=out, run=tmp_path / "run") for a in argv]
    target = Path(next(a for a in args if a.startswith(str(out))))
    target.write_text("KEEP\n")
    assert main(["--quiet", *args]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith("exists; give --force to overwrite it") and "\n" not in err
    assert target.read_text() == "KEEP\n"
    assert main(["--quiet", *args, "--force"]) == 0
    assert target.read_bytes() != b"KEEP\n"


@pytest.mark.parametrize(("argv", "kept"), [
    (["identify", "{bag}", "--out", "{out}"], "mac.png"),
    (["identify", "{bag}", "--out", "{out}"], "modes.json"),
    (["campaign", "{bag}", "--jobs", "1", "--out", "{out}"], "campaign.png"),
    (["campaign", "{bag}", "--jobs", "1", "--out", "{out}"], "campaign.csv"),
])
def test_folder_outputs_are_never_overwritten_without_force(
        tmp_path: Path, argv: list[str], kept: str, capsys: pytest.CaptureFixture[str]) -> None:
    """Refused before the work: the bag is not even read (it does not exist)."""
    from modal_twin.cli import main

    out = tmp_path / "out"
    out.mkdir()
    (out / kept).write_text("KEEP\n")
    args = [a.format(out=out, bag=tmp_path / "nobag") for a in argv]
    assert main(["--quiet", *args]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"modal-twin {argv[0]}: {out / kept} exists; give --force to overwrite it"
    assert [p.name for p in out.iterdir()] == [kept]
    assert (out / kept).read_text() == "KEEP\n"
    (out / kept).unlink()
    out.rmdir()
    out.write_text("KEEP\n")  # a file where the folder goes
    assert main(["--quiet", *args]) == 2
    assert "expected a folder for the outputs, got a file" in capsys.readouterr().err
    assert out.read_text() == "KEEP\n"


def test_residual_json_is_never_overwritten_without_force(tmp_path: Path,
                                                          capsys: pytest.CaptureFixture[str]
                                                          ) -> None:
    from modal_twin.cli import main

    out = tmp_path / "t.json"
    out.write_text("KEEP\n")
    assert main(["residual", str(BUILDING), str(tmp_path / "nobag"), "--json", str(out)]) == 2
    assert "exists; give --force" in capsys.readouterr().err
    assert out.read_text() == "KEEP\n"


@pytest.mark.parametrize(("matrix", "where", "value", "match"), [
    ("K", (0, 0), float("nan"), "K holds 1 NaN / Inf entries"),
    ("M", (1, 1), -1.0, "M has a negative mass -1"),
    ("M", (slice(None), slice(None)), 0.0, r"M has no mass \(M = 0\)"),
    ("K", (0, 1), -1.5, "K is not symmetric"),
    ("M", (0, 2), 0.3, "M is not symmetric"),
])
def test_export_model_refuses_matrices_no_tool_can_use(
        tmp_path: Path, matrix: str, where: tuple[object, ...], value: float, match: str,
        capsys: pytest.CaptureFixture[str]) -> None:
    import re

    import numpy as np

    from modal_twin.cli import main

    mats = {"M": np.eye(3), "K": np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])}
    mats[matrix][where] = value
    M, K = mats["M"], mats["K"]
    np.savez(tmp_path / "m.npz", M=M, K=K)
    assert main(["export", "model", str(tmp_path / "m.npz"), "--out",
                 str(tmp_path / "o.npz")]) == 2
    err = capsys.readouterr().err.strip()
    assert re.search(match, err) and "\n" not in err
    assert not (tmp_path / "o.npz").exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temp left


def test_view_of_a_matrix_model_says_what_it_takes(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    import numpy as np

    from modal_twin.cli import main

    np.savez(tmp_path / "m.npz", M=np.eye(2), K=np.eye(2))
    assert main(["view", str(tmp_path / "m.npz"), "--html", str(tmp_path / "v.html")]) == 2
    err = capsys.readouterr().err.strip()
    assert "a matrix model (.npz) has no geometry to draw; view takes a structure" in err
    assert "UTF-8" not in err and "\n" not in err


def test_view_of_a_frame_file_says_what_it_takes(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    """The impact test's frame file: one line saying what view takes (it listed the frame
    spec's keys as unknown keys of a structure file)."""
    from modal_twin.cli import main

    frame = Path(__file__).resolve().parents[1] / "config" / "structures" / "tracking_frame.yaml"
    assert main(["view", str(frame), "--html", str(tmp_path / "v.html")]) == 2
    err = capsys.readouterr().err.strip()
    assert "a frame file (kind: frame) is a matrix model built from its spec" in err
    assert "unknown keys" not in err and "\n" not in err
    assert not (tmp_path / "v.html").exists()


def test_effects_history_of_a_missing_folder_exits_2(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    from modal_twin.cli import main

    assert main(["effects", "history", str(tmp_path / "nope")]) == 2
    assert "no such model folder" in capsys.readouterr().err


@pytest.mark.ros
@pytest.mark.parametrize("rate", ["nan", "inf", "0", "-2"])
def test_replay_refuses_a_rate_that_is_not_finite_and_positive(domain_id: int, tmp_path: Path,
                                                               rate: str) -> None:
    from conftest import write_frames_bag

    from modal_twin.models.loading import load_model

    write_frames_bag(tmp_path / "bag", load_model(BUILDING).plant(), seconds=0.2,
                     scale=(1, 1, 0, 0, 0, 0), seed=1, block=100)
    r = subprocess.run([sys.executable, "-m", "modal_twin.cli", "replay", str(tmp_path / "bag"),
                        "--rate", rate, "--wait", "0"], capture_output=True, text=True,
                       timeout=HANG_GUARD_S, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert r.returncode == 2
    assert r.stderr.strip().endswith(f"--rate: expected a finite number > 0, got {float(rate)}")


def test_a_killed_writers_temporary_is_removed_at_the_next_write(tmp_path: Path) -> None:
    from modal_twin.paths import TEMP_PREFIX, atomic_file

    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale_dir = tmp_path / f"{TEMP_PREFIX}{dead.pid}-bag.x1"
    (stale_dir / "bag").mkdir(parents=True)
    stale_file = tmp_path / f"{TEMP_PREFIX}{dead.pid}-o.npz.x2.npz"
    stale_file.write_text("half")
    live = tmp_path / f"{TEMP_PREFIX}{os.getpid()}-other.x3"  # a writer still running
    live.mkdir()
    with atomic_file(tmp_path / "new.txt") as tmp:
        tmp.write_text("done")
    assert (tmp_path / "new.txt").read_text() == "done"
    assert not stale_dir.exists() and not stale_file.exists() and live.exists()


def test_a_sigkilled_import_leaves_nothing_after_the_next_one(tmp_path: Path) -> None:
    """A writer SIGKILLed inside its temporary folder (as an import is), then an import."""
    import signal

    import numpy as np

    from modal_twin.paths import TEMP_PREFIX

    out = tmp_path / "out"
    out.mkdir()
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    p = subprocess.Popen([sys.executable, "-c", (
        "import time\nfrom modal_twin.paths import atomic_dir\n"
        f"with atomic_dir({str(out / 'b1')!r}) as w:\n"
        "    w.mkdir(); (w / 'part.mcap').write_bytes(b'x' * 1000)\n"
        "    print('writing', flush=True); time.sleep(600)\n")],
        env=env, stdout=subprocess.PIPE, text=True)
    assert p.stdout is not None and p.stdout.readline().strip() == "writing"
    p.send_signal(signal.SIGKILL)
    p.wait()
    left = list(out.glob(f"{TEMP_PREFIX}{p.pid}-b1.*"))
    assert len(left) == 1 and (left[0] / "b1" / "part.mcap").is_file()  # what a kill leaves
    t = np.arange(2000) / 1000.0
    np.savez(tmp_path / "r.npz", data=np.vstack([np.sin(t), np.cos(t)]), fs_hz=1000.0,
             names=np.array(["a", "b"]), units=np.array(["m/s^2", "m/s^2"]))
    r = subprocess.run([sys.executable, "-m", "modal_twin.cli", "--quiet", "import",
                        str(tmp_path / "r.npz"), "--out", str(out / "b2")], env=env,
                       capture_output=True, text=True, timeout=HANG_GUARD_S)
    assert r.returncode == 0, r.stderr
    assert sorted(q.name for q in out.iterdir()) == ["b2"]


def test_outputs_are_private_to_their_user(tmp_path: Path) -> None:
    """One file-mode policy: files 0600, folders 0700, whatever the caller's umask."""
    import stat

    old = os.umask(0o022)
    try:
        r = run_py("import sys; from modal_twin.cli import main; sys.exit(main(['--quiet', "
                   f"'export', 'model', {str(BUILDING)!r}, '--out', 'o/m.npz']))", tmp_path)
    finally:
        os.umask(old)
    assert r.returncode == 0, r.stderr
    assert stat.S_IMODE((tmp_path / "o" / "m.npz").stat().st_mode) == 0o600
    assert stat.S_IMODE((tmp_path / "o").stat().st_mode) == 0o700


def _bag_with(tmp: Path, name: str) -> Path:
    """A bag folder whose metadata names ``name`` as its one MCAP file."""
    bag = tmp / "bag"
    bag.mkdir()
    (bag / "metadata.yaml").write_text(
        "rosbag2_bagfile_information:\n  version: 8\n  storage_identifier: mcap\n"
        f"  relative_file_paths: [{name}]\n  files: []\n  message_count: 0\n"
        "  topics_with_message_count: []\n")
    return bag


def test_a_bag_holding_a_fifo_is_refused_without_blocking(tmp_path: Path) -> None:
    bag = _bag_with(tmp_path, "part.mcap")
    os.mkfifo(bag / "part.mcap")
    for args in (["bag", "info", "bag"], ["identify", "bag", "--out", "id"],
                 ["bag", "salvage", "bag", "--out", "s"]):
        r = run_py(f"import sys; from modal_twin.cli import main; sys.exit(main({args!r}))",
                   tmp_path)
        assert r.returncode == 2, (args, r.stderr)
        assert "expected a regular bag file, got a FIFO" in r.stderr
        assert len(r.stderr.strip().splitlines()) == 1


def test_a_bag_naming_a_file_outside_is_refused(tmp_path: Path) -> None:
    from modal_twin.errors import BagError
    from modal_twin.io.bag import bag_info

    (tmp_path / "outside.mcap").write_bytes(b"\x89MCAP0\r\n")
    bag = _bag_with(tmp_path, "../outside.mcap")
    with pytest.raises(BagError, match="expected a file inside the bag"):
        bag_info(bag)


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs Linux /proc")
def test_an_output_folder_that_cannot_be_made_is_refused_before_the_work(
        tmp_path: Path) -> None:
    # audit of issue 22: `identify --out /proc/x` ran the whole identification, then failed
    from modal_twin.paths import check_new_in

    with pytest.raises(ConfigError, match="cannot write in /proc"):
        check_new_in("/proc/x/y", ("modes.json",), False)
    (tmp_path / "file").write_text("x")
    with pytest.raises(ConfigError, match="is a file, not a folder"):
        check_new_in(tmp_path / "file" / "out", ("modes.json",), False)
    out = check_new_in(tmp_path / "new" / "out", ("modes.json",), False)
    assert out == [tmp_path / "new" / "out" / "modes.json"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]  # the probe left nothing
