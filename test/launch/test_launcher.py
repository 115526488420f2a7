"""Launcher: start / stop, node death, malformed scenarios (signal forwarding: test_loopback)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from modal_twin.errors import ConfigError
from modal_twin.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]

SCENARIO = """
launch:
  name: t
  duration_s: {duration}
  ready_timeout_s: 30
  nodes:
    - {{name: excitation, executable: excitation_node}}
  record: {{topics: [/excitation/signal]}}
excitation:
  ros__parameters: {{kind: {kind}, duration_s: 2.0, fs_hz: 500.0, block_size: 25,
                    rms: [0.1, 0.1, 0.1, 0.0, 0.0, 0.0], f_max_hz: 20.0}}
"""


def _write(tmp_path: Path, text: str, name: str = "s.yaml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


@pytest.mark.ros
def test_run_starts_records_and_stops_cleanly(domain_id: int, tmp_path: Path) -> None:
    from modal_twin.io.bag import read_blocks
    from modal_twin.launch import launch

    res = launch(_write(tmp_path, SCENARIO.format(duration=5, kind="random")),
                 run_dir=tmp_path / "run", say=lambda s: None)
    assert res.exit_code == 0, res.message
    assert res.domain_id == domain_id  # taken from the environment when set
    assert set(res.node_exit_codes) == {"excitation", "recorder"}
    assert all(c is not None for c in res.node_exit_codes.values())  # nothing left running
    assert (tmp_path / "run" / "logs" / "excitation.log").is_file()
    assert "ros__parameters" in (tmp_path / "run" / "params" / "excitation.yaml").read_text()
    assert res.bag is not None
    blocks = read_blocks(res.bag, "/excitation/signal")  # rosbags reader
    assert [b.first_index for b in blocks] == [25 * k for k in range(40)]
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    with next(res.bag.glob("*.mcap")).open("rb") as fh:  # the mcap package's reader
        msgs = [m for *_, m in make_reader(fh, decoder_factories=[DecoderFactory()])
                .iter_decoded_messages(topics=["/excitation/signal"])]
    assert [m.first_sample_index for m in msgs] == [25 * k for k in range(40)]


@pytest.mark.ros
def test_node_death_is_named_and_fails_the_run(domain_id: int, tmp_path: Path) -> None:
    from modal_twin.launch import launch

    msgs: list[str] = []
    res = launch(_write(tmp_path, SCENARIO.format(duration=20, kind="bogus")),
                 run_dir=tmp_path / "run", say=msgs.append)
    assert res.exit_code == 1
    assert "node 'excitation' died" in res.message
    assert "kind: expected one of" in res.message  # the node's own error, from its log


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("launch: [1, 2\n", r"malformed YAML at line 2"),
        ("foo: 1\n", r"key 'launch': missing"),
        ("launch: {nodes: []}\n", r"key 'launch.nodes'"),
        ("launch: {nodes: [{name: a}]}\n", r"key 'launch.nodes\[0\].executable'"),
        ("launch: {nodes: [{name: a, executable: b, colour: red}]}\n", r"nodes\[0\].colour"),
        ("launch: {nodes: [{name: a, executable: b}], duration_s: -1}\n",
         r"launch.duration_s.*>= 0"),
        ("launch: {nodes: [{name: a, executable: b}]}\nzz: {ros__parameters: {}}\n",
         r"key 'zz': parameters for a node that is not launched"),
        ("launch: {nodes: [{name: a, executable: b}]}\na: {ros__parameters: 3}\n",
         r"key 'a': expected a mapping"),
    ],
)
def test_malformed_scenarios_name_file_key_and_problem(
    tmp_path: Path, text: str, match: str
) -> None:
    p = _write(tmp_path, text, "bad.yaml")
    with pytest.raises(ConfigError, match=match) as err:
        load_scenario(p)
    assert str(p) in str(err.value)


def test_shipped_scenarios_load() -> None:
    files = sorted((ROOT / "config" / "scenarios").glob("*.yaml"))
    assert files
    for f in files:
        sc = load_scenario(f)
        assert sc.nodes


def test_cli_refuses_unknown_topic_with_known_list(tmp_path: Path) -> None:
    out = subprocess.run(
        [sys.executable, "-m", "modal_twin.cli", "record", "-o", str(tmp_path / "b"), "/nope"],
        capture_output=True, text=True, timeout=60)
    assert out.returncode == 2
    assert "unknown topic '/nope'" in out.stderr and "/rig/raw" in out.stderr
    out = subprocess.run(
        [sys.executable, "-m", "modal_twin.cli", "record", "-o", str(tmp_path / "b"),
         "/x:pkg/msg/Nope"], capture_output=True, text=True, timeout=60)
    assert out.returncode == 2 and "unknown message type 'pkg/msg/Nope'" in out.stderr


@pytest.mark.parametrize("cmd", [["bag", "info"], ["bag", "salvage"], ["replay"]])
def test_cli_foreign_input_no_traceback(tmp_path: Path, cmd: list[str]) -> None:
    f = tmp_path / "foreign"
    f.mkdir()
    (f / "junk.mcap").write_bytes(b"\x00" * 64)
    out = subprocess.run([sys.executable, "-m", "modal_twin.cli", *cmd, str(f)],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 2
    assert "Traceback" not in out.stderr
    assert str(f) in out.stderr


@pytest.mark.ros
def test_a_launcher_holds_the_domain_it_drew_until_it_stops(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """No ROS_DOMAIN_ID set: the launcher reserves one, no other process can lock it until
    the launcher stops (modal_twin.domain; the draws themselves: test/test_domain.py)."""
    import os

    from modal_twin import domain
    from modal_twin.launch import Launcher

    locks = tmp_path / "locks"  # this test's own: no other process draws from it
    monkeypatch.setattr(domain, "domain_lock_folder", lambda: locks)
    monkeypatch.delenv("ROS_DOMAIN_ID", raising=False)
    sc = load_scenario(_write(tmp_path, SCENARIO.format(duration=1.0, kind="random")))
    lau = Launcher(sc, run_dir=tmp_path / "run", say=lambda s: None)
    assert domain._try_lock(locks, lau.domain_id) is None  # held by the launcher
    lau.stop()
    fd = domain._try_lock(locks, lau.domain_id)
    assert fd is not None  # given back
    os.close(fd)


def test_launch_set_overrides_one_node_parameter_and_refuses_a_bad_one() -> None:
    from modal_twin.commands.launch import apply_sets

    sc = load_scenario(ROOT / "config" / "scenarios" / "vehicle3d_worn_yaw_damper.yaml")
    got = apply_sets(sc, ["excitation.seed=32", "twin.window_s=5.5"])
    params = {n.name: n.parameters for n in got.nodes}
    assert params["excitation"]["seed"] == 32 and params["twin"]["window_s"] == 5.5
    assert params["excitation"]["speed_kmh"] == 300.0  # the others as the file says
    assert {n.name: n.parameters for n in sc.nodes}["excitation"]["seed"] == 31
    with pytest.raises(ConfigError, match=r"expected NODE\.PARAM=VALUE"):
        apply_sets(sc, ["seed=32"])
    with pytest.raises(ConfigError, match="no node 'exitation'"):
        apply_sets(sc, ["exitation.seed=32"])
    out = subprocess.run([sys.executable, "-m", "modal_twin.cli", "launch",
                          "vehicle3d_worn_yaw_damper", "--set", "seed"],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 2 and "Traceback" not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1 and "--set 'seed'" in out.stderr
