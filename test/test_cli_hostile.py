"""Every CLI command on binary, UTF-16, malformed or foreign input: one line, exit code 2."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
MODEL = str(ROOT / "config" / "structures" / "building.yaml")
sys.path.insert(0, str(ROOT / "test" / "io"))


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from modal_twin.io.bag import BagWriter
    from modal_twin.io.typestore import typestore

    d = tmp_path_factory.mktemp("hostile")
    (d / "bin.yaml").write_bytes(bytes(range(256)) * 8)
    (d / "u16.yaml").write_bytes("launch:\n  nodes: []\n".encode("utf-16"))
    (d / "bad.yaml").write_text("a: [1, 2\n")
    st = typestore()
    s = st.types["std_msgs/msg/String"]
    with BagWriter(d / "strbag", {"/measurement/frames": "std_msgs/msg/String"}) as w:
        w.write("/measurement/frames", 1, st.serialize_cdr(s(data="x"), "std_msgs/msg/String"))
    return d


@pytest.mark.parametrize("args", [
    "launch bin.yaml", "launch u16.yaml", "launch bad.yaml", "model info bin.yaml",
    "model info u16.yaml", "bag info bin.yaml", "replay bin.yaml",
    f"diagnose {MODEL} --train strbag --test strbag",
    f"effects add {MODEL} --train strbag --test strbag --out out --auto",
])
def test_hostile_input_is_one_line_and_exit_2(inputs: Path, args: str) -> None:
    r = subprocess.run([sys.executable, "-m", "modal_twin.cli", *args.split()], cwd=inputs,
                       capture_output=True, text=True, check=False)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2, r.stderr
    assert len(lines) == 1 and lines[0].startswith("modal-twin"), r.stderr
    assert "Traceback" not in r.stderr


def _record(path: Path, data: np.ndarray, fs: float) -> None:
    n = data.shape[0]
    np.savez(path, data=data, fs_hz=fs, names=np.array([f"a{i}" for i in range(n)]),
             units=np.array(["g"] * n))


@pytest.fixture(scope="module")
def unusable(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Records nothing downstream can use, and bombs that declare gigabytes."""
    from bombs import (
        csv_of_zeros,
        mat_declaring,
        npz_declaring,
        sparse_file,
        yaml_alias_bomb,
        zip_declaring,
    )

    d = tmp_path_factory.mktemp("unusable")
    x = np.random.default_rng(0).normal(size=(2, 100))
    _record(d / "rate.npz", x, 1e308)
    _record(d / "nan_rate.npz", x, float("nan"))
    _record(d / "empty.npz", np.zeros((2, 0)), 100.0)
    _record(d / "complex.npz", x * (1 + 1j), 100.0)
    csv_of_zeros(d / "wide.csv", 4, 4098)  # 4097 channels and time
    (d / "one.csv").write_text("t [s],a [g]\n0,1\n")
    npz_declaring(d / "bomb.npz", (1250, 1 << 20), extra={  # 10 GB declared in ~70 kB
        "fs_hz": np.array(100.0), "names": np.array(["a"] * 1250),
        "units": np.array(["g"] * 1250)})
    mat_declaring(d / "bomb.mat", 20_000, 20_000)  # 3.2 GB declared in 200 bytes
    zip_declaring(d / "bomb.zip", "CHAN001.V2", 3 << 30)
    (d / "four.csv").write_text("t [s],a [g]\n0,1\n0.1,2\n0.2,3\n0.3,1\n")
    yaml_alias_bomb(d / "lol.yaml")  # 10^9 nodes expanded in 500 bytes
    (d / "loop.yaml").write_text("channels: &a [*a]\n")
    sparse_file(d / "big.yaml", 65 << 20)  # 65 MiB that take no disk
    sparse_file(d / "big.json", 65 << 20)
    return d


@pytest.mark.parametrize(("args", "says"), [
    ("import rate.npz --out o", "sample rate: expected a finite number in [0.001, 1e+06] Hz"),
    ("import nan_rate.npz --out o", "sample rate: expected a finite number"),
    ("import empty.npz --out o", "an empty record (2 channels x 0 samples)"),
    ("import complex.npz --out o", "complex samples"),
    ("import wide.csv --out o --fs 10", "4098 columns; expected at most 4097"),
    ("import one.csv --out o", "expected at least 2 samples"),
    ("import bomb.npz --out o", "unpack to 10000 MiB, more than the 512 MiB"),
    ("import bomb.zip --out o", "unpack to 12288 MiB, more than the 512 MiB"),
    ("model info bomb.npz", "unpack to 10000 MiB"),
    ("model info bomb.mat", "unpack to 3052 MiB"),
    ("model info lol.yaml", "aliases that expand it to more than 500000 nodes"),
    ("launch lol.yaml", "aliases that expand it to more than 500000 nodes"),
    ("import four.csv --map lol.yaml --out o", "aliases that expand it to more than 500000"),
    ("import four.csv --map loop.yaml --out o", "an alias inside the node it names (a loop)"),
    ("import four.csv --map big.yaml --out o", "a channel map of 65 MiB; expected at most 64"),
    ("import four.csv --map big.json --out o", "a channel map of 65 MiB; expected at most 64"),
    (f"update {MODEL} --modes big.json --out o", "a modes file of 65 MiB; expected at most 64"),
    ("model info big.yaml", "of 65 MiB; expected at most 64 MiB (TEXT_FILE_MAX_BYTES)"),
])
def test_unusable_records_and_bombs_are_refused_in_one_line(unusable: Path, args: str,
                                                            says: str) -> None:
    """Exit 2, one line naming the limit, nothing written, and the child's peak memory
    (its own ``ru_maxrss``, measured by a wrapper process) far below what was declared."""
    probe = ("import resource, subprocess, sys; r = subprocess.run(sys.argv[1:], "
             "capture_output=True, text=True); sys.stderr.write(r.stderr); "
             "print(r.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)")
    r = subprocess.run([sys.executable, "-c", probe, sys.executable, "-m", "modal_twin.cli",
                        *args.split()], cwd=unusable, capture_output=True, text=True,
                       check=False)
    code, peak_kb = (int(v) for v in r.stdout.split())
    lines = r.stderr.strip().splitlines()
    assert code == 2, r.stderr
    assert len(lines) == 1 and lines[0].startswith("modal-twin") and says in lines[0], lines
    assert not (unusable / "o").exists()
    assert peak_kb < 400_000  # 400 MB: the interpreter and numpy, not the declared GBs
