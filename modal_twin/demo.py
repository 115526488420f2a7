"""The main job: the hidden-effect demo on the default twin (scenario S1).

1. Three runs of ``config/scenarios/s1_building_stick_slip.yaml`` (the rig's truth has
   stick-slip friction at ESB1; the twin runs the nominal linear-isolator model): low-level
   random (like Test 010 of [004]), earthquake-level random (the training record) and an
   earthquake-like record (held out).
2. Where it fails: the live twin's per-channel NRMSE (Eq. (8) of [004] beside it) at both
   levels.
3. Which effect is missing: the diagnosis of the training / held-out records.
4. Add it: the top candidate is fitted and written as model version v1 (v0 stays).
5. Watch the error fall: the held-out bag is replayed into a twin running v0, then v1
   (every block in order, scored over the whole record: single figures, the offline
   residual's to round-off); the live error table before and after, and the error-history
   plot.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin.commands.residual import error_report, last_metrics, metrics_table
from modal_twin.errors import LaunchError
from modal_twin.exit_codes import ExitCode
from modal_twin.paths import RUNS

__all__ = ["error_report", "register", "run", "run_demo"]

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "config" / "scenarios" / "s1_building_stick_slip.yaml"
BASE = [f"F0_C{i}_{d}" for i in (1, 2, 3) for d in "xy"]


def base_error(bag: Path) -> tuple[float, float]:
    """Return the median NRMSE and Eq. (8) error (percent) of the last /twin/metrics.

    Both medians are over the horizontal base-level accelerations of the bag's last
    /twin/metrics message.
    """
    return base_error_of(last_metrics(bag))


def base_error_of(m: Any) -> tuple[float, float]:
    """Median NRMSE and Eq. (8) error (percent) of a metrics message's base channels."""
    names = list(m.channel_names)
    rows = [names.index(c) for c in BASE]
    return (float(np.median(np.asarray(m.residual_rms)[rows])),
            float(np.median(np.asarray(m.rms_error)[rows])))


def base_noise(rec: Any) -> float:
    """Median noise floor (percent of RMS) of the base-level horizontal accelerations."""
    from modal_twin.diagnosis.noise import noise_floor

    keep = [c for c in BASE if c in rec.channel_names]
    return 100.0 * float(np.median(noise_floor(rec.channels(keep), rec.fs_hz)))


def _run(sc: Any, run_dir: Path, **excitation: Any) -> Path:
    from modal_twin.launch import Launcher
    from modal_twin.scenario import with_parameters

    res = Launcher(with_parameters(sc, "excitation", **excitation), run_dir=run_dir).run()
    if res.exit_code == ExitCode.INTERRUPTED:  # Ctrl-C: the command exits 130
        raise KeyboardInterrupt
    if res.exit_code != 0 or res.bag is None:
        msg = f"run {run_dir.name} failed: {res.message}"
        raise LaunchError(msg)
    return res.bag


