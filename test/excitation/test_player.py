"""DrivePlayer: blocks paced against a clock, started once the readers matched."""

from __future__ import annotations

import numpy as np

from modal_twin.excitation.drive import ExcitationConfig
from modal_twin.excitation.player import WAIT_READERS_S, DrivePlayer


def _player(created_s: float = 0.0) -> DrivePlayer:
    cfg = ExcitationConfig(channels=("ax",), rms=(1.0,), fs_hz=100.0, block_size=10,
                           rate=1.0, wait_subscribers=2)
    return DrivePlayer(np.arange(95.0)[None, :], cfg, first_index=1000, created_s=created_s)


def test_waits_for_its_readers_then_paces_in_real_time() -> None:
    p = _player(created_s=10.0)
    assert p.start_when_read(11.0, 0, readers=1) is None and not p.started
    assert p.due(11.0) == []
    assert p.start_when_read(12.0, 5_000, readers=2) is None and p.started
    # 0.25 s after the start at 100 Hz: samples 0..24 are due and one block ahead (..34),
    # handed out in whole blocks of 10: 0..29
    blocks = p.due(12.25)
    assert [b.first_index for b in blocks] == [1000, 1010, 1020]
    assert blocks[1].stamp_ns == 5_000 + 100_000_000  # sample 10 at 0.1 s
    np.testing.assert_array_equal(blocks[2].data[0], np.arange(20.0, 30.0))
    rest = p.due(100.0)  # the last block is short
    assert rest[-1].data.shape[1] == 5 and p.finished


def test_starts_without_readers_after_the_wait_and_says_so() -> None:
    p = _player(created_s=0.0)
    assert p.start_when_read(WAIT_READERS_S - 0.1, 0, readers=0) is None
    msg = p.start_when_read(WAIT_READERS_S + 0.1, 0, readers=0)
    assert p.started and msg is not None and "without 2 matched readers" in msg
