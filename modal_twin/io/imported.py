"""Write an imported record as a bag the pipeline replays, with its channel map.

The bag holds the samples on ``/measurement/frames`` (SignalBlock, blocks of about one
second) and the channel map on the latched ``/measurement/channels`` (ChannelMap, with each
channel's role and node, so a replayed bag tells the twin node what is an input), and the
same map with the record's metadata as ``channel_map.json`` inside the bag folder.
Everything is written to a temporary folder beside the target and renamed at the end: an
interrupted or failed import leaves nothing half-written.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin.channels import ChannelSpec
from modal_twin.errors import BagError
from modal_twin.io.bag import BagWriter
from modal_twin.io.channel_map import MAP_FILE, write_channel_map
from modal_twin.io.convert import block_to_rosbags
from modal_twin.io.typestore import typestore
from modal_twin.paths import atomic_dir, atomic_file
from modal_twin.signal_block import SignalBlock

__all__ = [
    "atomic_dir",
    "atomic_file",
    "bag_channel_map",
    "read_imported",
    "write_imported",
    "write_side_files",
]

log = logging.getLogger(__name__)

FRAMES = "/measurement/frames"
CHANNELS = "/measurement/channels"


def _map_msg(channels: list[ChannelSpec], source: str, store: Any) -> Any:
    T = store.types
    infos = [T["modal_twin_msgs/msg/ChannelInfo"](
        name=c.name, quantity=c.quantity, unit=c.unit, location=c.location,
        direction=c.direction, sensitivity=float(c.sensitivity),
        position_m=np.asarray(c.position_m, dtype=np.float64), role=c.role, node=c.node)
        for c in channels]
    header = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=0, nanosec=0),
                                      frame_id=source)
    return T["modal_twin_msgs/msg/ChannelMap"](header=header, source=source, channels=infos)


def write_imported(out: str | Path, block: SignalBlock, channels: list[ChannelSpec], *,
                   extra_files: dict[str, Any] | None = None, record_meta: dict[str, Any]
                   | None = None, block_s: float = 1.0,
                   progress: Callable[[float], None] | None = None) -> Path:
    """Write ``block`` and its channel map as a bag folder ``out`` (module docstring).

    Parameters
    ----------
    extra_files : dict, optional
        File name -> JSON-ready object (geometry, FRFs ...) written into the folder.
    record_meta : dict, optional
        Record-level metadata stored in the channel map file.
    progress : callable, optional
        Called with the fraction written.
    """
    if [c.name for c in channels] != list(block.channel_names):
        msg = "write_imported: channel map and block list different channels"
        raise BagError(msg)
    store = typestore()
    with atomic_dir(out) as work:
        topics = {FRAMES: "modal_twin_msgs/msg/SignalBlock",
                  CHANNELS: "modal_twin_msgs/msg/ChannelMap"}
        n_blk = max(1, round(block_s * block.fs_hz))
        with BagWriter(work, topics, flush_period_s=1e9) as w:
            t0 = block.stamp_ns
            w.write(CHANNELS, t0, store.serialize_cdr(_map_msg(channels, block.source, store),
                                                       topics[CHANNELS]))
            for k in range(0, block.n_samples, n_blk):
                sub = SignalBlock(block.channel_names, block.fs_hz, block.first_index + k,
                                  block.data[:, k: k + n_blk],
                                  t0 + round(k / block.fs_hz * 1e9), block.source)
                w.write(FRAMES, sub.stamp_ns, store.serialize_cdr(
                    block_to_rosbags(sub, store), topics[FRAMES]))
                if progress is not None and (k // n_blk) % 50 == 0:
                    progress(k / block.n_samples)
        write_channel_map(work / MAP_FILE, channels, fs_hz=block.fs_hz,
                          n_samples=block.n_samples, source=block.source,
                          **(record_meta or {}))
        _extras(work, extra_files)
    return Path(out)


def _extras(folder: Path, extra_files: dict[str, Any] | None) -> None:
    """Write JSON objects (``*.json``) and dicts of arrays (``*.npz``) into ``folder``."""
    for name, obj in (extra_files or {}).items():
        if name.endswith(".npz"):
            np.savez(folder / name, **obj)
        else:
            (folder / name).write_text(json.dumps(obj, default=str, indent=1))


def write_side_files(out: str | Path, extra_files: dict[str, Any]) -> Path:
    """Write only side files (geometry, spectra) into a new folder ``out`` (no bag)."""
    with atomic_dir(out) as work:
        work.mkdir()
        _extras(work, extra_files)
    return Path(out)


def read_imported(bag: str | Path) -> tuple[SignalBlock, list[ChannelSpec]]:
    """Return the record of a bag as one block and its channel map.

    The map comes from ``channel_map.json`` when the bag has one, else from the bag's
    last ``/measurement/channels`` message (a run's bag: the acquisition's map, with
    quantities, nodes and directions), else from the channel names
    (:func:`modal_twin.channels.default_role`). A damaged bag gives its
    longest contiguous run; what was skipped and where is logged as one warning
    (:func:`~modal_twin.io.bag.read_frames`).

    """
    from modal_twin.io.bag import read_frames

    frames = read_frames(bag, FRAMES)
    block = frames.longest
    if frames.skipped or frames.gaps:
        log.warning("bag %s, %s: %s", bag, FRAMES, frames.note(block))
    chans = {c.name: c for c in bag_channel_map(bag)}
    channels = [chans.get(n, ChannelSpec(n, "acceleration")) for n in block.channel_names]
    return block, channels


def bag_channel_map(bag: str | Path) -> list[ChannelSpec]:
    """Return a bag's channel map: ``channel_map.json``, else the recorded one, else none.

    The map :func:`read_imported` gives the record, without reading the samples (an
    empty list where the bag has neither: the roles then come from the channel names).
    """
    from modal_twin.io.channel_map import read_channel_map

    p = Path(bag) / MAP_FILE
    return read_channel_map(p) if p.is_file() else _recorded_map(bag)


def _recorded_map(bag: str | Path) -> list[ChannelSpec]:
    """Return the last channel map recorded on ``/measurement/channels`` (or none)."""
    from modal_twin.errors import ModalTwinError
    from modal_twin.io.bag import bag_info, read_messages
    from modal_twin.io.convert import channel_map_from_msg

    if CHANNELS not in {t.name for t in bag_info(bag).topics}:
        return []
    out: list[ChannelSpec] = []
    for _, _, msg in read_messages(bag, [CHANNELS]):
        try:
            out = channel_map_from_msg(msg)
        except (ModalTwinError, ValueError, TypeError, AttributeError) as err:
            log.warning("bag %s, %s: a channel map that does not convert skipped (%s)",
                        bag, CHANNELS, err)
    return out
