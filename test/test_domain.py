"""ROS domain reservation: bound RTPS ports and per-domain locks across processes."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from modal_twin import domain
from modal_twin.domain import domains_bound, reserve_domain
from modal_twin.errors import LaunchError

ROOT = Path(__file__).resolve().parents[1]
ALL = range(1, 233)

# A child process: every domain but FREE (argv[2], comma-separated) has a bound port, it
# waits for the common start time argv[3], reserves in the lock folder argv[1], says the id
# (or "none") and holds it until its stdin closes.
CHILD = """
import sys, time
from pathlib import Path
from modal_twin import domain
from modal_twin.errors import LaunchError
free = {int(d) for d in sys.argv[2].split(",")}
domain._udp_ports_in_use = lambda: {7400 + 250 * d for d in range(1, 233) if d not in free}
time.sleep(max(float(sys.argv[3]) - time.time(), 0.0))
try:
    r = domain.reserve_domain(folder=Path(sys.argv[1]))
except LaunchError:
    print("none", flush=True)
else:
    print(r.domain_id, flush=True)
sys.stdin.read()
"""


def _only_free(monkeypatch: pytest.MonkeyPatch, free: set[int]) -> None:
    """Every domain but ``free`` has a bound RTPS port (in this process only)."""
    ports = {7400 + 250 * d + 11 for d in ALL if d not in free}
    monkeypatch.setattr(domain, "_udp_ports_in_use", lambda: ports)


def _children(folder: Path, free: set[int], n: int) -> list[subprocess.Popen[str]]:
    start = time.time() + 2.0  # all draw at once, after their imports
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), *sys.path])}
    return [subprocess.Popen([sys.executable, "-c", CHILD, str(folder),
                              ",".join(map(str, sorted(free))), repr(start)],
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env)
            for _ in range(n)]


def _said(procs: list[subprocess.Popen[str]]) -> list[str]:
    out = []
    for p in procs:
        assert p.stdout is not None
        out.append(p.stdout.readline().strip())
    return out


def _end(procs: list[subprocess.Popen[str]]) -> None:
    for p in procs:
        p.kill()
        p.wait(30)


def test_the_rtps_port_ranges_map_to_their_domains() -> None:
    # domain d owns [7400 + 250 d, 7400 + 250 (d + 1)); below 7400 is no domain's
    assert domains_bound([80, 7399, 7400, 7649, 7650, 7911, 65535]) == {0, 1, 2, 232}


def test_a_bound_udp_port_marks_its_domain_in_use() -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
        assert port in domain._udp_ports_in_use()
        assert (port - 7400) // 250 in domains_bound(domain._udp_ports_in_use())


def test_the_one_domain_without_bound_ports_is_drawn(monkeypatch: pytest.MonkeyPatch,
                                                     tmp_path: Path) -> None:
    _only_free(monkeypatch, {77})
    for _ in range(5):
        with reserve_domain(folder=tmp_path) as r:
            assert r.domain_id == 77 and r.held


def test_a_held_domain_is_never_drawn_and_is_free_again_once_released(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    _only_free(monkeypatch, {5, 6, 7})
    first = reserve_domain(folder=tmp_path)
    drawn = set()
    for _ in range(30):
        with reserve_domain(folder=tmp_path) as r:
            drawn.add(r.domain_id)
    assert first.domain_id not in drawn and drawn <= {5, 6, 7}
    second = reserve_domain(folder=tmp_path)
    third = reserve_domain(folder=tmp_path)
    assert {first.domain_id, second.domain_id, third.domain_id} == {5, 6, 7}
    with pytest.raises(LaunchError, match=r"no free ROS domain.*ROS_DOMAIN_ID"):
        reserve_domain(folder=tmp_path)
    second.release()
    assert reserve_domain(folder=tmp_path).domain_id == second.domain_id
    first.release()
    third.release()


def test_concurrent_processes_never_share_a_domain(tmp_path: Path) -> None:
    """Four processes draw at once from two free domains: two get one each, two get none."""
    procs = _children(tmp_path, {5, 6}, 4)
    try:
        said = _said(procs)
    finally:
        _end(procs)
    assert sorted(said) == ["5", "6", "none", "none"]


def test_a_domain_is_free_again_when_its_holder_dies(monkeypatch: pytest.MonkeyPatch,
                                                     tmp_path: Path) -> None:
    _only_free(monkeypatch, {9})
    procs = _children(tmp_path, {9}, 1)
    try:
        assert _said(procs) == ["9"]
        with pytest.raises(LaunchError):
            reserve_domain(folder=tmp_path)
    finally:
        _end(procs)  # SIGKILL: nothing released by the holder itself
    with reserve_domain(folder=tmp_path) as r:
        assert r.domain_id == 9 and r.held


def test_a_lock_folder_open_to_others_is_not_used(monkeypatch: pytest.MonkeyPatch,
                                                  tmp_path: Path) -> None:
    _only_free(monkeypatch, {12})
    folder = tmp_path / "locks"
    folder.mkdir(mode=0o777)
    folder.chmod(0o777)
    with reserve_domain(folder=folder) as r:  # the bound ports alone decide
        assert r.domain_id == 12 and not r.held
    assert list(folder.iterdir()) == []
    private = tmp_path / "private"
    with reserve_domain(folder=private) as r:
        assert r.held
        assert private.stat().st_mode & 0o777 == 0o700
        assert (private / "12.lock").stat().st_mode & 0o777 == 0o600