def run_demo(run_dir: Path | None = None) -> int:
    """Run the hidden-effect demo; returns 0 when the error fell by the scenario's 3x."""
    from modal_twin.commands.residual import replay_into_twin
    from modal_twin.diagnosis.workflow import add_diagnosed, diagnose_model
    from modal_twin.io.records import record_from_bag
    from modal_twin.scenario import load_scenario
    from modal_twin.viz.error_history import plot_error_history
    from modal_twin.viz.force_state import force_state_plots

    t0 = time.monotonic()
    out = run_dir or Path.cwd() / RUNS / time.strftime("demo_%Y%m%d-%H%M%S")  # not the source
    sc = load_scenario(SCENARIO)
    model = ROOT / "config" / "structures" / "building.yaml"
    print(f"demo: {sc.description}\n(the diagnosis is not told what the rig hides)\n")
    low = _run(sc, out / "1_low_random", rms=[0.15, 0.15, 0.05, 0, 0, 0], seed=11)
    train = _run(sc, out / "2_train_random", rms=[1.0, 1.0, 0.3, 0, 0, 0], seed=12)
    test = _run(sc, out / "3_heldout_earthquake", kind="earthquake", duration_s=25.0,
                rms=[3.5, 3.0, 1.0, 0, 0, 0], seed=13)
    print("\n== 1. COMPARE / WHERE IT FAILS: live twin, nominal model")
    print("-- low-level random: base-channel NRMSE {:.2f} % (Eq. (8) of [004]: {:.2f} %)"
          .format(*base_error(low)))
    print(error_report(low, top=5))
    print("-- earthquake-like record: base-channel NRMSE {:.2f} % (Eq. (8) of [004]: {:.2f} %)"
          .format(*base_error(test)))
    print(error_report(test, top=10))
    print("\n== 2. WHICH EFFECT IS MISSING (train: earthquake-level random, judge: the "
          "earthquake-like record)")
    rec_train, rec_test = record_from_bag(train), record_from_bag(test)
    rec_low = record_from_bag(low)
    diag = diagnose_model(model, rec_train, rec_test, levels=[rec_low],
                          progress=lambda s: print(f"   {s}"))
    print(diag.format())
    for png in force_state_plots(model, diag, rec_train, out):
        print(f"   force-state map: {png}")
    best = diag.best
    versions = out / "models"
    mv = add_diagnosed(model, diag, rec_test, versions)
    if best is None or mv is None or mv.path is None:
        print("\nnothing to add")
        return 1
    print(f"\n== 3. ADD IT: {best.family} at {best.place} ({best.effect.law})")
    print(f"   wrote {mv.path} ({mv.note})")
    print("\n== 4. WATCH THE ERROR FALL: held-out bag replayed into the twin running v0, "
          f"then {mv.label} (every block in order, over the whole record)")
    replayed = {}
    for label, model_file in (("v0", model), (mv.label, mv.path)):
        try:
            run = replay_into_twin(model_file, test, rate=4.0, fs_hz=1000.0,
                                   run_dir=out / f"4_replay_{label}")
        except LaunchError as err:
            print(f"replay failed: {err}")
            return 1
        print(f"   {label}: {run.coverage()}")
        if not run.whole:
            return 1
        replayed[label] = run.metrics
    print(metrics_table(replayed[mv.label], top=10))
    (before, eq8_before), (after, eq8_after) = (base_error_of(replayed["v0"]),
                                                base_error_of(replayed[mv.label]))
    noise = base_noise(rec_test)
    print(f"\nbase-level horizontal accelerations on the held-out record, median NRMSE = "
          f"RMS(measured - model) / RMS(measured):\n   nominal (v0) {before:.2f} %  ->  with "
          f"{best.effect.law} at {best.effect.component} ({mv.label}) {after:.2f} %   "
          f"({before / max(after, 1e-12):.1f}x lower; noise floor {noise:.2f} %, after / noise "
          f"{after / max(noise, 1e-12):.2f})\n   Eq. (8) of [004] (difference of RMS values, "
          f"not a waveform error): {eq8_before:.2f} % -> {eq8_after:.2f} %")
    png = plot_error_history(versions, out / "error_history.png")
    from modal_twin.commands.report import make_report

    print(f"error history: {png}\nmodel versions: {versions}\nreport: {make_report(out)}\n"
          f"demo took {time.monotonic() - t0:.0f} s")
    return 0 if before / max(after, 1e-12) >= 3.0 else 1


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``demo`` parser (the command's module is this one: demo is above commands)."""
    de = sub.add_parser("demo", help="the main job: run the demo scenario and report")
    de.add_argument("--run-dir", type=Path, default=None)
    de.set_defaults(func=run)


def run(a: argparse.Namespace) -> int:
    """``modal-twin demo``: :func:`run_demo` into ``--run-dir``; its exit code."""
    return run_demo(run_dir=a.run_dir)
