"""The first sample reaches the bag in every launch; nodes die with a SIGKILLed launcher;
scenarios cannot escape the run folder or start foreign programs."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from modal_twin.errors import ConfigError
from modal_twin.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]
RIG = f"{ROOT}/config/rigs/building_rig.yaml"

CHAIN = f"""
launch:
  name: chain
  duration_s: {{duration}}
  ready_timeout_s: 120
  nodes:
    - {{{{name: excitation, executable: excitation_node}}}}
    - {{{{name: rig, executable: rig_node}}}}
    - {{{{name: acquisition, executable: acquisition_node}}}}
  record: {{{{topics: [/excitation/signal, /measurement/frames]}}}}
excitation:
  ros__parameters: {{{{kind: random, duration_s: {{drive_s}}, fs_hz: 1000.0, block_size: 50,
                    rms: [0.1, 0.1, 0.1, 0.0, 0.0, 0.0], f_max_hz: 20.0, rate: 4.0}}}}
rig:
  ros__parameters: {{{{rig_file: {RIG}}}}}
acquisition:
  ros__parameters: {{{{rig_file: {RIG}}}}}
"""


def chain_scenario(tmp: Path, duration: float = 8.0, drive_s: float = 1.0) -> Path:
    """Excitation -> rig -> acquisition with the recorder; a short drive at 4x real time."""
    p = tmp / "chain.yaml"
    p.write_text(CHAIN.format(duration=duration, drive_s=float(drive_s)))
    return p


def first_indices(bag: Path) -> dict[str, int | None]:
    """First sample index of each signal topic in a bag (None: no block)."""
    from modal_twin.io.bag import read_blocks

    out: dict[str, int | None] = {}
    for topic in ("/excitation/signal", "/measurement/frames"):
        blocks = read_blocks(bag, topic)
        out[topic] = blocks[0].first_index if blocks else None
    return out


@pytest.mark.ros
def test_first_sample_is_recorded_in_every_launch(domain_id: int, tmp_path: Path) -> None:
    from modal_twin.launch import launch

    # the 1 s drive at 4x is in the bag 0.1 s after ready even at load 26 on 2 cores
    # (session 9): 2 s after ready is 20x that, 8 s only waited 10 x 6 s longer
    scen = chain_scenario(tmp_path, duration=2.0)
    for k in range(10):
        res = launch(scen, run_dir=tmp_path / f"run{k}", say=lambda s: None)
        assert res.exit_code == 0, res.message
        assert res.bag is not None
        assert first_indices(res.bag) == {"/excitation/signal": 0, "/measurement/frames": 0}, k


def child_pids(pid: int) -> list[int]:
    """Direct children of a process (from /proc)."""
    out = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                out.append(int(d.name))
    return out


def alive(pids: list[int]) -> list[int]:
    """The processes of ``pids`` still running (zombies count as gone)."""
    out = []
    for p in pids:
        try:
            state = Path(f"/proc/{p}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if state != "Z":
            out.append(p)
    return out


def kill_launcher_and_count_orphans(scen: Path, run_dir: Path, wait_s: float = 60.0
                                    ) -> tuple[int, int]:
    """Launch, SIGKILL the launcher once up; return (nodes started, nodes left after wait_s)."""
    proc = subprocess.Popen([sys.executable, "-m", "modal_twin.cli", "launch", str(scen),
                             "--run-dir", str(run_dir)], stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    for line in proc.stdout:
        if "up and matched" in line:
            break
    kids = child_pids(proc.pid)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    end = time.monotonic() + wait_s
    while alive(kids) and time.monotonic() < end:
        time.sleep(0.2)
    left = alive(kids)
    for p in left:
        os.kill(p, signal.SIGKILL)
    return len(kids), len(left)


@pytest.mark.ros
def test_nodes_die_with_a_sigkilled_launcher(domain_id: int, tmp_path: Path) -> None:
    n, left = kill_launcher_and_count_orphans(chain_scenario(tmp_path, duration=0, drive_s=30),
                                              tmp_path / "run")
    assert n == 4  # three nodes and the recorder
    assert left == 0


@pytest.mark.parametrize(("node", "match"), [
    ("{name: ../../../x, executable: rig_node}", r"nodes\[0\].name.*'../../../x'"),
    ("{name: x, executable: /bin/sh}", r"nodes\[0\].executable.*'/bin/sh'"),
])
def test_scenario_cannot_escape_or_run_programs(tmp_path: Path, node: str, match: str) -> None:
    p = tmp_path / "s.yaml"
    p.write_text(f"launch: {{nodes: [{node}]}}\n")
    with pytest.raises(ConfigError, match=match):
        load_scenario(p)


def test_allow_external_lets_a_foreign_executable_through(tmp_path: Path) -> None:
    p = tmp_path / "s.yaml"
    p.write_text("launch: {nodes: [{name: x, executable: my_daq_bridge}]}\n")
    assert load_scenario(p, allow_external=True).nodes[0].executable == "my_daq_bridge"
