"""rosbag2 (MCAP) bags: a crash-bounded writer, reading, summary and salvage.

Bags are written with rosbags' MCAP storage. To bound what a crash (SIGKILL, power loss)
can take, the writer closes the open chunk and flushes the file every ``flush_period_s``
(0.5 s by default); a bag cut that way has no summary and no ``metadata.yaml``, and
:func:`salvage` reads its records to the break with the ``mcap`` stream reader and writes
a complete, indexed bag. Long campaigns rotate into numbered parts (``rotate_s`` /
``rotate_bytes``); every function here accepts a bag folder or a folder of parts.
"""

from __future__ import annotations

import logging
import os
import struct
import time
import zlib
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from modal_twin.errors import BagError, ModalTwinError
from modal_twin.io.bag_migrate import migrator
from modal_twin.io.topics import bag_qos
from modal_twin.io.typestore import known_types, typestore
from modal_twin.paths import open_regular
from modal_twin.signal_block import SignalBlock

__all__ = [
    "BagInfo",
    "BagWriter",
    "TopicInfo",
    "bag_info",
    "bag_parts",
    "read_blocks",
    "read_messages",
    "read_raw",
    "salvage",
]

log = logging.getLogger(__name__)

MCAP_MAGIC = b"\x89MCAP0\r\n"


@dataclass(frozen=True, slots=True)
class TopicInfo:
    """One topic of a bag."""

    name: str
    msgtype: str
    count: int


@dataclass(frozen=True, slots=True)
class BagInfo:
    """Summary of a bag (all parts)."""

    path: Path
    parts: tuple[Path, ...]
    topics: tuple[TopicInfo, ...]
    start_ns: int
    end_ns: int
    size_bytes: int

    @property
    def duration_s(self) -> float:
        """Time from the first to the last message in seconds."""
        return max(0, self.end_ns - self.start_ns) / 1e9

    @property
    def message_count(self) -> int:
        """Messages over all topics."""
        return sum(t.count for t in self.topics)

    def format(self) -> str:
        """Human-readable table."""
        lines = [
            f"bag:       {self.path}",
            f"parts:     {len(self.parts)}",
            f"size:      {self.size_bytes / 1e6:.2f} MB",
            f"duration:  {self.duration_s:.3f} s",
            f"messages:  {self.message_count}",
            "topics:",
        ]
        w = max((len(t.name) for t in self.topics), default=5)
        lines += [f"  {t.name:<{w}}  {t.count:>8}  {t.msgtype}" for t in self.topics]
        return "\n".join(lines)


def _check_msgtype(msgtype: str) -> None:
    types = known_types()
    if msgtype not in types:
        msg = f"unknown message type {msgtype!r}; known types: {', '.join(types)}"
        raise BagError(msg)


def _checksum_chunks(writer: Any) -> None:
    """Make the rosbags MCAP writer store each chunk's CRC-32 (it writes 0: no check).

    The chunk record is ``opcode (1) + length (8) + start, end, uncompressed size (3 x 8)``
    then the CRC-32 of the uncompressed records (MCAP spec, Chunk record); it is filled in
    after the chunk is written, and readers (rosbags, mcap) then verify it.
    """
    storage = getattr(writer, "storage", None)
    close_chunk = getattr(storage, "close_chunk", None)
    if storage is None or close_chunk is None:
        return

    def close_with_crc() -> None:
        crc = zlib.crc32(storage.chunk.bio.getvalue())
        start = storage.bio.tell()
        close_chunk()
        end = storage.bio.tell()
        storage.bio.seek(start + 9 + 24)
        storage.bio.write(struct.pack("<I", crc))
        storage.bio.seek(end)

    storage.close_chunk = close_with_crc


