"""Request limits, request paths and the sliding block window: known answers."""

from __future__ import annotations

import os
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from modal_twin.block_window import BlockWindow
from modal_twin.errors import OptionError, SignalError
from modal_twin.excitation.drive import ExcitationConfig
from modal_twin.io.command_convert import config_from_command
from modal_twin.signal_block import SignalBlock
from modal_twin.validation import check_array_budget, check_field, check_request_path


@pytest.mark.parametrize("value", [4294967295, -1, 2.5, float("nan"), float("inf"), 1e308,
                                   "x", None])
def test_check_field_refuses_order_out_of_limits(value: object) -> None:
    with pytest.raises(OptionError, match=r"max_order: expected an integer in \[0, 400\]"):
        check_field(value, "max_order", "max_order")


def test_check_field_accepts_and_converts() -> None:
    assert check_field(24, "max_order", "max_order") == 24
    assert check_field(np.float64(2000.0), "fs", "sample_rate_hz") == 2000.0
    with pytest.raises(OptionError, match=r"window_s: expected a finite number .* got inf"):
        check_field(float("inf"), "window_s", "window_s")


def test_array_budget() -> None:
    check_array_budget((64, 1000), "x", budget_bytes=64 * 1000 * 8)
    with pytest.raises(OptionError, match=r"x: expected at most 1 MiB, got shape \(6, 1000000"):
        check_array_budget((6, 10**6), "x", budget_bytes=2**20)


def test_request_path_inside_roots_only(tmp_path: Path) -> None:
    root = tmp_path / "run"
    root.mkdir()
    (root / "rec.npz").write_bytes(b"0" * 10)
    (tmp_path / "outside.npz").write_bytes(b"0")
    assert check_request_path("rec.npz", "p", [root]) == (root / "rec.npz").resolve()
    with pytest.raises(OptionError, match="p: expected a file inside"):
        check_request_path("../outside.npz", "p", [root])
    with pytest.raises(OptionError, match="p: expected a file inside"):
        check_request_path(str(tmp_path / "outside.npz"), "p", [root])
    os.mkfifo(root / "fifo")
    with pytest.raises(OptionError, match="p: expected a regular file"):
        check_request_path("fifo", "p", [root])  # returns at once: a FIFO is never opened
    with pytest.raises(OptionError, match="p: expected at most 0 MiB"):
        check_request_path("rec.npz", "p", [root], max_bytes=5)
    with pytest.raises(OptionError, match="p: no such file"):
        check_request_path("missing.npz", "p", [root])


def _blk(i0: int, n: int = 10, fs: float = 100.0, names: tuple[str, ...] = ("a", "b")
         ) -> SignalBlock:
    return SignalBlock(names, fs, i0, np.full((len(names), n), float(i0)))


def test_block_window_keeps_last_seconds_and_restarts() -> None:
    w = BlockWindow(0.5, "frames")  # 50 samples at 100 Hz
    with pytest.raises(SignalError, match="no frames received yet"):
        w.joined()
    for k in range(10):
        assert w.add(_blk(10 * k))
    assert w.n_samples == 50 and w.n_received == 100
    j = w.joined()
    assert (j.first_index, j.n_samples) == (50, 50)
    tail = w.joined(0.2)
    assert (tail.first_index, tail.n_samples) == (80, 20)
    assert not w.add(_blk(500))  # a gap restarts the window
    assert w.n_samples == 10
    assert not w.add(_blk(510, names=("a",)))  # a new channel layout too
    with pytest.raises(OptionError, match="frames: window_s x sample rate x channels"):
        BlockWindow(1e6, "frames").add(_blk(0, fs=1e5))
    with pytest.raises(SignalError, match="window_s: expected a finite value > 0"):
        BlockWindow(float("inf"))


def _command(**kw: object) -> SimpleNamespace:
    fields = dict(kind="random", channels=[], duration_s=0.0, sample_rate_hz=0.0,
                  amplitude=0.0, f_min_hz=0.0, f_max_hz=0.0, record_path="", record_scale=0.0,
                  seed=0)
    fields.update(kw)
    return SimpleNamespace(**fields)


def test_command_limits_checked_before_any_drive(tmp_path: Path) -> None:
    base = ExcitationConfig()
    cfg = config_from_command(_command(duration_s=5.0, sample_rate_hz=200.0), base, [tmp_path])
    assert (cfg.duration_s, cfg.fs_hz, cfg.kind) == (5.0, 200.0, "random")
    with pytest.raises(OptionError, match=r"command.duration_s: expected a finite number"):
        config_from_command(_command(duration_s=1e308), base, [tmp_path])
    with pytest.raises(OptionError, match=r"command.sample_rate_hz"):
        config_from_command(_command(sample_rate_hz=float("nan")), base, [tmp_path])
    with pytest.raises(OptionError, match=r"duration_s x sample_rate_hz x channels: expected "
                                          r"at most 256 MiB"):
        config_from_command(_command(duration_s=86_000.0, sample_rate_hz=1e5), base, [tmp_path])
    with pytest.raises(OptionError, match=r"command.record_path: expected a file inside"):
        config_from_command(_command(kind="record", record_path="/etc/passwd"), base, [tmp_path])
    with pytest.raises(OptionError, match=r"command.seed"):
        config_from_command(_command(seed=2**40), base, [tmp_path])
