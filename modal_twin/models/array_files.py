"""Bounded readers of array files: NPZ, MATLAB ``.mat`` and numeric CSV.

A file is judged by what it unpacks to, not by its size on disk: a 1 MB compressed NPZ may
declare a 10 GB array. Every reader here reads the declared shapes first and refuses a file
whose arrays would take more than ``max_bytes``
(:data:`~modal_twin.validation.FILE_UNPACKED_MAX_BYTES` by default) before allocating any
of them:

- **NPZ**: the header of each ``.npy`` member (shape and dtype, read from the zip stream
  without unpacking the data; NumPy then allocates exactly the declared array);
- **.mat** (MATLAB 4 to 7.2): the variables' shapes and classes from
  :func:`scipy.io.whosmat`, and each compressed variable's unpacked size, counted by
  streaming it through zlib without keeping it (cells, structs and sparse matrices have no
  shape that bounds them); MATLAB 7.3 (HDF5) through h5py, by the datasets' shapes;
- **CSV**: columns counted on the header (a line longer than ``max_columns`` cells of 64
  characters is refused unread), lines counted in one pass without keeping them, rows x
  columns x 8 bytes checked against ``max_bytes`` before parsing; then read line by line
  and converted in chunks by NumPy's C reader (memory and time linear in the file).
"""

from __future__ import annotations

import csv
import os
import struct
import zipfile
import zlib
from collections.abc import Callable, Iterator
from math import prod
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.errors import ConfigError
from modal_twin.paths import check_regular
from modal_twin.validation import FILE_UNPACKED_MAX_BYTES, LIMITS

__all__ = [
    "check_text_file",
    "check_unpacked",
    "hdf5_datasets",
    "mat_arrays",
    "mat_sizes",
    "npz_arrays",
    "npz_members",
    "read_csv_numbers",
    "read_text_bounded",
    "regular_file",
    "zip_texts",
]

MAX_CHANNELS = int(LIMITS["n_channels"].hi)
CELL_CHARS = 64
"""Longest CSV cell counted in the line-length bound (a float printed with %.17g is 24)."""
TEXT_FACTOR = 4
"""A text format's numbers may take up to this many times its text once parsed (Python
lists of floats): text files are held to ``max_bytes / TEXT_FACTOR`` of text."""
_CHUNK_CELLS = 1 << 18
"""Cells converted at a time (their text stays in memory until converted)."""


def _mib(n: float) -> str:
    return f"{n / 2**20:.0f} MiB" if n >= 2**20 else f"{n:.0f} bytes"


def check_unpacked(path: str | Path, nbytes: int, max_bytes: int, what: str = "arrays"
                   ) -> None:
    """Refuse ``path`` whose ``what`` would unpack to more than ``max_bytes``.

    Raises
    ------
    ConfigError
        Naming the file, the unpacked size and the limit.
    """
    if nbytes > max_bytes:
        msg = (f"{path}: its {what} unpack to {_mib(nbytes)}, more than the "
               f"{_mib(max_bytes)} a file may unpack to (FILE_UNPACKED_MAX_BYTES)")
        raise ConfigError(msg)


def regular_file(path: str | Path) -> Path:
    """Return ``path`` if it is a regular file; refuse a FIFO, device or folder unopened.

    Opening a FIFO would block until someone writes to it
    (:func:`modal_twin.paths.check_regular`).

    Raises
    ------
    ConfigError
        Missing, or not a regular file.
    """
    return check_regular(path, "file")


# ----------------------------------------------------------------------------------- NPZ
def _npy_header(fh: Any) -> tuple[tuple[int, ...], np.dtype[Any]]:
    fmt = np.lib.format
    version = fmt.read_magic(fh)
    if version == (1, 0):
        shape, _, dtype = fmt.read_array_header_1_0(fh)
    elif version == (2, 0):
        shape, _, dtype = fmt.read_array_header_2_0(fh)
    else:  # 3.0: a UTF-8 header, no public reader
        shape, _, dtype = getattr(fmt, "_read_array_header")(fh, version)  # noqa: B009
    return tuple(int(s) for s in shape), np.dtype(dtype)


