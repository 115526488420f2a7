"""The main job: run the building-twin scenario, then read its bag and report where the
nominal model fails (per-channel RMS error, Eq. (8) of [004])."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np

from modal_twin.io.bag import bag_info, read_messages

__all__ = ["error_report", "run_demo"]

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "config" / "scenarios" / "building_twin.yaml"


def error_report(bag: Path, top: int = 15) -> str:
    """Tables of the last /twin/metrics of a bag: worst channels, and errors grouped by
    location and direction (residual RMS relative to the measured RMS)."""
    last = None
    for _, _, msg in read_messages(bag, ["/twin/metrics"]):
        last = msg
    if last is None:
        return "no /twin/metrics in the bag"
    names = list(last.channel_names)
    err = np.asarray(last.rms_error)
    res = np.asarray(last.residual_rms)
    order = np.argsort(-np.nan_to_num(res, nan=-1.0))[:top]
    lines = [f"model {last.model_version}, window {last.window_s:.0f} s, {last.samples} samples",
             f"{'channel':<12}{'RMS meas':>12}{'RMS model':>12}{'Eq.8 err %':>12}"
             f"{'resid %':>10}"]
    for i in order:
        lines.append(f"{names[i]:<12}{last.rms_measured[i]:12.4g}{last.rms_predicted[i]:12.4g}"
                     f"{err[i]:12.2f}{res[i]:10.2f}")
    groups: dict[str, list[float]] = defaultdict(list)
    for n, r in zip(names, res, strict=True):
        loc, _, d = n.rpartition("_")
        level = loc.split("_")[0] if (loc[:1] in "FR" and "_C" in loc) or "_P" in loc else loc
        groups[f"{level} {d}"].append(float(r))
    lines.append("\nresidual % by place and direction (mean over channels):")
    for key in sorted(groups, key=lambda k: -np.nanmean(groups[k])):
        lines.append(f"  {key:<12}{np.nanmean(groups[key]):8.2f}")
    return "\n".join(lines)


def run_demo(run_dir: Path | None = None) -> int:
    """Launch the building-twin scenario and print the recorded error tables."""
    from modal_twin.launch import Launcher
    from modal_twin.scenario import load_scenario

    sc = load_scenario(SCENARIO)
    print(f"demo: {sc.description}")
    res = Launcher(sc, run_dir=run_dir).run()
    if res.exit_code != 0 or res.bag is None:
        return res.exit_code or 1
    print(bag_info(res.bag).format())
    print()
    print(error_report(res.bag))
    return 0
