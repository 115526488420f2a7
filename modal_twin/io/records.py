"""Bags to the diagnosis's :class:`~modal_twin.diagnosis.record.Record`.

A damaged bag gives its good part: frames that do not decode are skipped and a missing
stretch of samples splits the record into runs (:func:`~modal_twin.io.bag.read_frames`);
what was skipped and where is logged as one warning.
"""

from __future__ import annotations

import logging
from pathlib import Path

from modal_twin.diagnosis.record import Record, record_from_blocks
from modal_twin.io.bag import FrameRead, read_frames
from modal_twin.io.channel_map import MAP_FILE, read_channel_map
from modal_twin.models.plant import Plant

__all__ = ["record_from_bag", "records_from_bag"]

log = logging.getLogger(__name__)


def record_from_bag(bag: str | Path, topic: str = "/measurement/frames", *,
                    plant: Plant | None = None) -> Record:
    """Read the measurement frames of a bag as one :class:`Record`.

    A bag written by ``modal-twin import`` carries its channel map (``BAG/channel_map.json``):
    then the channels' roles say what is an input and what a response, and ``plant`` (the
    model the record is compared with) names them (:func:`record_from_blocks`). Without a
    map, the naming rule of the shipped scenarios applies (``table_*`` are the inputs). A
    damaged bag gives its longest contiguous run (the rest is logged, module docstring).
    """
    p = Path(bag)
    channels = read_channel_map(p / MAP_FILE) if (p / MAP_FILE).is_file() else None
    frames = read_frames(bag, topic)
    used = frames.longest
    if frames.skipped or frames.gaps:
        log.warning("bag %s, %s: %s", bag, topic, frames.note(used))
    return record_from_blocks([used], source=str(bag), channels=channels, plant=plant)


def records_from_bag(bag: str | Path, topic: str = "/measurement/frames", *,
                     plant: Plant | None = None, min_samples: int = 2
                     ) -> tuple[list[Record], FrameRead]:
    """Read every contiguous run of a bag's frames as a :class:`Record` (gaps stay gaps).

    Runs shorter than ``min_samples`` are left out (they count in the reading's gaps and
    runs). The channel map applies as in :func:`record_from_bag`.
    """
    p = Path(bag)
    channels = read_channel_map(p / MAP_FILE) if (p / MAP_FILE).is_file() else None
    frames = read_frames(bag, topic)
    recs = [record_from_blocks([r], source=f"{bag}[{r.first_index}:{r.next_index}]",
                               channels=channels, plant=plant)
            for r in frames.runs if r.n_samples >= max(min_samples, 2)]
    return recs, frames
