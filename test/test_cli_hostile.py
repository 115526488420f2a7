"""Every CLI command on binary, UTF-16, malformed or foreign input: one line, exit code 2."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MODEL = str(ROOT / "config" / "structures" / "building.yaml")


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
