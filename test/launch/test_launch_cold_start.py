"""No run lost to a cold start: the nodes compile their kernels before the run starts.

Known answer: scenario S2 (``config/scenarios/s2_vehicle_elastic_equipment.yaml``) with its
excitation cut to 8 s at 200 Hz is 1601 samples; launched with numba's cache pointed at an
empty folder (``NUMBA_CACHE_DIR``: every kernel compiled from scratch, as on a fresh
checkout), the bag holds all 1601 of them, because the rig and the twin compile while they
configure (``compiling kernels ... done in X s`` in their logs, X well above the ~1 s of a
load from the disk cache) and the launcher starts the excitation, and counts the run's
duration, only once every node has said ``ready``. With a ready timeout shorter than the
compile, the launch ends NOT_READY with one line naming the nodes not yet ready, the twin
among them.

The same launch is S2's own check (the twin of the rigid-equipment car beside the rig with
the hidden elastic mount): once ready, a run from a cold cache is the run from a warm one,
so one launch serves both (one S2 launch fewer in the suite).
"""

from __future__ import annotations

import itertools
import re
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

if TYPE_CHECKING:
    from modal_twin.launch import LaunchResult

pytestmark = [pytest.mark.ros, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[2]
S2 = ROOT / "config" / "scenarios" / "s2_vehicle_elastic_equipment.yaml"
DONE = re.compile(r"compiling kernels \.\.\. done in ([0-9.]+) s")


def _launch(tmp: Path, cache: Path, *, ready_timeout_s: float | None = None,
            only: str = ""):
    from modal_twin.launch import Launcher
    from modal_twin.scenario import load_scenario, with_parameters

    sc = load_scenario(S2)
    sc = with_parameters(replace(sc, duration_s=16.0), "excitation", duration_s=8.0)
    if ready_timeout_s is not None:
        sc = replace(sc, ready_timeout_s=ready_timeout_s)
    if only:  # that node alone, nothing recorded
        sc = replace(sc, nodes=tuple(n for n in sc.nodes if n.name == only), record_topics=())
    lines: list[str] = []
    mp = pytest.MonkeyPatch()
    mp.delenv("ROS_DOMAIN_ID", raising=False)  # the launcher reserves its own
    mp.setenv("NUMBA_CACHE_DIR", str(cache))
    try:
        res = Launcher(sc, run_dir=tmp / "run", say=lines.append).run()
    finally:
        mp.undo()
    return res, lines


@pytest.fixture(scope="module")
def cold_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[LaunchResult, Path]:
    """S2 (8 s of track) launched once on an empty numba cache: the result and the cache."""
    tmp = tmp_path_factory.mktemp("cold")
    cache = tmp / "numba"
    cache.mkdir()
    res, _ = _launch(tmp, cache)
    assert res.exit_code == 0, res.message
    assert res.bag is not None
    return res, cache


def test_a_cold_start_compiles_before_the_run_and_records_every_sample(
        cold_run: tuple[LaunchResult, Path]) -> None:
    from modal_twin.io.bag import read_blocks

    res, cache = cold_run
    assert res.bag is not None
    frames = read_blocks(res.bag, "/measurement/frames")
    assert sum(b.n_samples for b in frames) == 1601  # 8 s at 200 Hz: nothing lost
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
    # model), so the twin cannot be ready whatever the machine's load. The twin is launched
    # alone: with the whole graph, which nodes the line names depends on the load (nodes
    # not yet discovered are named before the ones not ready: "missing nodes acquisition,
    # rig" with the twin discovered but compiling, at load 8.5 on 2 cores), and the rig's
    # shorter compile was done on a busy CI run
    res, lines = _launch(tmp_path, cache, ready_timeout_s=5.0, only="twin")
    assert res.exit_code == ExitCode.NOT_READY
    assert "\n" not in res.message
    # each stage of getting ready names it: "missing nodes twin" (not yet discovered),
    # "missing endpoints twin:/..." (its topics not yet made) or "missing ready from twin
    # (starting: ...)"
    assert res.message.startswith("not ready after 5 s: missing "), res.message
    assert re.search(r"missing (nodes twin$|endpoints twin:/|ready from twin \()",
                     res.message), res.message
    assert f"launch: {res.message}" in lines


def test_s2_launch_twin_error_is_largest_in_the_bending_band_channels(
        cold_run: tuple[LaunchResult, Path]) -> None:
    from modal_twin.demo import last_metrics
    from modal_twin.io.bag import read_blocks

    res, _ = cold_run
    assert res.bag is not None
    frames = read_blocks(res.bag, "/measurement/frames")
    got = sum(b.n_samples for b in frames)  # 8 s at 200 Hz, nothing lost
    gaps = [(a.first_index + a.n_samples, b.first_index) for a, b in itertools.pairwise(frames)
            if b.first_index != a.first_index + a.n_samples]
    assert got == 1601, (f"{got} samples: first index {frames[0].first_index}, last "
                         f"{frames[-1].first_index + frames[-1].n_samples}, gaps {gaps}")
    assert "table_zt1" in frames[0].channel_names and "floor_mid_z" in frames[0].channel_names
    m = last_metrics(res.bag)
    assert m is not None and m.samples == 1601
    err = dict(zip(m.channel_names, m.residual_rms, strict=True))
    # the rigid-equipment twin fails near EQ1 / mid-car, much less above the rear pivot
    assert err["floor_mid_z"] > 10.0
    assert err["floor_mid_z"] > 2.0 * err["floor_rear_pivot_z"]
