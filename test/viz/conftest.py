"""Headless Chromium for the rendering checks (skipped where chromium is not installed)."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

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
