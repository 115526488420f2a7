"""Launched nodes bind UDP on 127.0.0.1 only unless ``--network``; Ctrl-C exits 130;
SIGTERM is forwarded (exit 0, the bag closed, no node left).

Two launches serve these checks: the loopback-only one ends with Ctrl-C (SIGINT), the
``--network`` one with SIGTERM.
"""

from __future__ import annotations

import os
import signal
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from modal_twin.exit_codes import ExitCode

SCENARIO = """
launch:
  name: lo
  duration_s: 0
  ready_timeout_s: 60
  nodes:
    - {name: excitation, executable: excitation_node}
  record: {topics: [/excitation/signal]}
excitation:
  ros__parameters: {kind: random, duration_s: 600.0, fs_hz: 200.0, block_size: 20,
                    rms: [0.1, 0.1, 0.1, 0.0, 0.0, 0.0], f_max_hz: 20.0}
"""


def udp_addresses(pid: int) -> set[str]:
    """Local IPv4 addresses of the UDP sockets process ``pid`` holds (/proc/net/udp)."""
    inodes = set()
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        try:
            target = os.readlink(fd)
        except OSError:
            continue
        if target.startswith("socket:["):
            inodes.add(target[8:-1])
    out = set()
    for line in Path(f"/proc/{pid}/net/udp").read_text().splitlines()[1:]:
        cols = line.split()
        if cols[9] in inodes:
            hexaddr = cols[1].split(":")[0]
            out.add(".".join(str(int(hexaddr[i:i + 2], 16)) for i in (6, 4, 2, 0)))
    return out


def children(pid: int) -> list[int]:
    """Direct child processes of ``pid``."""
    text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    return [int(c) for c in text.split()]


def launch_until_matched(tmp_path: Path, *extra: str) -> subprocess.Popen[str]:
    scen = tmp_path / "s.yaml"
    scen.write_text(SCENARIO)
    env = {k: v for k, v in os.environ.items()
           if k not in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "FASTRTPS_DEFAULT_PROFILES_FILE",
                        "MODAL_TWIN_TRANSPORT")}
    proc = subprocess.Popen(
        [sys.executable, "-m", "modal_twin.cli", "launch", str(scen), "--run-dir",
         str(tmp_path / "run"), *extra], stdout=subprocess.PIPE, text=True, env=env)
    assert proc.stdout is not None
    for line in proc.stdout:
        if "up and matched" in line:
            return proc
    proc.wait(60)
    pytest.fail(f"the launch did not come up (exit {proc.returncode})")


@pytest.fixture(scope="module")
def network_launch(tmp_path_factory: pytest.TempPathFactory
                   ) -> tuple[dict[int, set[str]], int, Path]:
    """A ``--network`` launch, sent SIGTERM once up and matched: the UDP addresses of its
    nodes, the launcher's exit code and the folder of the run."""
    tmp = tmp_path_factory.mktemp("network")
    mp = pytest.MonkeyPatch()
    mp.delenv("ROS_DOMAIN_ID", raising=False)  # the launcher reserves its own
    try:
        proc = launch_until_matched(tmp, "--network")
        try:
            addrs = {pid: udp_addresses(pid) for pid in children(proc.pid)}
        finally:
            proc.send_signal(signal.SIGTERM)
            code = proc.wait(60)
    finally:
        mp.undo()
    return addrs, code, tmp / "run"


@pytest.mark.ros
@pytest.mark.parametrize("network", [False, True])
def test_launched_nodes_bind_the_loopback_only_unless_network(
        domain_id: int, tmp_path: Path, network: bool, request: pytest.FixtureRequest
) -> None:
    if network:  # the launch that test_sigterm_is_forwarded_and_bag_is_closed ends
        addrs, _, _ = request.getfixturevalue("network_launch")
    else:
        proc = launch_until_matched(tmp_path)
        try:
            addrs = {pid: udp_addresses(pid) for pid in children(proc.pid)}
        finally:
            proc.send_signal(signal.SIGINT)
            code = proc.wait(60)
    assert len(addrs) == 2  # the excitation node and the recorder
    assert all(addrs.values())  # each holds its DDS sockets
    bound = set().union(*addrs.values())
    if network:
        assert bound - {"127.0.0.1"}  # Fast DDS's own transports: 0.0.0.0 / the interfaces
    else:
        assert bound == {"127.0.0.1"}, addrs
        ctrl_c_exits_130(code, tmp_path)  # the same launch serves both (one launch fewer)


@pytest.mark.ros
def test_sigterm_is_forwarded_and_bag_is_closed(
        network_launch: tuple[dict[int, set[str]], int, Path]) -> None:
    _, code, run = network_launch
    assert code == 0
    assert (run / "bag" / "metadata.yaml").is_file()
    out = subprocess.run(["pgrep", "-f", str(run)], capture_output=True, check=False)
    assert out.stdout == b""  # no node outlived the launcher


def ctrl_c_exits_130(code: int, tmp_path: Path) -> None:
    """Ctrl-C on the launcher once up and matched: exit 130; the run closed, all private."""
    assert code == ExitCode.INTERRUPTED == 130
    assert (tmp_path / "run" / "bag" / "metadata.yaml").is_file()  # the bag still closed
    # one file-mode policy: the launcher's logs and parameters, the bag, all private
    run = tmp_path / "run"
    for f in (run / "logs" / "excitation.log", run / "params" / "excitation.yaml",
              run / "bag" / "metadata.yaml"):
        assert stat.S_IMODE(f.stat().st_mode) == 0o600, f
    for d in (run, run / "logs", run / "bag"):
        assert stat.S_IMODE(d.stat().st_mode) == 0o700, d


@pytest.mark.ros
def test_the_transport_follows_the_network_choice(tmp_path: Path) -> None:
    from modal_twin.io.ros import FASTDDS_PROFILES, FASTDDS_PROFILES_NETWORK, dds_env

    env = dds_env({})
    assert env["FASTRTPS_DEFAULT_PROFILES_FILE"] == str(FASTDDS_PROFILES)
    assert env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "SYSTEM_DEFAULT"  # not rmw's LOCALHOST
    assert dds_env(dict(env)) == env  # a child process keeps its parent's choice
    assert dds_env({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}) == env
    net = dds_env(dict(env), network=True)
    assert net["FASTRTPS_DEFAULT_PROFILES_FILE"] == str(FASTDDS_PROFILES_NETWORK)
    assert net["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "SUBNET"
    assert dds_env({"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET"}) == net
    own = {"FASTRTPS_DEFAULT_PROFILES_FILE": "/my/profiles.xml"}
    assert dds_env(dict(own)) == {**own, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    udp = dds_env({}, shared_memory=False, folder=tmp_path)
    text = Path(udp["FASTRTPS_DEFAULT_PROFILES_FILE"]).read_text()
    users = text[text.index("<userTransports>"):text.index("</userTransports>")]
    assert "modal_twin_udp_loopback" in users and "modal_twin_shm" not in users
    # the network file is the loopback one without the participant and its transports
    lo, nw = FASTDDS_PROFILES.read_text(), FASTDDS_PROFILES_NETWORK.read_text()
    assert "<interfaceWhiteList>" in lo
    assert "<participant " not in nw and "<transport_descriptors>" not in nw
    assert lo[lo.index("<data_writer"):] == nw[nw.index("<data_writer"):]