def npz_members(path: str | Path) -> dict[str, tuple[tuple[int, ...], np.dtype[Any]]]:
    """Return the declared shape and dtype of every array of an NPZ file (headers only).

    Raises
    ------
    ConfigError
        Not a zip file, a member that is not an ``.npy`` array, or an object array.
    """
    p = regular_file(path)
    out: dict[str, tuple[tuple[int, ...], np.dtype[Any]]] = {}
    try:
        with zipfile.ZipFile(p) as z:
            for info in z.infolist():
                name = info.filename.removesuffix(".npy")
                with z.open(info) as fh:
                    shape, dtype = _npy_header(fh)
                if dtype.hasobject:
                    msg = f"{p}: array {name!r} holds Python objects; expected numbers or text"
                    raise ConfigError(msg)
                out[name] = (shape, dtype)
    except (OSError, ValueError, zipfile.BadZipFile, EOFError, RuntimeError,
            NotImplementedError, zlib.error) as err:
        if isinstance(err, ConfigError):
            raise
        msg = f"{p}: not a readable NPZ file ({type(err).__name__}: {err})"
        raise ConfigError(msg) from err
    return out


def npz_arrays(path: str | Path, *, max_bytes: int = FILE_UNPACKED_MAX_BYTES,
               keys: tuple[str, ...] | None = None) -> dict[str, np.ndarray]:
    """Return the arrays of an NPZ file (only ``keys`` when given), checked before loading.

    Refused if their declared sizes add up to more than ``max_bytes`` (module docstring;
    numbers counted as float64, what the stages make of them).

    Raises
    ------
    ConfigError
        Not a readable NPZ file, or too large unpacked.
    """
    p = Path(path)
    members = npz_members(p)
    wanted = [k for k in members if keys is None or k in keys]
    total = sum(prod(members[k][0]) * max(members[k][1].itemsize, 8) for k in wanted)
    check_unpacked(p, total, max_bytes)
    try:
        with np.load(p, allow_pickle=False) as z:
            return {k: z[k] for k in wanted}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError, zlib.error) as err:
        msg = f"{p}: not a readable NPZ file ({type(err).__name__}: {err})"
        raise ConfigError(msg) from err


# ----------------------------------------------------------------------------------- MAT
_MI_MATRIX, _MI_COMPRESSED = 14, 15
_DENSE_BYTES = {"double": 8, "single": 8, "int8": 8, "uint8": 8, "int16": 8, "uint16": 8,
                "int32": 8, "uint32": 8, "int64": 8, "uint64": 8, "logical": 8, "char": 4}
"""Bytes per element a dense variable takes once read and made float (text: 4 per char)."""
_MX_CLASS = {4: "char", 5: "sparse", 6: "double", 7: "single", 8: "int8", 9: "uint8",
             10: "int16", 11: "uint16", 12: "int32", 13: "uint32", 14: "int64", 15: "uint64"}
"""MATLAB 5 array classes (mxCLASS) by code; the others are cells, structs, objects."""
_HEAD = 512


def _stream_size(fh: Any, nbytes: int, limit: int) -> tuple[int, bytes]:
    """Return the unpacked size of ``nbytes`` of zlib data and its first bytes (not more).

    Counting stops past ``limit``.
    """
    d = zlib.decompressobj()
    total, left, head = 0, nbytes, b""
    while left > 0 and total <= limit:
        buf = fh.read(min(left, 1 << 20))
        if not buf:
            break
        left -= len(buf)
        while buf and total <= limit:
            out = d.decompress(buf, 1 << 20)
            if len(head) < _HEAD:
                head += out[: _HEAD - len(head)]
            total += len(out)
            buf = d.unconsumed_tail
    return total, head


def _matrix_estimate(head: bytes, size: int, end: str) -> int:
    """Return the bytes a miMATRIX element of ``size`` unpacked bytes takes once read.

    Its header (MAT-file format: tag, array flags with the class, dimensions) gives the
    class and shape: a numeric or text array takes its shape's worth; a cell, struct,
    object or sparse array (no shape bounds it) 8 times its unpacked size.
    """
    try:
        mtype = struct.unpack_from(end + "I", head, 0)[0]
        cls = _MX_CLASS.get(struct.unpack_from(end + "I", head, 16)[0] & 0xFF, "")
        dtype, dbytes = struct.unpack_from(end + "II", head, 24)
        dims = struct.unpack_from(end + f"{dbytes // 4}i", head, 32) if dtype == 5 else ()
    except struct.error:
        return 8 * size
    if mtype != _MI_MATRIX or cls not in _DENSE_BYTES or not dims or min(dims) < 0:
        return 8 * size
    return max(size, prod(dims) * _DENSE_BYTES[cls])


