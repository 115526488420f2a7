"""No run lost to a cold start: the nodes compile their kernels before the run starts.

Known answer: scenario S2 (``config/scenarios/s2_vehicle_elastic_equipment.yaml``) with its
excitation cut to 4 s at 200 Hz is 801 samples; launched with numba's cache pointed at an
empty folder (``NUMBA_CACHE_DIR``: every kernel compiled from scratch, as on a fresh
checkout), the bag holds all 801 of them, because the rig and the twin compile while they
configure (``compiling kernels ... done in X s`` in their logs, X well above the ~1 s of a
load from the disk cache) and the launcher starts the excitation, and counts the run's
duration, only once every node has said ``ready``. With a ready timeout shorter than the
compile, the launch ends NOT_READY with one line naming the nodes not yet ready, the twin
among them.
"""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import pytest

pytestmark = [pytest.mark.ros, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[2]
S2 = ROOT / "config" / "scenarios" / "s2_vehicle_elastic_equipment.yaml"
DONE = re.compile(r"compiling kernels \.\.\. done in ([0-9.]+) s")


def _launch(tmp: Path, cache: Path, *, ready_timeout_s: float | None = None):
    from modal_twin.launch import Launcher, free_domain_id
    from modal_twin.scenario import load_scenario, with_parameters

    sc = load_scenario(S2)
    sc = with_parameters(replace(sc, duration_s=10.0), "excitation", duration_s=4.0)
    if ready_timeout_s is not None:
        sc = replace(sc, ready_timeout_s=ready_timeout_s)
    lines: list[str] = []
    mp = pytest.MonkeyPatch()
    mp.setenv("ROS_DOMAIN_ID", str(free_domain_id()))
    mp.setenv("NUMBA_CACHE_DIR", str(cache))
    try:
        res = Launcher(sc, run_dir=tmp / "run", say=lines.append).run()
    finally:
        mp.undo()
    return res, lines


def test_a_cold_start_compiles_before_the_run_and_records_every_sample(tmp_path: Path) -> None:
    from modal_twin.io.bag import read_blocks

    cache = tmp_path / "numba"
    cache.mkdir()
    res, _ = _launch(tmp_path, cache)
    assert res.exit_code == 0, res.message
    assert res.bag is not None
    frames = read_blocks(res.bag, "/measurement/frames")
    assert sum(b.n_samples for b in frames) == 801  # 4 s at 200 Hz: nothing lost
    assert frames[0].first_index == 0
    assert any(cache.rglob("*.nbi"))  # compiled into the empty cache, not loaded
    for node in ("rig", "twin"):
        log = (res.run_dir / "logs" / f"{node}.log").read_text()
        took = [float(x) for x in DONE.findall(log)]
        assert len(took) == 1, log[-2000:]
        assert took[0] > 2.0  # a compile (seconds), not a load from the disk cache
        # the compile ends before the first block: the excitation started after it
        assert log.index("compiling kernels ... done") < log.find("drive") or \
            "drive" not in log


def test_a_node_still_compiling_at_the_ready_timeout_is_named_in_one_line(
        tmp_path: Path) -> None:
    from modal_twin.exit_codes import ExitCode

    cache = tmp_path / "numba"
    cache.mkdir()
    # 5 s: below the CPU time of the twin's cold compile (its kernels and the vehicle's
    # model), so the twin cannot be ready whatever the machine's load; the rig's compile is
    # shorter, so whether it is named depends on the load (it was ready on a busy CI run)
    res, lines = _launch(tmp_path, cache, ready_timeout_s=5.0)
    assert res.exit_code == ExitCode.NOT_READY
    assert "\n" not in res.message
    # "missing nodes A, B" (not yet discovered) or "missing ready from A (...); B (...)"
    assert res.message.startswith("not ready after 5 s: missing "), res.message
    assert re.search(r"missing (nodes .*\btwin\b|ready from .*\btwin \()", res.message), \
        res.message
    assert f"launch: {res.message}" in lines
