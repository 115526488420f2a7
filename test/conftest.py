"""Shared fixtures: per-test ROS domain, ROS availability, shared data folder."""

from __future__ import annotations

import itertools
import os
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")  # 2 shared cores: BLAS threads only contend
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import pytest

SHARED = Path(__file__).resolve().parents[2] / "shared"
_domains = itertools.count((os.getpid() * 7) % 60 + 20)


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


@pytest.fixture
def domain_id(monkeypatch: pytest.MonkeyPatch) -> int:
    """A ROS_DOMAIN_ID of this test's own (set in the environment for child processes)."""
    d = next(_domains) % 100 + 1
    monkeypatch.setenv("ROS_DOMAIN_ID", str(d))
    return d


@pytest.fixture
def shared_dir() -> Path:
    """../shared, or skip when it is absent."""
    if not SHARED.is_dir():
        pytest.skip("../shared is not beside the checkout")
    return SHARED