class BagWriter:
    """Write serialized (CDR) messages to a rosbag2 MCAP bag with bounded crash loss.

    Parameters
    ----------
    path : path
        Bag folder to create (must not exist). With rotation it holds ``part_0000`` ...
    topics : dict
        Topic name -> message type (checked against :func:`known_types`).
    flush_period_s : float
        Longest time a written message stays only in memory.
    rotate_s, rotate_bytes : float or int, optional
        Start a new part after this long / this many bytes.
    """

    def __init__(
        self,
        path: str | Path,
        topics: dict[str, str],
        *,
        flush_period_s: float = 0.5,
        rotate_s: float | None = None,
        rotate_bytes: int | None = None,
    ) -> None:
        self.path = Path(path)
        if self.path.exists():
            msg = f"bag {self.path} exists already; choose a new path"
            raise BagError(msg)
        for t in topics.values():
            _check_msgtype(t)
        self.topics = dict(topics)
        self.flush_period_s = flush_period_s
        self.rotate_s = rotate_s
        self.rotate_bytes = rotate_bytes
        self._rotating = rotate_s is not None or rotate_bytes is not None
        self._part = -1
        self._writer: Any = None
        self._conns: dict[str, Any] = {}
        self.counts: dict[str, int] = dict.fromkeys(topics, 0)
        self._open_part()

    def _open_part(self) -> None:
        from rosbags.rosbag2 import StoragePlugin, Writer

        self._part += 1
        if self._rotating:
            self.path.mkdir(parents=True, exist_ok=True)
            part_path = self.path / f"part_{self._part:04d}"
        else:
            part_path = self.path
        store = typestore()
        self._writer = Writer(part_path, version=9, storage_plugin=StoragePlugin.MCAP)
        self._writer.open()
        _checksum_chunks(self._writer)
        self._conns = {
            topic: self._writer.add_connection(topic, mt, typestore=store,
                                               offered_qos_profiles=bag_qos(topic))
            for topic, mt in self.topics.items()
        }
        self._opened = time.monotonic()
        self._last_flush = self._opened

    def write(self, topic: str, t_ns: int, raw: bytes | memoryview) -> None:
        """Write one serialized message received at ``t_ns`` (ns since the epoch)."""
        conn = self._conns.get(topic)
        if conn is None:
            msg = f"topic {topic!r} is not recorded; recorded: {sorted(self._conns)}"
            raise BagError(msg)
        self._writer.write(conn, int(t_ns), raw)
        self.counts[topic] += 1
        now = time.monotonic()
        self.flush_if_due(now)
        if self._rotating and self._rotation_due(now):
            self._writer.close()
            self._open_part()

    def _rotation_due(self, now: float) -> bool:
        if self.rotate_s is not None and now - self._opened >= self.rotate_s:
            return True
        if self.rotate_bytes is not None:
            storage = getattr(self._writer, "storage", None)
            bio = getattr(storage, "bio", None)
            return bio is not None and bio.tell() >= self.rotate_bytes
        return False

    def flush_if_due(self, now: float | None = None) -> None:
        """Flush when ``flush_period_s`` has passed since the last flush."""
        now = time.monotonic() if now is None else now
        if now - self._last_flush >= self.flush_period_s:
            self.flush()

    def flush(self) -> None:
        """Close the pending chunk and push it to the disk (bounded loss on a crash)."""
        storage = getattr(self._writer, "storage", None)
        chunk = getattr(storage, "chunk", None)
        if storage is not None and chunk is not None and chunk.bio.tell():
            storage.close_chunk()
        bio = getattr(storage, "bio", None)
        if bio is not None:
            bio.flush()
            os.fsync(bio.fileno())
        self._last_flush = time.monotonic()

    def close(self) -> None:
        """Write the summary and ``metadata.yaml``."""
        if self._writer is not None:
            writer, self._writer = self._writer, None
            writer.close()

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def bag_parts(path: str | Path) -> list[Path]:
    """Bag folders making up ``path`` (itself, or its ``part_*`` folders in order).

    Raises
    ------
    BagError
        If the path does not exist, is not a rosbag2 bag, or was cut off while recording.
    """
    p = Path(path)
    if not p.exists():
        msg = f"no such bag: {p}"
        raise BagError(msg)
    if p.is_dir() and not list(p.glob("*.mcap")) and not list(p.glob("*.db3")):
        parts = sorted(q for q in p.glob("part_*") if q.is_dir())
        if parts:
            cut = [q.name for q in parts if not (q / "metadata.yaml").is_file()]
            if cut:
                msg = (f"bag {p}: rotated parts {cut} of {len(parts)} were cut off while "
                       f"recording; run `modal-twin bag salvage {p}` to join all parts into "
                       "one readable bag")
                raise BagError(msg)
            for q in parts:
                bag_parts(q)
            return parts
    if p.is_file():
        msg = f"{p} is a file; a rosbag2 bag is a folder holding metadata.yaml and a .mcap file"
        raise BagError(msg)
    if not (p / "metadata.yaml").is_file():
        if list(p.glob("*.mcap")):
            msg = (
                f"bag {p} has no metadata.yaml: it was cut off while recording; "
                f"run `modal-twin bag salvage {p}` to make it readable"
            )
        else:
            msg = f"{p} is not a rosbag2 bag (no metadata.yaml and no .mcap file)"
        raise BagError(msg)
    return [p]


