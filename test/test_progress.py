"""Progress display: plain lines off a terminal, a bar on one, nothing when quiet."""

from __future__ import annotations

import io
import re

import pytest

from modal_twin import progress
from modal_twin.progress import Progress, Verbosity, track

ANSI = re.compile(r"\x1b\[")


class _Clock:
    """A monotonic clock the test advances by hand (no sleeping, no wall-clock limit)."""

    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


@pytest.fixture
def clock(monkeypatch: pytest.MonkeyPatch) -> _Clock:
    c = _Clock()
    monkeypatch.setattr(progress.time, "monotonic", c)
    return c


@pytest.fixture
def level():
    old = progress.get_verbosity()
    yield progress.set_verbosity
    progress.set_verbosity(old)


def test_library_default_is_quiet() -> None:
    """Imported as a library the core prints no progress (the CLI turns it on)."""
    import subprocess
    import sys

    code = "from modal_twin import progress; print(progress.get_verbosity().name)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "QUIET"


def test_plain_lines_are_throttled_and_clean(clock: _Clock, level) -> None:
    level(Verbosity.NORMAL)
    out = io.StringIO()
    with Progress("generations", total=30, unit="gen", stream=out, interval_s=5.0) as p:
        for _ in range(30):
            clock.t += 1.0  # 1 s per step: a line every 5 steps at most
            p.update(note="cost 0.5")
    text = out.getvalue()
    assert "\r" not in text
    assert not ANSI.search(text)
    lines = text.splitlines()
    assert len(lines) == 30 // 5 + 1  # six throttled lines and the closing one
    assert lines[0] == "generations: 5/30 (17 %) gen, 5.0 s, cost 0.5"
    assert lines[-1] == "generations: 30/30 (100 %) gen, 30.0 s, cost 0.5, done"


def test_short_step_prints_nothing_at_normal(clock: _Clock, level) -> None:
    level(Verbosity.NORMAL)
    out = io.StringIO()
    assert list(track(range(4), "orders", stream=out)) == [0, 1, 2, 3]
    assert out.getvalue() == ""


def test_verbose_prints_start_and_end(clock: _Clock, level) -> None:
    level(Verbosity.VERBOSE)
    out = io.StringIO()
    for _ in track([1, 2, 3], "orders", unit="order", stream=out):
        clock.t += 0.5
    lines = out.getvalue().splitlines()
    assert lines[0] == "orders: 0/3 (0 %) order, 0.0 s, started"
    assert lines[1] == "orders: 2/3 (67 %) order, 1.0 s"
    assert lines[-1] == "orders: 3/3 (100 %) order, 1.5 s, done"


def test_failure_is_named(clock: _Clock, level) -> None:
    level(Verbosity.VERBOSE)
    out = io.StringIO()

    def fail() -> None:
        with Progress("fit", stream=out):
            msg = "boom"
            raise RuntimeError(msg)

    with pytest.raises(RuntimeError, match="boom"):
        fail()
    assert out.getvalue().splitlines()[-1] == "fit: 0 it, 0.0 s, failed"


def test_break_out_of_track_is_not_a_failure(clock: _Clock, level) -> None:
    level(Verbosity.VERBOSE)
    out = io.StringIO()
    gen = track(range(10), "scan", stream=out)
    for k in gen:
        if k == 2:
            break
    gen.close()
    assert out.getvalue().splitlines()[-1].endswith(", done")


@pytest.mark.parametrize("stream_type", [io.StringIO, _Tty])
def test_quiet_prints_nothing(clock: _Clock, level, stream_type: type[io.StringIO]) -> None:
    level(Verbosity.QUIET)
    out = stream_type()
    with Progress("global search", total=5, stream=out) as p:
        for _ in range(5):
            clock.t += 10.0
            p.update()
    assert out.getvalue() == ""


@pytest.mark.parametrize(("verbosity", "left"), [(Verbosity.NORMAL, False),
                                                 (Verbosity.VERBOSE, True)])
def test_terminal_gets_a_bar(level, verbosity: Verbosity, left: bool) -> None:
    level(verbosity)
    out = _Tty()
    for _ in track(range(3), "orders", stream=out):
        pass
    assert out.getvalue().startswith("\rorders:")  # drawn in place
    assert ("3/3" in out.getvalue()) is left  # NORMAL clears its bar at the end


def test_cli_flags_set_the_level(level) -> None:
    from modal_twin.cli import _parser

    a = _parser().parse_args(["--quiet", "demo"])
    assert a.quiet and not a.verbose
    a = _parser().parse_args(["bag", "info", "some.bag", "--verbose"])  # after the command
    assert a.verbose and not a.quiet
    a = _parser().parse_args(["demo"])
    assert not (a.quiet or a.verbose)
    with pytest.raises(SystemExit):
        _parser().parse_args(["--quiet", "--verbose", "demo"])


def test_global_search_reports_generations(clock: _Clock, level,
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    """Differential evolution calls back once per generation: lines name the best cost."""
    import numpy as np

    from modal_twin.updating.optimize import global_search

    class _Quadratic:
        theta0 = np.zeros(2)
        lower = np.full(2, -1.0)
        upper = np.full(2, 1.0)

        def cost(self, theta: np.ndarray) -> float:
            clock.t += 0.01
            return float(np.sum((theta - 0.3) ** 2))

    level(Verbosity.VERBOSE)
    out = io.StringIO()
    monkeypatch.setattr(progress.sys, "stderr", out)
    problem = _Quadratic()
    _, cost, _ = global_search(problem, maxiter=5, popsize=5, tol=0.0)  # type: ignore[arg-type]
    lines = out.getvalue().splitlines()
    assert lines[0].startswith("global search: 0/5")
    assert lines[-1].startswith("global search: 5/5 (100 %) generation")
    assert "cost " in lines[-1] and lines[-1].endswith("done")
    assert cost < 0.05


def test_step_speaks_only_when_long(level) -> None:
    """A step shorter than show_after_s prints nothing; a longer one its start and end."""
    import threading

    level(Verbosity.NORMAL)
    out = io.StringIO()
    with progress.step("quick", stream=out, show_after_s=60.0):
        pass
    assert out.getvalue() == ""
    seen = threading.Event()
    with progress.step("identifying", stream=out, show_after_s=0.01):
        seen.wait(0.01)
        while "identifying ..." not in out.getvalue():  # the timer's line, then the end
            seen.wait(0.01)
    lines = out.getvalue().splitlines()
    assert lines[0] == "identifying ..."
    assert re.fullmatch(r"identifying: done, \d+\.\d s", lines[1])
    level(Verbosity.QUIET)
    quiet = io.StringIO()
    with progress.step("silent", stream=quiet, show_after_s=0.0):
        seen.wait(0.05)
    assert quiet.getvalue() == ""
