"""Progress of long work: a bar on a terminal, plain lines in a log, nothing when quiet.

Core code marks its long loops with :func:`track` (an iterator wrapper) or :class:`Progress`
(a context manager with ``update``); what is shown is decided by one global
:class:`Verbosity` that the front end sets (``modal-twin --quiet / --verbose``):

========  ===========================================  =====================================
level     stderr is a terminal                         stderr is a file or a pipe
========  ===========================================  =====================================
QUIET     nothing                                      nothing
NORMAL    a tqdm bar, redrawn in place                 a line ``desc: 12/30 (40 %), 6.1 s``
                                                       at most every ``interval_s`` (5 s) and
                                                       a closing line if any line was written
VERBOSE   the bar                                      a start line, lines every 1 s, an end
========  ===========================================  =====================================

The library default is QUIET: imported as a library (tests, notebooks, nodes) the core
prints nothing (STYLE habit 8: progress is rendered by the front end, never printed by the
core); :func:`modal_twin.cli.main` sets NORMAL or what ``--quiet`` / ``--verbose`` ask.
Plain lines carry no carriage return and no ANSI code, so a log file or CI output stays
readable.

Why tqdm and not rich: tqdm is one small pure-Python package without dependencies (rich
pulls in markdown-it-py, pygments and mdurl), it renders a bar on any stream given to it,
and its per-update cost is below a microsecond when nothing is redrawn; rich's
strengths (tables, markup, live layouts) are not used here. tqdm's own fallback off a
terminal still writes carriage returns, so the plain lines are ours (a few lines of code).

Example
-------
>>> from modal_twin import progress
>>> total = 0
>>> for k in progress.track(range(3), "orders"):
...     total += k
>>> total
3
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from enum import IntEnum
from types import TracebackType
from typing import IO, Any, TypeVar

__all__ = ["STEP_SHOW_S", "Progress", "Verbosity", "get_verbosity", "set_verbosity", "step",
           "track"]

T = TypeVar("T")


class Verbosity(IntEnum):
    """How much the front end shows: QUIET (errors only), NORMAL, VERBOSE."""

    QUIET = 0
    NORMAL = 1
    VERBOSE = 2


_LEVEL = [Verbosity.QUIET]


def set_verbosity(level: Verbosity | int) -> None:
    """Set the process-wide verbosity (the CLI does this once, from its flags)."""
    _LEVEL[0] = Verbosity(level)


def get_verbosity() -> Verbosity:
    """Return the process-wide verbosity (library default QUIET)."""
    return _LEVEL[0]


def _fmt_count(n: float) -> str:
    return f"{n:g}" if isinstance(n, float) and not n.is_integer() else f"{int(n)}"


class Progress:
    """Progress of one long step, as a context manager.

    Parameters
    ----------
    desc : str
        What is running (``"global search"``, ``"SSI orders"``).
    total : int or float, optional
        Number of steps, if known.
    unit : str
        Name of one step (shown on the bar).
    stream : text stream, optional
        Where to write (default ``sys.stderr`` at the time of entry).
    interval_s : float
        Shortest time between two plain lines at NORMAL verbosity (VERBOSE: 1 s).

    Example
    -------
    >>> with Progress("generations", total=2) as p:
    ...     p.update()
    ...     p.update(note="cost 0.1")
    """

    def __init__(self, desc: str, total: float | None = None, *, unit: str = "it",
                 stream: IO[str] | None = None, interval_s: float = 5.0) -> None:
        self.desc, self.total, self.unit = desc, total, unit
        self.n: float = 0
        self.note = ""
        self._stream = stream
        self._interval = interval_s
        self._bar: Any = None
        self._t0 = self._last = 0.0
        self._lines = 0
        self._mode = "off"

    # -- context manager ------------------------------------------------------------------
    def __enter__(self) -> Progress:
        level = get_verbosity()
        out = self._stream if self._stream is not None else sys.stderr
        self._out = out
        self._t0 = self._last = time.monotonic()
        if level is Verbosity.QUIET:
            self._mode = "off"
        elif _is_terminal(out):
            from tqdm import tqdm

            self._mode = "bar"
            self._bar = tqdm(total=self.total, desc=self.desc, unit=self.unit, file=out,
                             leave=level is Verbosity.VERBOSE, mininterval=0.2,
                             dynamic_ncols=True)
        else:
            self._mode = "lines"
            if level is Verbosity.VERBOSE:
                self._interval = min(self._interval, 1.0)
                self._line("started")
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        # a generator closed early (``break`` out of :func:`track`) has not failed
        self.close(failed=exc_type is not None and not issubclass(exc_type, GeneratorExit))

    # -- updates --------------------------------------------------------------------------
    def update(self, n: float = 1, *, note: str | None = None) -> None:
        """Advance by ``n`` steps; ``note`` (e.g. the best cost so far) is shown beside."""
        self.n += n
        if note is not None:
            self.note = note
        if self._mode == "bar":
            if note is not None:
                self._bar.set_postfix_str(note, refresh=False)
            self._bar.update(n)
        elif self._mode == "lines":
            now = time.monotonic()
            if now - self._last >= self._interval:
                self._line()
                self._last = now

    def close(self, *, failed: bool = False) -> None:
        """End the display (a closing plain line if any line was written, or verbose)."""
        if self._mode == "bar":
            self._bar.close()
        elif self._mode == "lines" and (self._lines or get_verbosity() is Verbosity.VERBOSE):
            self._line("failed" if failed else "done")
        self._mode = "off"

    @property
    def elapsed_s(self) -> float:
        """Seconds since the step began."""
        return time.monotonic() - self._t0

    def _line(self, state: str = "") -> None:
        count = _fmt_count(self.n)
        if self.total:
            count += f"/{_fmt_count(self.total)} ({100.0 * self.n / self.total:.0f} %)"
        parts = [f"{self.desc}: {count} {self.unit}", f"{self.elapsed_s:.1f} s"]
        if self.note:
            parts.append(self.note)
        if state:
            parts.append(state)
        self._out.write(", ".join(parts) + "\n")
        self._out.flush()
        self._lines += 1


def _is_terminal(stream: IO[str]) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def track(iterable: Iterable[T], desc: str, total: float | None = None, *,
          unit: str = "it", stream: IO[str] | None = None,
          interval_s: float = 5.0) -> Iterator[T]:
    """Yield from ``iterable`` while showing its progress (:class:`Progress`).

    ``total`` defaults to ``len(iterable)`` where it has one.
    """
    if total is None and hasattr(iterable, "__len__"):
        total = len(iterable)  # type: ignore[arg-type]
    with Progress(desc, total, unit=unit, stream=stream, interval_s=interval_s) as p:
        for item in iterable:
            yield item
            p.update()


STEP_SHOW_S = 2.0
"""A :func:`step` still running after this many seconds says so (and then how long it took)."""


@contextmanager
def step(desc: str, *, stream: IO[str] | None = None,
         show_after_s: float = STEP_SHOW_S) -> Iterator[None]:
    """Mark one long step without a count.

    A line ``desc ...`` once it has run ``show_after_s`` and ``desc: done, 12.3 s`` at its
    end; nothing for a short step, nothing when QUIET; VERBOSE: every step's lines.

    Example
    -------
    >>> with step("identifying"):
    ...     pass
    """
    level = get_verbosity()
    out = stream if stream is not None else sys.stderr
    t0 = time.monotonic()
    shown = threading.Event()
    lock = threading.Lock()

    def say(text: str) -> None:
        with lock:
            out.write(text + "\n")
            out.flush()

    def started() -> None:
        shown.set()
        say(f"{desc} ...")

    timer = None
    if level is Verbosity.VERBOSE:
        started()
    elif level is Verbosity.NORMAL:
        timer = threading.Timer(show_after_s, started)
        timer.daemon = True
        timer.start()
    failed = False
    try:
        yield
    except BaseException:
        failed = True
        raise
    finally:
        if timer is not None:
            timer.cancel()
            timer.join()  # a line it is writing is written before the last one
        if shown.is_set():
            say(f"{desc}: {'failed' if failed else 'done'}, {time.monotonic() - t0:.1f} s")