def _check_part(part: Path) -> None:
    """Refuse a bag part whose files are not regular files inside it.

    The metadata and every file it names (``relative_file_paths``) are checked after
    symbolic links, without opening them: a FIFO would block the reader, a link or a
    ``..`` would read outside the bag.
    """
    from modal_twin.paths import check_regular
    from modal_twin.yaml_files import read_yaml

    root = part.resolve()
    try:
        doc = read_yaml(part / "metadata.yaml", "bag metadata")
        info = doc.get("rosbag2_bagfile_information") or {}
        for name in info.get("relative_file_paths") or []:
            f = check_regular(part / str(name), "bag file")
            if not f.resolve().is_relative_to(root):
                msg = f"{f}: expected a file inside the bag {part}"
                raise BagError(msg)
    except ModalTwinError as err:
        msg = f"cannot read bag {part}: {err}"
        raise BagError(msg) from err


def _open_reader(part: Path) -> Any:
    from rosbags.rosbag2 import Reader

    _check_part(part)
    reader = Reader(part)
    try:
        reader.open()
    except Exception as err:
        msg = f"cannot read bag {part}: {err}"
        raise BagError(msg) from err
    return reader


def read_raw(
    path: str | Path, topics: list[str] | None = None
) -> Iterator[tuple[str, str, int, bytes]]:
    """Yield ``(topic, msgtype, t_ns, cdr_bytes)`` in time order over all parts."""
    for part in bag_parts(path):
        reader = _open_reader(part)
        try:
            conns = [c for c in reader.connections if topics is None or c.topic in topics]
            if topics is not None:
                have = {c.topic for c in reader.connections}
                missing = [t for t in topics if t not in have]
                if missing and part == bag_parts(path)[0]:
                    log.warning("topics %s not in bag %s (it has %s)", missing, part, sorted(have))
            fix = {c.id: migrator(c.msgtype, getattr(c.msgdef, "data", ""), typestore())
                   for c in conns}
            for conn, t_ns, raw in reader.messages(connections=conns):
                f = fix[conn.id]
                yield conn.topic, conn.msgtype, int(t_ns), f(bytes(raw)) if f else bytes(raw)
        except BagError:
            raise
        except Exception as err:
            msg = f"bag {part} is damaged: {err}; try `modal-twin bag salvage`"
            raise BagError(msg) from err
        finally:
            reader.close()


def read_messages(
    path: str | Path, topics: list[str] | None = None
) -> Iterator[tuple[str, int, Any]]:
    """Yield ``(topic, t_ns, message)`` decoded with the project typestore."""
    store = typestore()
    for topic, msgtype, t_ns, raw in read_raw(path, topics):
        yield topic, t_ns, store.deserialize_cdr(raw, msgtype)


SIGNAL_BLOCK = "modal_twin_msgs/msg/SignalBlock"


def read_blocks(path: str | Path, topic: str) -> list[SignalBlock]:
    """All :class:`SignalBlock` of ``topic`` in a bag, in recorded order.

    A message that cannot be decoded or converted is skipped, counted and reported in one
    warning (its index, time and the reason); the rest is read.

    Raises
    ------
    BagError
        The bag cannot be read, or ``topic`` is not of type SignalBlock (a foreign bag).
    """
    from modal_twin.io.convert import block_from_msg

    store = typestore()
    out: list[SignalBlock] = []
    skipped: list[tuple[int, int, str]] = []
    for k, (_, msgtype, t_ns, raw) in enumerate(read_raw(path, [topic])):
        if msgtype != SIGNAL_BLOCK:
            msg = f"bag {path}: topic {topic} holds {msgtype}, expected {SIGNAL_BLOCK}"
            raise BagError(msg)
        try:
            out.append(block_from_msg(store.deserialize_cdr(raw, msgtype)))
        except Exception as err:  # one bad message must not cost the whole bag
            skipped.append((k, t_ns, f"{type(err).__name__}: {err}"))
    if skipped:
        k, t_ns, why = skipped[0]
        log.warning("bag %s, %s: skipped %d malformed message(s); first: #%d at t=%d ns (%s)",
                    path, topic, len(skipped), k, t_ns, why.splitlines()[0][:200])
    return out


