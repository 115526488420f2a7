"""Readers are bounded by what a file unpacks to, checked before anything is allocated.

Each bomb declares (or unpacks to) gigabytes while weighing kilobytes; the refusal must
come from the declared sizes, so the memory traced while refusing stays small.
"""

from __future__ import annotations

import os
import tracemalloc
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import scipy.io as sio
from bombs import (
    csv_of_zeros,
    mat_cell_zeros,
    mat_declaring,
    npz_declaring,
    zip_declaring,
    zip_of_zeros,
)

from modal_twin.errors import ConfigError
from modal_twin.excitation.signals import load_record
from modal_twin.io.strong_motion import read_record
from modal_twin.io.tabular import read_csv, read_npz
from modal_twin.io.uff import read_uff
from modal_twin.models.array_files import (
    mat_arrays,
    mat_sizes,
    npz_arrays,
    npz_members,
    read_csv_numbers,
    zip_texts,
)
from modal_twin.models.matrix_model import read_matrix_arrays
from modal_twin.validation import FILE_UNPACKED_MAX_BYTES

TEN_GB = (1250, 1 << 20)  # float64: 10,000 MiB


def _peak_mb(f: Callable[[], object]) -> float:
    """Peak traced allocation (MB) while ``f`` runs and raises ConfigError."""
    tracemalloc.start()
    try:
        with pytest.raises(ConfigError, match=r"unpack to|columns|channels"):
            f()
        return tracemalloc.get_traced_memory()[1] / 1e6
    finally:
        tracemalloc.stop()


@pytest.fixture
def npz_bomb(tmp_path: Path) -> Path:
    return npz_declaring(tmp_path / "bomb.npz", TEN_GB, extra={
        "fs_hz": np.array(100.0), "names": np.array(["a"] * 1250),
        "units": np.array(["g"] * 1250), "channels": np.array(["a"] * 1250)})


def test_npz_headers_give_the_declared_sizes(npz_bomb: Path) -> None:
    assert npz_bomb.stat().st_size < 1e6
    members = npz_members(npz_bomb)
    assert members["data"] == (TEN_GB, np.dtype("<f8"))
    assert members["names"][0] == (1250,)


@pytest.mark.parametrize("reader", [npz_arrays, read_npz, read_matrix_arrays, load_record])
def test_every_npz_reader_refuses_a_bomb_before_allocating(npz_bomb: Path,
                                                          reader: Callable) -> None:
    assert _peak_mb(lambda: reader(npz_bomb)) < 20.0


def test_npz_within_the_limit_reads_exactly(tmp_path: Path) -> None:
    p = tmp_path / "ok.npz"
    x = np.arange(12.0).reshape(3, 4)
    np.savez_compressed(p, data=x, fs_hz=50.0)
    z = npz_arrays(p)
    np.testing.assert_array_equal(z["data"], x)
    # the bound counts numbers as float64: 3 x 4 x 8 = 96 bytes
    assert npz_arrays(p, max_bytes=96 + 8, keys=("data", "fs_hz"))["fs_hz"] == 50.0
    with pytest.raises(ConfigError, match="unpack to 104 bytes, more than the 103 bytes"):
        npz_arrays(p, max_bytes=103)


def test_object_arrays_are_refused(tmp_path: Path) -> None:
    p = tmp_path / "obj.npz"
    np.savez(p, data=np.array([{"a": 1}], dtype=object))
    with pytest.raises(ConfigError, match="Python objects"):
        npz_members(p)


def test_mat_declared_shape_refused_before_loading(tmp_path: Path) -> None:
    p = mat_declaring(tmp_path / "k.mat", 20_000, 20_000)  # 3.2 GB declared, 200 bytes
    assert p.stat().st_size < 1000
    assert mat_sizes(p) == 8 * 20_000 * 20_000
    assert _peak_mb(lambda: mat_arrays(p)) < 20.0
    assert _peak_mb(lambda: read_matrix_arrays(p)) < 20.0


def test_mat_cell_counted_by_its_unpacked_stream(tmp_path: Path) -> None:
    # a cell has no shape that bounds it: 16 MiB of zeros weigh ~16 kB compressed
    p = mat_cell_zeros(tmp_path / "c.mat", 16 * 2**20)
    assert p.stat().st_size < 1e5
    est = mat_sizes(p)
    assert 8 * 16 * 2**20 <= est <= 8 * (16 * 2**20 + 200)  # 8 x the unpacked stream
    with pytest.raises(ConfigError, match="unpack to 128 MiB"):
        mat_arrays(p, max_bytes=100 * 2**20)


