"""One executor interface: the specs, the serial executor, ordered maps (modal_twin.executors)."""

from __future__ import annotations

from concurrent.futures import Executor, ProcessPoolExecutor, ThreadPoolExecutor

import numpy as np
import pytest

from modal_twin.errors import OptionError
from modal_twin.executors import SerialExecutor, free_cores, make_executor, map_ordered, mapper


def seeded_sum(seed: int) -> float:
    """Work that carries its seed (never the global RNG of a worker)."""
    return float(np.random.default_rng(seed).standard_normal(1000).sum())


def fails(x: int) -> int:
    if x == 2:
        msg = f"x: expected not 2, got {x}"
        raise ValueError(msg)
    return x


@pytest.mark.parametrize(("spec", "kind"), [(1, SerialExecutor), ("serial", SerialExecutor),
                                            ("1", SerialExecutor), (2, ProcessPoolExecutor),
                                            ("2", ProcessPoolExecutor)])
def test_specs_give_their_executor(spec, kind):
    with make_executor(spec) as ex:
        assert type(ex) is kind
        assert map_ordered(ex, seeded_sum, range(7)) == [seeded_sum(s) for s in range(7)]


def test_auto_is_serial_or_a_pool_of_the_free_cores():
    with make_executor(None) as ex:
        if free_cores() > 1:
            assert isinstance(ex, ProcessPoolExecutor)
        else:
            assert isinstance(ex, SerialExecutor)
    assert 1 <= free_cores() <= len(__import__("os").sched_getaffinity(0))


def test_a_given_executor_is_used_and_left_open():
    with ThreadPoolExecutor(2) as pool:
        with make_executor(pool) as ex:
            assert ex is pool
        # still usable: make_executor did not shut it down
        assert map_ordered(pool, abs, [-3, 1, -2]) == [3, 1, 2]


def test_results_in_input_order_and_identical_across_executors():
    items = list(range(40))[::-1]
    want = [seeded_sum(s) for s in items]
    for spec in (1, 2):
        with make_executor(spec) as ex:
            assert map_ordered(ex, seeded_sum, items) == want
            assert mapper(ex)(seeded_sum, items) == want


def test_serial_executor_delivers_exceptions_through_the_future():
    ex = SerialExecutor()
    assert ex.submit(fails, 1).result() == 1
    fut = ex.submit(fails, 2)
    assert isinstance(fut.exception(), ValueError)
    with pytest.raises(ValueError, match="x: expected not 2, got 2"):
        map_ordered(ex, fails, [1, 2, 3])
    assert isinstance(ex, Executor)


@pytest.mark.parametrize("spec", [0, -2, True, "fast", "dask://", 2.5])
def test_bad_spec_raises(spec):
    cm = make_executor(spec)
    with pytest.raises(OptionError, match="executor: expected None, 'auto', 'serial', N >= 1"):
        cm.__enter__()


def test_dask_local_cluster_of_two_workers():
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        addr = "dask://" + cluster.scheduler_address.removeprefix("tcp://")
        with make_executor(addr) as ex:
            got = map_ordered(ex, seeded_sum, range(12))
        assert len(cluster.workers) == 2
    assert got == [seeded_sum(s) for s in range(12)]
