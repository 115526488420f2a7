"""Bags to the diagnosis's :class:`~modal_twin.diagnosis.record.Record`."""

from __future__ import annotations

from pathlib import Path

from modal_twin.diagnosis.record import Record, record_from_blocks
from modal_twin.io.bag import read_blocks

__all__ = ["record_from_bag"]


def record_from_bag(bag: str | Path, topic: str = "/measurement/frames") -> Record:
    """Read the measurement frames of a bag as one :class:`Record`."""
    return record_from_blocks(read_blocks(bag, topic), source=str(bag))