def bag_info(path: str | Path) -> BagInfo:
    """Topics, types, counts, time span and size of a bag."""
    parts = bag_parts(path)
    counts: dict[tuple[str, str], int] = {}
    start, end, size = 2**63 - 1, 0, 0
    for part in parts:
        reader = _open_reader(part)
        try:
            for c in reader.connections:
                key = (c.topic, c.msgtype)
                counts[key] = counts.get(key, 0) + c.msgcount
            if reader.message_count:
                start = min(start, reader.start_time)
                end = max(end, reader.end_time)
        finally:
            reader.close()
        size += sum(f.stat().st_size for f in part.iterdir() if f.is_file())
    topics = tuple(TopicInfo(t, mt, n) for (t, mt), n in sorted(counts.items()))
    if start > end:
        start = end = 0
    return BagInfo(Path(path), tuple(parts), topics, start, end, size)


def salvage(path: str | Path, out: str | Path | None = None) -> BagInfo:  # noqa: C901
    """Rewrite a bag cut off while recording into a complete, indexed bag.

    Reads the ``.mcap`` file record by record up to the break (``mcap`` stream reader)
    and writes every complete message to ``out`` (default ``<path>_salvaged``). The
    original is left untouched.

    Raises
    ------
    BagError
        If ``path`` holds no ``.mcap`` file, or the file is not MCAP at all.
    """
    from mcap.exceptions import McapError
    from mcap.records import Channel, Message, Schema
    from mcap.stream_reader import StreamReader
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import get_types_from_msg

    src = Path(path)
    if not src.exists():
        msg = f"no such bag: {src}"
        raise BagError(msg)
    files = [src] if src.is_file() else (sorted(src.glob("*.mcap"))
                                         or sorted(src.glob("part_*/*.mcap")))
    if not files:
        msg = f"{src} holds no .mcap file to salvage"
        raise BagError(msg)
    default = src.with_name(src.name.removesuffix(".mcap") + "_salvaged")
    dst = Path(out) if out is not None else default
    if dst.exists():
        msg = f"output {dst} exists already; give another with --out"
        raise BagError(msg)
    store = typestore()
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    messages: list[tuple[int, int, bytes]] = []
    broken = ""
    for f in files:
        with open_regular(f, "bag file") as fh:  # a FIFO is refused, never waited on
            if fh.read(8) != MCAP_MAGIC:
                msg = f"{f} is not an MCAP file (wrong magic bytes)"
                raise BagError(msg)
            fh.seek(0)
            try:
                for rec in StreamReader(fh, skip_magic=False, validate_crcs=True).records:
                    if isinstance(rec, Schema):
                        schemas[rec.id] = rec
                    elif isinstance(rec, Channel):
                        channels[rec.id] = rec
                    elif isinstance(rec, Message):
                        messages.append((rec.channel_id, rec.log_time, bytes(rec.data)))
            except (McapError, ValueError, struct.error) as err:
                broken = type(err).__name__  # the break: keep what came before it
    if not messages:
        msg = f"{src} was cut before its first complete chunk: no message to recover"
        raise BagError(msg)
    writer = Writer(dst, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    conns: dict[int, Any] = {}
    for cid, ch in channels.items():
        schema = schemas.get(ch.schema_id)
        if ch.topic in {c.topic for c in conns.values()}:  # the same topic in another part
            conns[cid] = next(c for c in conns.values() if c.topic == ch.topic)
            continue
        if ch.schema_id and schema is not None and schema.name not in store.fielddefs:
            store.register(get_types_from_msg(schema.data.decode(), schema.name))
        msgtype = schema.name if schema is not None else ""
        if msgtype not in store.fielddefs:
            log.warning("salvage: skipping topic %s of unknown type %r", ch.topic, msgtype)
            continue
        conns[cid] = writer.add_connection(ch.topic, msgtype, typestore=store)
    kept = 0
    for cid, t_ns, raw in sorted(messages, key=lambda m: m[1]):
        if cid in conns:
            writer.write(conns[cid], t_ns, raw)
            kept += 1
    writer.close()
    log.info("salvage: %d messages from %s into %s (stopped at: %s)", kept, src, dst,
             broken or "end of file")
    return bag_info(dst)
