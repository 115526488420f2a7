"""Bags to the diagnosis's :class:`~modal_twin.diagnosis.record.Record`."""

from __future__ import annotations

from pathlib import Path

from modal_twin.diagnosis.record import Record, record_from_blocks
from modal_twin.io.bag import read_blocks
from modal_twin.io.channel_map import MAP_FILE, read_channel_map
from modal_twin.models.plant import Plant

__all__ = ["record_from_bag"]


def record_from_bag(bag: str | Path, topic: str = "/measurement/frames", *,
                    plant: Plant | None = None) -> Record:
    """Read the measurement frames of a bag as one :class:`Record`.

    A bag written by ``modal-twin import`` carries its channel map (``BAG/channel_map.json``):
    then the channels' roles say what is an input and what a response, and ``plant`` (the
    model the record is compared with) names them (:func:`record_from_blocks`). Without a
    map, the naming rule of the shipped scenarios applies (``table_*`` are the inputs).
    """
    p = Path(bag)
    channels = read_channel_map(p / MAP_FILE) if (p / MAP_FILE).is_file() else None
    return record_from_blocks(read_blocks(bag, topic), source=str(bag), channels=channels,
                              plant=plant)