def mat5_sizes(path: Path, limit: int) -> list[int]:
    """Return the bytes each top-level variable of a MATLAB 5-7.2 file takes once read.

    Compressed variables are streamed through zlib and counted, not kept
    (:func:`_matrix_estimate` of their header and unpacked size); reading stops once the
    sum passes ``limit``.
    """
    sizes: list[int] = []
    with path.open("rb") as fh:
        head = fh.read(128)
        end = "<" if head[126:128] == b"IM" else ">"
        while sum(sizes) <= limit:
            tag = fh.read(8)
            if len(tag) < 8:
                break
            mtype, nbytes = struct.unpack(end + "II", tag)
            if mtype >> 16:  # a small data element: its data is in the tag
                sizes.append(4)
                continue
            if mtype == _MI_COMPRESSED:
                size, first = _stream_size(fh, nbytes, limit)
            else:
                pos = fh.tell()
                first = tag + fh.read(min(nbytes, _HEAD - 8))
                size = nbytes
                fh.seek(pos + nbytes)
            sizes.append(_matrix_estimate(first, size, end))
    return sizes


def mat_sizes(path: str | Path, limit: int = FILE_UNPACKED_MAX_BYTES) -> int:
    """Return the bytes the variables of a ``.mat`` file take once read (upper estimate).

    MATLAB 5 to 7.2 (:func:`mat5_sizes`): numeric and text arrays by their declared shape
    times 8 bytes (4 per character), cells, structs, sparse matrices and objects 8 times
    their unpacked size in the file (MATLAB may store doubles as bytes), counted by
    streaming. MATLAB 4 (never compressed): :func:`scipy.io.whosmat` shapes.

    Raises
    ------
    ConfigError
        Not a MATLAB file scipy reads.
    """
    import scipy.io as sio
    from scipy.io.matlab import MatReadError

    p = Path(path)
    try:
        with p.open("rb") as fh:
            head = fh.read(128)
        if len(head) == 128 and head[124:126] in (b"\x00\x01", b"\x01\x00"):
            return sum(mat5_sizes(p, limit))
        info = sio.whosmat(p)
    except (OSError, ValueError, NotImplementedError, TypeError, struct.error, zlib.error,
            MatReadError) as err:
        msg = f"{p}: not a readable .mat file ({type(err).__name__}: {err})"
        raise ConfigError(msg) from err
    return sum(prod(int(s) for s in shape) * _DENSE_BYTES.get(cls, 8) for _, shape, cls in info)


def hdf5_datasets(path: str | Path, *, group: str | None = "/", needs: tuple[str, ...] = (),
                  max_bytes: int = FILE_UNPACKED_MAX_BYTES, kind: str = "HDF5 file"
                  ) -> tuple[dict[str, Any], str]:
    """Return the numeric datasets of one group of an HDF5 file, as stored, and its name.

    The group's datasets are refused before loading if they would unpack to more than
    ``max_bytes`` (:func:`check_unpacked`).

    Parameters
    ----------
    path : str or Path
    group : str, optional
        Group name (``"/"``: the root); None: the first group, by name, that holds every
        dataset of ``needs`` (the root when none does).
    needs : tuple of str
        Dataset names the chosen group must hold (with ``group=None``).
    max_bytes : int
    kind : str
        What the file is, for the messages.

    Raises
    ------
    ConfigError
        No h5py, not a readable HDF5 file, no such group, or too large unpacked.
    """
    p = Path(path)
    try:
        import h5py  # type: ignore[import-untyped]
    except ImportError as err:
        msg = f"{p}: a {kind} needs h5py (requirements/python.txt)"
        raise ConfigError(msg) from err
    try:
        with h5py.File(p, "r") as f:
            names = sorted(k for k, v in f.items() if isinstance(v, h5py.Group)
                           and all(n in v for n in needs))
            if group is None:
                group = names[0] if names else "/"
            if group not in f or not isinstance(f[group], h5py.Group):
                msg = f"{p}: no group {group!r}; groups with {list(needs)}: {names}"
                raise ConfigError(msg)
            sets = {k: v for k, v in f[group].items() if isinstance(v, h5py.Dataset)}
            total = sum(prod(v.shape) * 8 for v in sets.values())
            check_unpacked(p, total, max_bytes, "variables")
            return ({k: np.asarray(v[()]) for k, v in sets.items()
                     if v.dtype.kind in "biuf"}, group)
    except (OSError, ValueError, KeyError) as err:
        msg = f"{p}: not a readable {kind} ({type(err).__name__}: {err})"
        raise ConfigError(msg) from err


