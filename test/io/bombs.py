"""Small files that declare, or unpack to, far more than they weigh (tests and the bench).

Each writer streams its output: making a bomb never holds what it declares.
"""

from __future__ import annotations

import struct
import zipfile
import zlib
from pathlib import Path

import numpy as np


def npz_declaring(path: Path, shape: tuple[int, ...], *, data_bytes: int = 1 << 16,
                  extra: dict[str, np.ndarray] | None = None) -> Path:
    """NPZ whose ``data`` member declares ``shape`` float64 but holds ``data_bytes`` zeros."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        with z.open("data.npy", "w", force_zip64=True) as fh:
            np.lib.format.write_array_header_1_0(
                fh, {"descr": "<f8", "fortran_order": False, "shape": shape})
            zero = bytes(1 << 20)
            left = data_bytes
            while left > 0:
                fh.write(zero[: min(left, len(zero))])
                left -= len(zero)
        for k, v in (extra or {}).items():
            with z.open(f"{k}.npy", "w") as fh:
                np.lib.format.write_array(fh, np.asarray(v))
    return path


def npz_zeros(path: Path, n_channels: int, n_samples: int, **extra: np.ndarray) -> Path:
    """NPZ record whose ``data`` really is ``(n_channels, n_samples)`` zeros, compressed."""
    return npz_declaring(path, (n_channels, n_samples), data_bytes=8 * n_channels * n_samples,
                         extra=extra)


def mat_declaring(path: Path, rows: int, cols: int, name: str = "K") -> Path:
    """MATLAB 5 file with one compressed double matrix declared ``rows x cols``, no data."""
    nm = name.encode()
    body = (struct.pack("<II", 6, 8) + struct.pack("<II", 6, 0)      # flags: double
            + struct.pack("<II", 5, 8) + struct.pack("<ii", rows, cols)  # dims
            + struct.pack("<II", 1, len(nm)) + nm + bytes(-len(nm) % 8)  # name
            + struct.pack("<II", 9, 8 * rows * cols))                    # real part tag only
    matrix = struct.pack("<II", 14, len(body)) + body
    comp = zlib.compress(matrix)
    head = b"MATLAB 5.0 MAT-file, crafted".ljust(116) + bytes(8) + struct.pack("<H", 0x0100)
    head += b"IM"
    path.write_bytes(head + struct.pack("<II", 15, len(comp)) + comp)
    return path


def mat_cell_zeros(path: Path, n_bytes: int) -> Path:
    """MATLAB 5 file: a compressed 1x1 cell holding a uint8 row of ``n_bytes`` zeros.

    A cell has no shape that bounds what it holds: only its unpacked size tells.
    """
    nm = b"c"
    inner = (struct.pack("<II", 6, 8) + struct.pack("<II", 9, 0)          # flags: uint8
             + struct.pack("<II", 5, 8) + struct.pack("<ii", 1, n_bytes)
             + struct.pack("<II", 1, 0)                                   # no name
             + struct.pack("<II", 2, n_bytes))                             # miUINT8 data
    inner_pad = (-n_bytes) % 8
    inner_len = len(inner) + n_bytes + inner_pad
    outer = (struct.pack("<II", 6, 8) + struct.pack("<II", 1, 0)          # flags: cell
             + struct.pack("<II", 5, 8) + struct.pack("<ii", 1, 1)
             + struct.pack("<II", 1, len(nm)) + nm + bytes(-len(nm) % 8))
    c = zlib.compressobj()
    chunks = [c.compress(struct.pack("<II", 14, len(outer) + 8 + inner_len) + outer
                         + struct.pack("<II", 14, inner_len) + inner)]
    zero = bytes(1 << 20)
    left = n_bytes + inner_pad
    while left > 0:
        chunks.append(c.compress(zero[: min(left, len(zero))]))
        left -= len(zero)
    chunks.append(c.flush())
    comp = b"".join(chunks)
    head = b"MATLAB 5.0 MAT-file, crafted".ljust(116) + bytes(8) + struct.pack("<H", 0x0100)
    head += b"IM"
    path.write_bytes(head + struct.pack("<II", 15, len(comp)) + comp)
    return path


def zip_of_zeros(path: Path, member: str, n_bytes: int) -> Path:
    """Zip with one deflated member of ``n_bytes`` spaces (a strong-motion file, say)."""
    with (zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z,
          z.open(member, "w", force_zip64=True) as fh):
        blank = b" " * (1 << 20)
        left = n_bytes
        while left > 0:
            fh.write(blank[: min(left, len(blank))])
            left -= len(blank)
    return path


def zip_declaring(path: Path, member: str, declared: int) -> Path:
    """Zip whose one member's central-directory entry declares ``declared`` bytes (< 4 GiB).

    Nothing that large is written: only the size field lies.
    """
    with zipfile.ZipFile(path, "w", zipfile.ZIP_STORED) as z:
        z.writestr(member, b" " * 64)
    data = bytearray(path.read_bytes())
    cd = data.rfind(b"PK\x01\x02")
    struct.pack_into("<I", data, cd + 24, declared)
    path.write_bytes(bytes(data))
    return path


def csv_of_zeros(path: Path, n_rows: int, n_cols: int) -> Path:
    """CSV with a ``name [unit]`` header and ``n_rows`` rows of ``n_cols`` zeros."""
    row = ",".join(["0"] * n_cols) + "\n"
    with path.open("w") as fh:
        fh.write(",".join(f"a{i} [g]" for i in range(n_cols)) + "\n")
        block = row * 4096
        for _ in range(n_rows // 4096):
            fh.write(block)
        fh.write(row * (n_rows % 4096))
    return path


def yaml_alias_bomb(path: Path, levels: int = 9, width: int = 9) -> Path:
    """YAML "billion laughs": ``width ** levels`` strings (10^9 at 9 x 9) in 500 bytes."""
    lines = [f"l0: &l0 [{', '.join(['lol'] * width)}]"]
    lines += [f"l{k}: &l{k} [{', '.join([f'*l{k - 1}'] * width)}]" for k in range(1, levels)]
    path.write_text("\n".join(lines) + "\n")
    return path


def sparse_file(path: Path, n_bytes: int) -> Path:
    """A file of ``n_bytes`` that takes no disk (a hole: ``truncate``)."""
    with path.open("wb") as fh:
        fh.truncate(n_bytes)
    return path
