"""rosbag2 (MCAP) bags: a crash-bounded writer, reading, summary and salvage.

Bags are written with rosbags' MCAP storage. To bound what a crash (SIGKILL, power loss)
can take, the writer closes the open chunk and flushes the file every ``flush_period_s``
(0.5 s by default); a bag cut that way has no summary and no ``metadata.yaml``, and
:func:`salvage` reads its records to the break (:func:`scan_mcap`, record by record, over
a damaged chunk to the next intact one) and writes a complete, indexed bag. Long campaigns
rotate into numbered parts (``rotate_s`` / ``rotate_bytes``); every function here accepts
a bag folder or a folder of parts. :func:`read_frames` gives a topic's SignalBlocks as
contiguous runs, with what it skipped and the gaps in place.
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
    "FrameRead",
    "TopicInfo",
    "bag_info",
    "bag_parts",
    "read_blocks",
    "read_frames",
    "read_messages",
    "read_raw",
    "salvage",
    "scan_mcap",
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
    """Yield ``(topic, t_ns, message)`` decoded with the project typestore.

    A message that does not decode is skipped; the count and the first one's time and
    reason are logged (one warning per topic) once the bag is read.
    """
    store = typestore()
    skipped: dict[str, list[tuple[int, str]]] = {}
    for topic, msgtype, t_ns, raw in read_raw(path, topics):
        try:
            msg = store.deserialize_cdr(raw, msgtype)
        except Exception as err:  # one bad message must not cost the rest of the bag
            skipped.setdefault(topic, []).append((t_ns, f"{type(err).__name__}: {err}"))
            continue
        yield topic, t_ns, msg
    for topic, bad in skipped.items():
        log.warning("bag %s, %s: skipped %d message(s) that do not decode; first at t=%.3f s "
                    "(%s)", path, topic, len(bad), bad[0][0] / 1e9,
                    bad[0][1].splitlines()[0][:120])


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


@dataclass(frozen=True, slots=True)
class FrameRead:
    """The frames of one topic as contiguous runs, and what was left out and where.

    Attributes
    ----------
    runs : tuple of SignalBlock
        Contiguous parts of the record, in sample order (one when nothing is missing).
    skipped : tuple of (int, int, str)
        Messages left out: index on the topic, receive time (ns), reason.
    gaps : tuple of (int, int)
        Missing sample ranges ``[first, stop)`` between the runs (by sample index: a gap
        stays a gap, the samples after it keep their place).
    n_messages : int
        Messages on the topic.
    start_ns : int
        Receive time of the topic's first message (times in :meth:`note` count from it).
    """

    runs: tuple[SignalBlock, ...]
    skipped: tuple[tuple[int, int, str], ...]
    gaps: tuple[tuple[int, int], ...]
    n_messages: int
    start_ns: int = 0

    @property
    def longest(self) -> SignalBlock:
        """The longest run (the first of equal ones)."""
        return max(self.runs, key=lambda b: b.n_samples)

    def note(self, used: SignalBlock | None = None) -> str:
        """One line saying what was skipped and where (empty when nothing was)."""
        if not self.skipped and not self.gaps:
            return ""
        fs = self.runs[0].fs_hz
        parts = []
        if self.skipped:
            k, t_ns, why = self.skipped[0]
            parts.append(f"skipped {len(self.skipped)} of {self.n_messages} messages "
                         f"(first #{k}, {(t_ns - self.start_ns) / 1e9:.3f} s in: "
                         f"{why.splitlines()[0][:120]})")
        if self.gaps:
            lost = sum(b - a for a, b in self.gaps)
            where = ", ".join(f"{a}..{b - 1}" for a, b in self.gaps[:3])
            parts.append(f"{len(self.gaps)} gap(s) of {lost} samples ({lost / fs:.3f} s) at "
                         f"samples {where}" + (" ..." if len(self.gaps) > 3 else ""))
        if used is not None:
            total = sum(b.n_samples for b in self.runs)
            parts.append(f"using samples {used.first_index}..{used.next_index - 1} "
                         f"({used.n_samples / fs:.2f} s of {total / fs:.2f} s read)")
        return "; ".join(parts)


def _layout(b: SignalBlock) -> tuple[tuple[str, ...], float]:
    return b.channel_names, b.fs_hz


def read_frames(path: str | Path, topic: str = "/measurement/frames") -> FrameRead:
    """Read the SignalBlocks of ``topic`` as contiguous runs, skipping what cannot be used.

    A message that does not decode, that has another channel layout or sample rate than
    most of the topic, that holds NaN / Inf or that repeats samples already read is
    skipped and counted; a
    missing stretch of samples ends a run and is kept as a gap (never closed up).

    Raises
    ------
    BagError
        The bag cannot be read, ``topic`` is not of type SignalBlock, or no message on it
        is usable.
    """
    from collections import Counter

    from modal_twin.io.convert import block_from_msg

    store = typestore()
    good: list[tuple[int, int, SignalBlock]] = []
    skipped: list[tuple[int, int, str]] = []
    n, start = 0, 0
    for k, (_, msgtype, t_ns, raw) in enumerate(read_raw(path, [topic])):
        n, start = k + 1, start if k else t_ns
        if msgtype != SIGNAL_BLOCK:
            msg = f"bag {path}: topic {topic} holds {msgtype}, expected {SIGNAL_BLOCK}"
            raise BagError(msg)
        try:
            good.append((k, t_ns, block_from_msg(store.deserialize_cdr(raw, msgtype))))
        except Exception as err:  # one bad message must not cost the whole record
            skipped.append((k, t_ns, f"{type(err).__name__}: {err}"))
    if not good:
        msg = (f"bag {path}: no usable SignalBlock on {topic} ({n} messages"
               + (f", {len(skipped)} malformed" if skipped else "") + ")")
        raise BagError(msg)
    common = Counter(_layout(b) for _, _, b in good).most_common(1)[0][0]
    runs: list[list[SignalBlock]] = []
    gaps: list[tuple[int, int]] = []
    end = None
    for k, t_ns, b in sorted(good, key=lambda g: g[2].first_index):
        if _layout(b) != common:
            skipped.append((k, t_ns, f"channels or rate differ from the topic's "
                                     f"({b.n_channels} channels at {b.fs_hz:g} Hz)"))
        elif bad := b.nonfinite():
            skipped.append((k, t_ns, f"non-finite sample in {bad[0][0]} at {bad[0][1]}"))
        elif end is not None and b.first_index < end:
            skipped.append((k, t_ns, f"repeats samples {b.first_index}..{end - 1}"))
        else:
            if end is None or b.first_index > end:
                if end is not None:
                    gaps.append((end, b.first_index))
                runs.append([])
            runs[-1].append(b)
            end = b.next_index
    skipped.sort()
    from modal_twin.signal_block import concatenate_blocks

    return FrameRead(tuple(concatenate_blocks(r) for r in runs), tuple(skipped), tuple(gaps),
                     n, start)


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


MAX_RECORD_BYTES = 1 << 30
"""Longest MCAP record salvage accepts (a longer length field is damage)."""
_CHUNK_OP, _MESSAGE_INDEX_OP, _FOOTER_OP, _DATA_END_OP = 0x06, 0x07, 0x02, 0x0F
_KNOWN_OPS = frozenset(range(0x01, 0x10))
_COMPRESSIONS = (b"", b"zstd", b"lz4")


@dataclass
class McapScan:
    """What :func:`scan_mcap` read from one MCAP file, and the damage it stepped over."""

    schemas: dict[int, Any]
    channels: dict[int, Any]
    messages: list[tuple[int, int, bytes]]
    bad_chunks: int = 0
    lost_messages: int = 0
    skipped_bytes: int = 0
    lost_span_ns: tuple[int, int] | None = None
    cut: bool = False

    def note(self) -> str:
        """One line on the damage (empty when there was none)."""
        parts = []
        if self.bad_chunks:
            span = ""
            if self.lost_span_ns is not None:
                lo, hi = self.lost_span_ns
                span = f" (log time {lo / 1e9:.3f}..{hi / 1e9:.3f} s)"
            parts.append(f"{self.bad_chunks} damaged chunk(s) left out, {self.lost_messages} "
                         f"message(s) in them{span}")
        if self.skipped_bytes:
            parts.append(f"{self.skipped_bytes} unreadable bytes stepped over")
        if self.cut:
            parts.append("the file ends inside a record (cut while recording)")
        return "; ".join(parts)


def _chunk_records(body: bytes) -> tuple[Any, list[Any]]:
    """Return the chunk of a CHUNK record's body and its records (CRC verified)."""
    from io import BytesIO

    from mcap.data_stream import ReadDataStream
    from mcap.records import Chunk
    from mcap.stream_reader import breakup_chunk

    chunk = Chunk.read(ReadDataStream(BytesIO(body)))
    return chunk, breakup_chunk(chunk, validate_crc=True)