def _h5_arrays(p: Path, max_bytes: int) -> dict[str, Any]:
    sets, _ = hdf5_datasets(p, max_bytes=max_bytes, kind="MATLAB 7.3 file")
    return {k: v.T for k, v in sets.items()}  # MATLAB stores column-major: transpose back


def mat_arrays(path: str | Path, *, max_bytes: int = FILE_UNPACKED_MAX_BYTES
               ) -> dict[str, Any]:
    """Return the variables of a ``.mat`` file (MATLAB 4 to 7.3), checked before loading.

    Refused if they would take more than ``max_bytes`` (module docstring; :func:`mat_sizes`).

    Raises
    ------
    ConfigError
        Not a readable ``.mat`` file, or too large unpacked.
    """
    import scipy.io as sio
    from scipy.io.matlab import MatReadError

    p = regular_file(path)
    try:
        with p.open("rb") as fh:
            head = fh.read(128)
    except OSError as err:
        msg = f"{p}: cannot read ({err})"
        raise ConfigError(msg) from err
    if head.startswith((b"MATLAB 7.3", b"\x89HDF\r\n\x1a\n")):
        return _h5_arrays(p, max_bytes)
    check_unpacked(p, mat_sizes(p, max_bytes), max_bytes, "variables")
    try:
        return {k: v for k, v in sio.loadmat(p).items() if not k.startswith("__")}
    except (OSError, ValueError, NotImplementedError, TypeError, struct.error, zlib.error,
            MatReadError) as err:
        msg = f"{p}: not a readable .mat file ({type(err).__name__}: {err})"
        raise ConfigError(msg) from err


# ----------------------------------------------------------------------------------- CSV
def _lines(fh: Any, path: Path, max_line: int) -> Iterator[str]:
    while True:
        line = fh.readline(max_line + 1)
        if not line:
            return
        if len(line) > max_line:
            msg = (f"{path}: a line longer than {max_line} characters (more than "
                   f"{max_line // CELL_CHARS} columns); expected at most {MAX_CHANNELS} "
                   "channels")
            raise ConfigError(msg)
        yield line


