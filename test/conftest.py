"""Shared fixtures: per-test ROS domain, ROS availability, shared data folder."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")  # 2 shared cores: BLAS threads only contend
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import pytest

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"


def _ros_available() -> bool:
    try:
        import modal_twin_msgs.msg  # noqa: F401
        import rclpy  # noqa: F401
    except ImportError:
        return False
    return True


ROS = _ros_available()


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if ROS:
        return
    skip = pytest.mark.skip(reason="rclpy / modal_twin_msgs not installed (run make setup)")
    for item in items:
        if "ros" in item.keywords:
            item.add_marker(skip)


def pytest_sessionstart(session: pytest.Session) -> None:
    """Under pytest-xdist (``make test``): compile the twin's numba kernels once, here in
    the controller, before the workers start (xdist starts them after this hook), so that
    on a fresh checkout the workers load them from numba's disk cache instead of each
    compiling the same kernels at once (~20 s of CPU each on this machine)."""
    config = session.config
    if hasattr(config, "workerinput") or not getattr(config.option, "numprocesses", None):
        return
    from modal_twin.diagnosis.fitting import warm_up_kernels
    from modal_twin.models.loading import load_model

    warm_up_kernels(load_model(ROOT / "config" / "structures" / "building.yaml").plant())


@pytest.fixture
def domain_id(monkeypatch: pytest.MonkeyPatch) -> Iterator[int]:
    """A ROS_DOMAIN_ID of this test's own (set in the environment for child processes).

    Reserved until the test ends (:func:`modal_twin.domain.reserve_domain`): no other
    process here (a parallel worker, another test run, a demo) draws it meanwhile, so two
    graphs never see each other's nodes.
    """
    from modal_twin.domain import reserve_domain

    with reserve_domain() as r:
        monkeypatch.setenv("ROS_DOMAIN_ID", str(r.domain_id))
        yield r.domain_id


@pytest.fixture
def shared_dir() -> Path:
    """../shared, or skip when it is absent."""
    if not SHARED.is_dir():
        pytest.skip("../shared is not beside the checkout")
    return SHARED


def write_frames_bag(path: Path, plant: object, *, seconds: float, scale: tuple[float, ...],
                     seed: int, block: int, noise_rms: dict[str, float] | None = None) -> None:
    """A bag of /measurement/frames: band-limited 6-DOF random table motion (RMS ``scale``
    per axis) through a truth rig of ``plant``, in blocks of ``block`` samples at 1 kHz."""
    import numpy as np

    from modal_twin.excitation import signals
    from modal_twin.io.bag import BagWriter
    from modal_twin.io.convert import block_to_rosbags
    from modal_twin.io.typestore import typestore
    from modal_twin.models.building_factory import INPUTS_6DOF
    from modal_twin.rig.truth import TruthRig
    from modal_twin.signal_block import SignalBlock

    rig = TruthRig(plant, 1e-3, noise_rms=noise_rms, seed=seed)  # type: ignore[arg-type]
    rng = np.random.default_rng(seed)
    ag = signals.band_limited_random(6, seconds, 1000.0, f_min_hz=0.2, f_max_hz=20.0,
                                     rms=1.0, rng=rng) * np.asarray(scale)[:, None]
    st = typestore()
    sb = "modal_twin_msgs/msg/SignalBlock"
    with BagWriter(path, {"/measurement/frames": sb}) as w:
        for k in range(0, ag.shape[1], block):
            raw = rig.process(SignalBlock(INPUTS_6DOF, 1000.0, k, ag[:, k:k + block],
                                          stamp_ns=10**18 + k * 10**6))
            w.write("/measurement/frames", raw.stamp_ns,
                    st.serialize_cdr(block_to_rosbags(raw, st), sb))


# headless Chromium for the rendering checks of test/viz (skipped where it is not installed)
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--enable-logging=stderr",
         "--v=0"]

_CONSOLE = re.compile(r"CONSOLE.*|Uncaught.*")


def render(page: Path, tmp: Path, *, screenshot: Path | None = None, size: str = "1200,900",
           budget_ms: int = 4000) -> tuple[str, list[str]]:
    """Load ``page``; return the DOM after scripts ran and the console messages."""
    args = [CHROMIUM, *FLAGS, f"--user-data-dir={tmp / 'chromium-profile'}",
            f"--window-size={size}", f"--virtual-time-budget={budget_ms}"]
    args += [f"--screenshot={screenshot}"] if screenshot else ["--dump-dom"]
    out = subprocess.run([*args, page.resolve().as_uri()], capture_output=True, text=True,
                         timeout=180, check=False)
    return out.stdout, _CONSOLE.findall(out.stderr)


@pytest.fixture
def chromium(tmp_path: Path):
    """``render(page, screenshot=None)`` -> (DOM, console lines); skips without chromium."""
    if CHROMIUM is None:
        pytest.skip("chromium not installed (apt-get install chromium)")

    def _render(page: Path, **kw: object) -> tuple[str, list[str]]:
        return render(page, tmp_path, **kw)  # type: ignore[arg-type]

    return _render
