"""Flow control of a replay by its consumer's answers (no DDS: the answers are fed in)."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from modal_twin.errors import BagError
from modal_twin.io.convert import block_to_rosbags
from modal_twin.io.replay import ConsumerPacing
from modal_twin.io.typestore import typestore
from modal_twin.signal_block import SignalBlock

MSGTYPE = "modal_twin_msgs/msg/SignalBlock"


class _Node:
    """Stands in for the replaying node: a subscription handle and a logger."""

    def __init__(self) -> None:
        self.warnings: list[str] = []

    def create_subscription(self, *args: Any) -> Any:
        return SimpleNamespace(get_publisher_count=lambda: 1)

    def get_logger(self) -> Any:
        return SimpleNamespace(warning=self.warnings.append)


def _raw(first: int, n: int = 50) -> bytes:
    store = typestore()
    blk = SignalBlock(("a",), 1000.0, first, np.zeros((1, n)))
    return bytes(store.serialize_cdr(block_to_rosbags(blk, store), MSGTYPE))


def _answer(first: int, n: int = 50) -> Any:
    return SimpleNamespace(first_sample_index=first, n_samples=n)


def test_answers_release_the_blocks_up_to_them_in_order() -> None:
    pacing = ConsumerPacing(_Node(), "/twin/residual", lead=3, stall_s=30.0)  # type: ignore[arg-type]
    for k in range(5):
        pacing.sent(_raw(50 * k), MSGTYPE)
    assert pacing.unanswered == 5
    pacing._on_answer(_answer(0))
    assert (pacing.answered, pacing.unanswered) == (1, 4)
    pacing._on_answer(_answer(999_950))  # not a block of this replay: ignored
    assert pacing.unanswered == 4
    pacing._on_answer(_answer(150))  # the consumer dropped block 1 (50..99): answered by 3's
    assert (pacing.answered, pacing.unanswered) == (4, 1)
    pacing._on_answer(_answer(200))
    assert pacing.unanswered == 0 and "5 of 5 blocks answered" in pacing.summary()
    pacing.wait(0)  # nothing awaits: returns at once
    assert not pacing.stalled


def test_a_consumer_that_never_answers_is_said_and_counted(
        monkeypatch: pytest.MonkeyPatch) -> None:
    import rclpy

    monkeypatch.setattr(rclpy, "spin_once", lambda *a, **k: None)
    node = _Node()
    pacing = ConsumerPacing(node, "/twin/residual", lead=1, stall_s=0.2)  # type: ignore[arg-type]
    pacing.sent(_raw(0), MSGTYPE)
    pacing.wait(0)
    assert pacing.stalled and pacing.unanswered == 1
    assert "no answer on /twin/residual" in node.warnings[0]
    assert "0 of 1 blocks answered on /twin/residual (the consumer stalled)" in pacing.summary()
    with pytest.raises(BagError, match="lead >= 1"):
        ConsumerPacing(node, "/twin/residual", lead=0, stall_s=1.0)  # type: ignore[arg-type]