def read_csv_numbers(path: str | Path, header: Callable[[list[list[str]]], int], *,
                     max_bytes: int = FILE_UNPACKED_MAX_BYTES,
                     max_columns: int = MAX_CHANNELS + 1, peek: int = 2,
                     ) -> tuple[list[list[str]], FloatArray]:
    """Header rows and the numbers of a CSV, streamed with bounds (module docstring).

    Lines starting with ``#`` and empty lines are skipped. ``header`` is given the first
    ``peek`` rows and returns how many of them are header rows; every following row must
    have as many cells as the first row, all numbers.

    Returns
    -------
    header_rows : list of list of str
    values : ndarray (n_rows, n_columns)

    Raises
    ------
    ConfigError
        Too many columns, too many values (``max_bytes`` as float64), a ragged row, a cell
        that is not a number, or text that does not decode.
    """
    p = regular_file(path)
    max_line = max_columns * CELL_CHARS
    chunks: list[FloatArray] = []
    rows_done = 0
    try:
        with p.open(newline="", encoding="utf-8") as fh:
            lines = (ln for ln in _lines(fh, p, max_line)
                     if ln.strip() and not ln.lstrip().startswith("#"))
            first_lines = [ln for _, ln in zip(range(peek), lines, strict=False)]
            first = list(csv.reader(first_lines))
            if not first:
                msg = f"{p}: empty CSV"
                raise ConfigError(msg)
            n_col = len(first[0])
            if n_col > max_columns:
                msg = (f"{p}: {n_col} columns; expected at most {max_columns} "
                       f"({MAX_CHANNELS} channels and a time column)")
                raise ConfigError(msg)
            n_head = header(first)
            # rows x columns before parsing: the lines counted in one pass, nothing kept
            check_unpacked(p, 8 * n_col * max(_count_lines(p) - n_head, 0), max_bytes,
                           "numbers")
            pending = first_lines[n_head:]
            line_no = n_head
            chunk_rows = max(1, _CHUNK_CELLS // max(n_col, 1))
            for ln in lines:
                pending.append(ln)
                if len(pending) >= chunk_rows:
                    chunks.append(_to_floats(p, pending, n_col, line_no))
                    line_no += len(pending)
                    rows_done += len(pending)
                    pending = []
                    check_unpacked(p, 8 * n_col * rows_done, max_bytes, "numbers")
            if pending:
                chunks.append(_to_floats(p, pending, n_col, line_no))
    except (UnicodeDecodeError, OSError, csv.Error) as err:
        msg = f"{p}: cannot read as CSV text ({type(err).__name__}: {err})"
        raise ConfigError(msg) from err
    values = np.concatenate(chunks, axis=0) if chunks else np.zeros((0, n_col))
    return first[:n_head], values


def _count_lines(p: Path) -> int:
    """Lines of a file (a last line without a newline counted), read in 1 MiB blocks."""
    n, last = 0, b"\n"
    with p.open("rb") as fh:
        while block := fh.read(1 << 20):
            n += block.count(b"\n")
            last = block[-1:]
    return n + (last != b"\n")


def _to_floats(p: Path, lines: list[str], n_col: int, before: int) -> FloatArray:
    """Parse data lines with NumPy's C reader; name the first bad row if they do not."""
    try:
        a = np.loadtxt(lines, delimiter=",", ndmin=2, dtype=np.float64, comments=None,
                       quotechar='"')
        if a.shape[1] == n_col:
            return a
    except ValueError as err:
        problem: Exception | None = err
    else:
        problem = None
    for k, r in enumerate(csv.reader(lines)):
        if len(r) != n_col:
            msg = (f"{p}: expected {n_col} columns on every row, row {before + k + 1} has "
                   f"{len(r)} (missing columns)")
            raise ConfigError(msg)
    msg = f"{p}: non-numeric cell in data rows {before + 1}..{before + len(lines)} ({problem})"
    raise ConfigError(msg)


# ---------------------------------------------------------------------------- text, zip
def check_text_file(path: str | Path, *, max_bytes: int = FILE_UNPACKED_MAX_BYTES) -> None:
    """Refuse a text data file (UFF, V2, SMC) larger than ``max_bytes / TEXT_FACTOR``.

    Raises
    ------
    ConfigError
        Larger, or not there.
    """
    p = regular_file(path)
    check_unpacked(p, p.stat().st_size * TEXT_FACTOR, max_bytes, "text's numbers")


def read_text_bounded(path: str | Path, *, max_bytes: int = FILE_UNPACKED_MAX_BYTES) -> bytes:
    """Bytes of a text data file (UFF, V2, SMC) of at most ``max_bytes / TEXT_FACTOR``.

    Raises
    ------
    ConfigError
        Larger, or not readable.
    """
    p = Path(path)
    check_text_file(p, max_bytes=max_bytes)
    try:
        with p.open("rb") as fh:  # its own size: no buffer of the whole limit
            return fh.read(min(os.fstat(fh.fileno()).st_size, max_bytes // TEXT_FACTOR) + 1)
    except OSError as err:
        msg = f"{p}: cannot read ({err})"
        raise ConfigError(msg) from err


def zip_texts(path: str | Path, keep: Callable[[str], bool], *,
              max_bytes: int = FILE_UNPACKED_MAX_BYTES) -> list[tuple[str, str]]:
    """Return ``(name, text)`` of the members of a zip that ``keep`` selects, by name.

    Refused before unpacking if their declared sizes exceed ``max_bytes / TEXT_FACTOR``
    (a zip member never unpacks to more than its declared size: :mod:`zipfile` stops there).

    Raises
    ------
    ConfigError
        Not a readable zip, or too large unpacked.
    """
    p = regular_file(path)
    try:
        with zipfile.ZipFile(p) as z:
            infos = sorted((i for i in z.infolist() if keep(i.filename)),
                           key=lambda i: i.filename)
            check_unpacked(p, TEXT_FACTOR * sum(i.file_size for i in infos), max_bytes,
                           "members' numbers")
            return [(i.filename, z.read(i).decode("latin-1")) for i in infos]
    except (OSError, zipfile.BadZipFile, zlib.error, EOFError, NotImplementedError,
            RuntimeError) as err:
        msg = f"{p}: not a readable zip file ({type(err).__name__}: {err})"
        raise ConfigError(msg) from err