def _plausible_chunk(head: bytes, length: int) -> bool:
    """Whether the first bytes of a record body can start a chunk of ``length`` bytes."""
    if len(head) < 40:
        return False
    clen = struct.unpack_from("<I", head, 28)[0]
    if clen > 4 or head[32:32 + clen] not in _COMPRESSIONS:
        return False
    data_len = struct.unpack_from("<Q", head, 32 + clen)[0]
    return data_len == length - (40 + clen)


def _next_chunk(fh: Any, start: int, size: int) -> int | None:
    """Offset of the next intact chunk record at or after ``start`` (None if there is none).

    Every ``0x06`` byte is a candidate; its length field, its header fields and its CRC
    must all agree before it is taken.
    """
    pos = start
    while pos < size:
        fh.seek(pos)
        window = fh.read(1 << 20)
        k = window.find(bytes([_CHUNK_OP]))
        while k >= 0:
            c = pos + k
            fh.seek(c + 1)
            head = fh.read(8 + 48)
            if len(head) >= 8:
                length = struct.unpack_from("<Q", head)[0]
                if (length <= min(size - c - 9, MAX_RECORD_BYTES)
                        and _plausible_chunk(head[8:], length)):
                    fh.seek(c + 9)
                    try:
                        _chunk_records(fh.read(length))
                    except Exception:  # a false start: look on
                        pass
                    else:
                        return c
            k = window.find(bytes([_CHUNK_OP]), k + 1)
        if len(window) < (1 << 20):
            return None
        pos += len(window)
    return None