def test_mat_within_the_limit_reads(tmp_path: Path) -> None:
    p = tmp_path / "m.mat"
    sio.savemat(p, {"K": np.eye(3), "M": 2 * np.eye(3)}, do_compression=True)
    d = mat_arrays(p)
    np.testing.assert_array_equal(d["M"], 2 * np.eye(3))
    assert 2 * 9 * 8 <= mat_sizes(p) <= 2 * (9 * 8 + 64)  # the data and its headers


def test_mat_73_read_through_h5py(tmp_path: Path) -> None:
    h5py = pytest.importorskip("h5py")
    p = tmp_path / "v73.mat"
    with h5py.File(p, "w", userblock_size=512) as f:
        f["K"] = np.arange(6.0).reshape(3, 2)  # MATLAB writes column-major: read back .T
    with p.open("r+b") as fh:
        fh.write(b"MATLAB 7.3 MAT-file".ljust(128))
    np.testing.assert_array_equal(mat_arrays(p)["K"], np.arange(6.0).reshape(3, 2).T)
    with pytest.raises(ConfigError, match="unpack to 48 bytes"):
        mat_arrays(p, max_bytes=40)


def test_csv_rows_times_columns_bounded_before_parsing(tmp_path: Path) -> None:
    p = csv_of_zeros(tmp_path / "z.csv", 40_000, 8)  # 2.56 MB as float64
    head, v = read_csv_numbers(p, lambda rows: 1)
    assert v.shape == (40_000, 8) and head[0][0] == "a0 [g]"
    tracemalloc.start()
    try:
        with pytest.raises(ConfigError, match="numbers unpack to"):
            read_csv_numbers(p, lambda rows: 1, max_bytes=1 << 20)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 3e6  # lines counted in 1 MiB blocks, no row parsed


def test_csv_columns_bounded_on_the_header(tmp_path: Path) -> None:
    ok = csv_of_zeros(tmp_path / "ok.csv", 3, 4097)  # time + 4096 channels
    assert read_csv_numbers(ok, lambda rows: 1)[1].shape == (3, 4097)
    wide = csv_of_zeros(tmp_path / "wide.csv", 3, 4098)
    with pytest.raises(ConfigError, match="4098 columns; expected at most 4097"):
        read_csv(wide, fs_hz=10.0)
    # a single line of a million cells is refused at the line bound, not parsed
    line = tmp_path / "line.csv"
    line.write_text(",".join(["0"] * 1_000_000) + "\n")
    assert _peak_mb(lambda: read_csv(line, fs_hz=10.0)) < 5.0


def test_text_and_zip_bounded_by_what_they_unpack_to(tmp_path: Path) -> None:
    z = zip_declaring(tmp_path / "rec.zip", "CHAN001.V2", 200 * 2**20)
    assert z.stat().st_size < 1000
    assert _peak_mb(lambda: read_record(z)) < 5.0  # 4 x 200 MiB of text > 512 MiB
    real = zip_of_zeros(tmp_path / "real.zip", "CHAN001.V2", 2**20)
    assert zip_texts(real, lambda n: n.endswith(".V2"))[0][1] == " " * 2**20
    with pytest.raises(ConfigError, match="unpack to 4 MiB"):
        zip_texts(real, lambda n: n.endswith(".V2"), max_bytes=2**20)
    big = tmp_path / "big.uff"
    with big.open("wb") as fh:
        fh.truncate(FILE_UNPACKED_MAX_BYTES // 4 + 1)  # sparse: no disk used
    assert _peak_mb(lambda: read_uff(big)) < 5.0


@pytest.mark.parametrize("reader", [npz_arrays, mat_arrays, read_csv, read_uff, read_record,
                                    load_record])
def test_a_fifo_is_refused_unopened(tmp_path: Path, reader: Callable) -> None:
    """Opening a FIFO for reading blocks until a writer comes: no reader may open one."""
    fifo = tmp_path / "x.npz"
    if reader in (read_csv, load_record):
        fifo = fifo.with_suffix(".csv")
    os.mkfifo(fifo)
    with pytest.raises(ConfigError, match=r"regular file|no such file"):
        reader(fifo)
