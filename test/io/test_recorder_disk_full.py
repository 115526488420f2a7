"""A full disk ends the recorder with one line and exit code 1, the bag closed or salvageable."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.ros

HERE = Path(__file__).resolve().parent


@pytest.fixture
def tiny_disk(tmp_path: Path):  # type: ignore[no-untyped-def]
    """A 1 MB tmpfs (needs root; skipped elsewhere)."""
    d = tmp_path / "tiny"
    d.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(d)],
                       capture_output=True, check=False)
    if r.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {r.stderr.decode().strip()}")
    yield d
    subprocess.run(["umount", "-l", str(d)], check=False)


def test_disk_full_stops_recorder_cleanly(tiny_disk: Path, domain_id: int) -> None:
    from modal_twin.errors import BagError
    from modal_twin.io.bag import bag_info, read_blocks, salvage

    bag = tiny_disk / "bag"
    rec = subprocess.Popen([sys.executable, "-m", "modal_twin.cli", "record", "-o", str(bag),
                            "/rig/raw", "--flush-period", "0.05"],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    pub = subprocess.Popen([sys.executable, str(HERE / "pub_blocks.py"), "/rig/raw", "400",
                            "100", "16", "50"], stdout=subprocess.DEVNULL)
    try:
        out = rec.communicate(timeout=300)[0]
    finally:
        pub.kill()
        pub.wait()
    assert rec.returncode == 1, out
    lines = [ln for ln in out.splitlines() if "recording stopped" in ln]
    assert len(lines) == 1 and "No space left on device" in lines[0], out
    assert "Traceback" not in out
    try:
        n = bag_info(bag).message_count
    except BagError:  # no room even for the index: the salvage reads what was flushed
        n = salvage(bag, tiny_disk.parent / "salvaged").message_count
    assert n > 0
    if (bag / "metadata.yaml").is_file():
        assert len(read_blocks(bag, "/rig/raw")) == n