def scan_mcap(f: Path) -> McapScan:  # noqa: C901
    """Read an MCAP file record by record, stepping over damage (salvage's reader).

    Each record is ``opcode (1) + length (8) + body`` (MCAP spec). A chunk whose CRC or
    records do not check is left out whole (the message index records after it say how
    many messages it held and when) and reading goes on at the next record; a length field
    that cannot be right (past the end of the file, an unknown opcode) is damage in the
    framing itself: the bytes are searched for the next intact chunk. A file cut while
    recording ends inside its last record; a complete one has a summary after the data,
    whose schemas and channels stand in for damaged ones.
    """
    from io import BytesIO

    from mcap.data_stream import ReadDataStream
    from mcap.records import Channel, Message, MessageIndex, Schema

    scan = McapScan({}, {}, [])
    size = f.stat().st_size
    last_bad = summary = False
    with open_regular(f, "bag file") as fh:  # a FIFO is refused, never waited on
        if fh.read(8) != MCAP_MAGIC:
            msg = f"{f} is not an MCAP file (wrong magic bytes)"
            raise BagError(msg)
        pos = 8
        while pos + 9 <= size:
            fh.seek(pos)
            head = fh.read(9)
            op, length = head[0], struct.unpack_from("<Q", head, 1)[0]
            if op == _FOOTER_OP:
                break
            if op == _DATA_END_OP:  # the summary follows: its schemas and channels only
                summary = True
            if op not in _KNOWN_OPS or length > MAX_RECORD_BYTES or pos + 9 + length > size:
                nxt = _next_chunk(fh, pos + 1, size)
                if nxt is None:
                    scan.cut = op in _KNOWN_OPS and length <= MAX_RECORD_BYTES
                    if not scan.cut:
                        scan.skipped_bytes += size - pos
                    break
                scan.skipped_bytes += nxt - pos
                pos, last_bad = nxt, False
                continue
            body = fh.read(length)
            pos += 9 + length
            try:
                if op == _CHUNK_OP:
                    _, recs = _chunk_records(body)
                    last_bad = False
                elif op == _MESSAGE_INDEX_OP:
                    if last_bad:  # the index of a damaged chunk: what it held
                        idx = MessageIndex.read(ReadDataStream(BytesIO(body)))
                        scan.lost_messages += len(idx.records)
                        times = [t for t, _ in idx.records]
                        if times:
                            lo, hi = scan.lost_span_ns or (min(times), max(times))
                            scan.lost_span_ns = (min(lo, *times), max(hi, *times))
                    continue
                elif summary and op not in (0x03, 0x04):
                    continue
                elif op in (0x03, 0x04, 0x05):  # schema, channel, message outside chunks
                    st = ReadDataStream(BytesIO(body))
                    recs = [Schema.read(st) if op == 0x03 else Channel.read(st) if op == 0x04
                            else Message.read(st, length)]
                else:
                    continue
            except Exception:  # a damaged record: leave it out, read on
                scan.bad_chunks += 1
                last_bad = True
                continue
            for rec in recs:
                if isinstance(rec, Schema):
                    scan.schemas.setdefault(rec.id, rec)
                elif isinstance(rec, Channel):
                    scan.channels.setdefault(rec.id, rec)
                elif isinstance(rec, Message):
                    scan.messages.append((rec.channel_id, rec.log_time, bytes(rec.data)))
    return scan


def salvage(path: str | Path, out: str | Path | None = None) -> BagInfo:  # noqa: C901
    """Rewrite a bag cut off while recording into a complete, indexed bag.

    Reads the ``.mcap`` files record by record (:func:`scan_mcap`: a damaged chunk is
    left out and reading resumes at the next intact record, a file cut while recording
    is read to the cut) and writes every intact message to ``out`` (default
    ``<path>_salvaged``); the damage stepped over is logged as warnings. The original is
    left untouched.

    Raises
    ------
    BagError
        If ``path`` holds no ``.mcap`` file, or the file is not MCAP at all.
    """
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
    schemas: dict[int, Any] = {}
    channels: dict[int, Any] = {}
    messages: list[tuple[int, int, bytes]] = []
    notes = []
    for f in files:
        scan = scan_mcap(f)
        schemas.update(scan.schemas)
        channels.update(scan.channels)
        messages += scan.messages
        if scan.note():
            notes.append(f"{f.name}: {scan.note()}")
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
    log.info("salvage: %d messages from %s into %s", kept, src, dst)
    for n in notes:
        log.warning("salvage: %s", n)
    return bag_info(dst)
