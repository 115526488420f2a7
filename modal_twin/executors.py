"""One executor interface for all fan-out work (DESIGN.md, "Scale").

Candidate fits, global-search populations, multi-start refinements and the windows of a
monitoring campaign are independent tasks. They go through a
:class:`concurrent.futures.Executor`, chosen by one spec:

========================  ==================================================================
spec                      executor
========================  ==================================================================
``None`` / ``"auto"``     a process pool of the free cores when more than one is free
                          (CPU affinity less the 1-minute load average), else serial
``1`` / ``"serial"``      :class:`SerialExecutor` (in this process, one task at a time)
``N`` / ``"N"`` (N > 1)   a :class:`~concurrent.futures.ProcessPoolExecutor` of N processes
``"dask://HOST:PORT"``    ``dask.distributed.Client("tcp://HOST:PORT").get_executor()``
an ``Executor``           itself (the caller keeps ownership; it is not shut down here)
========================  ==================================================================

Results do not depend on the executor: :func:`map_ordered` returns them in input order, and
seeded work must carry its seed in the task's arguments (never the global RNG of a worker).

Example
-------
>>> with make_executor("serial") as ex:
...     map_ordered(ex, abs, [-1, 2, -3])
[1, 2, 3]
"""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Executor, Future, ProcessPoolExecutor
from contextlib import contextmanager
from typing import Any, TypeVar

from modal_twin.errors import OptionError

__all__ = ["ExecutorSpec", "SerialExecutor", "free_cores", "make_executor", "map_ordered",
           "mapper"]

_log = logging.getLogger(__name__)
T = TypeVar("T")
R = TypeVar("R")
ExecutorSpec = str | int | Executor | None
DASK_SCHEME = "dask://"


class SerialExecutor(Executor):
    """Run each submitted call at once in this process (a ``concurrent.futures`` executor).

    The future it returns is already done; an exception raised by the call is set on it.
    """

    def submit(self, fn: Callable[..., R], /, *args: Any, **kwargs: Any) -> Future[R]:
        """Call ``fn(*args, **kwargs)`` now and return its completed future."""
        fut: Future[R] = Future()
        try:
            fut.set_result(fn(*args, **kwargs))
        except Exception as err:  # delivered through the future, as a pool does
            fut.set_exception(err)
        return fut


def free_cores() -> int:
    """Cores this process may use (affinity) less the 1-minute load average, at least 1."""
    n = len(os.sched_getaffinity(0))
    try:
        load = os.getloadavg()[0]
    except OSError:
        load = 0.0
    return max(1, min(n, round(n - load)))


def _pool(n: int) -> ProcessPoolExecutor:
    _log.debug("process pool of %d workers", n)
    return ProcessPoolExecutor(max_workers=n)


def _parse(spec: str | int) -> int | str:
    """Return a worker count (``int``) or a Dask address (``str``); raises on anything else."""
    n = 0
    if isinstance(spec, int) and not isinstance(spec, bool):
        n = spec
    elif not isinstance(spec, str):
        pass
    elif spec.startswith(DASK_SCHEME) and len(spec) > len(DASK_SCHEME):
        return "tcp://" + spec[len(DASK_SCHEME):]
    elif spec in ("serial", "auto"):
        n = 1 if spec == "serial" else free_cores()
    elif spec.strip().isdigit():
        n = int(spec)
    if n < 1:
        msg = (f"executor: expected None, 'auto', 'serial', N >= 1, 'dask://HOST:PORT' or an "
               f"Executor, got {spec!r}")
        raise OptionError(msg)
    return n


@contextmanager
def make_executor(spec: ExecutorSpec = None) -> Iterator[Executor]:
    """Return the executor of ``spec`` (module table), shut down on leaving unless it was given.

    Parameters
    ----------
    spec : None, str, int or Executor
        ``None`` / ``"auto"``, ``1`` / ``"serial"``, ``N`` (also as a string, e.g. from
        ``--jobs``), ``"dask://HOST:PORT"`` or an executor.

    Yields
    ------
    Executor

    Raises
    ------
    OptionError
        An unknown spec, or ``N < 1``.

    """
    if isinstance(spec, Executor):
        yield spec
        return
    what = _parse("auto" if spec is None else spec)
    if isinstance(what, str):
        from dask.distributed import Client  # optional: only for clusters

        client = Client(what)
        try:
            yield client.get_executor()
        finally:
            client.close()
        return
    ex: Executor = SerialExecutor() if what == 1 else _pool(what)
    try:
        yield ex
    finally:
        ex.shutdown(wait=True, cancel_futures=True)


def map_ordered(executor: Executor, fn: Callable[[T], R], items: Iterable[T]) -> list[R]:
    """``[fn(x) for x in items]`` on ``executor``, in input order whatever the executor.

    A process pool gets the items in chunks (about four per worker) so that short tasks do
    not pay one round trip each. ``fn`` and the items must be picklable for a process pool
    or a cluster (module-level functions, or instances of module-level classes).
    """
    xs = list(items)
    if isinstance(executor, SerialExecutor):
        return [fn(x) for x in xs]
    if isinstance(executor, ProcessPoolExecutor):
        n_workers = len(os.sched_getaffinity(0))
        chunk = max(1, math.ceil(len(xs) / (4 * n_workers)))
        return list(executor.map(fn, xs, chunksize=chunk))
    futures = [executor.submit(fn, x) for x in xs]
    return [f.result() for f in futures]


def mapper(executor: Executor) -> Callable[[Callable[[T], R], Iterable[T]], list[R]]:
    """Return a ``map``-like callable on ``executor`` (e.g. for scipy's ``workers=``)."""

    def _map(fn: Callable[[T], R], items: Iterable[T]) -> list[R]:
        return map_ordered(executor, fn, items)

    return _map
