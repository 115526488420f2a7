"""The main job: run the demo scenario, then read back its bag and report what happened."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from modal_twin.io.bag import bag_info, read_blocks
from modal_twin.signal_block import concatenate_blocks

__all__ = ["run_demo"]

ROOT = Path(__file__).resolve().parents[1]


def run_demo(run_dir: Path | None = None) -> int:
    """Launch ``config/scenarios/demo.yaml`` and print the recorded signals' summary."""
    from modal_twin.launch import Launcher
    from modal_twin.scenario import load_scenario

    sc = load_scenario(ROOT / "config" / "scenarios" / "demo.yaml")
    res = Launcher(sc, run_dir=run_dir).run()
    if res.exit_code != 0 or res.bag is None:
        return res.exit_code or 1
    info = bag_info(res.bag)
    print(info.format())
    blocks = read_blocks(res.bag, "/excitation/signal")
    sig = concatenate_blocks(blocks)
    print(f"\n/excitation/signal: {len(blocks)} blocks, {sig.n_samples} samples at "
          f"{sig.fs_hz:.0f} Hz, no gaps (first-sample indices contiguous)")
    print(f"{'channel':>8} {'rms':>10} {'peak':>10}")
    for name, row in zip(sig.channel_names, sig.data, strict=True):
        print(f"{name:>8} {np.sqrt(np.mean(row**2)):10.4f} {np.max(np.abs(row)):10.4f}")
    return 0
