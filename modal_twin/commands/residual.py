"""``modal-twin residual MODEL BAG``: the twin offline on a record, its error per channel.

The model (any structure, vehicle or version file) is run on the record's measured inputs
(an imported bag's channels by their roles: any subset of the model's inputs, the others
zero) and compared with every response it has: per channel the NRMSE, RMS(measured -
model) / RMS(measured), against the noise floor estimated from the record itself, and
Eq. (8) of [004] (a difference of RMS values) beside it, labelled. ``--ride`` adds the ride
figures of every vertical acceleration channel (a vehicle's floor): the Sperling index Wz
of the record and of the model, and the floor-PSD band error
(:mod:`modal_twin.models.ride`, Sec. 5.2 of [002]).

With ``--live`` the bag is instead replayed (``replay_node``: its frames, and the latched
channel map that tells the twin the channels' roles) into a twin node (``twin_node``)
running the model, as it would run beside a structure in service. The replay is paced by
the twin's answers, so the twin processes every block in order at any load, and its
metrics span the whole record (first to last sample index): the same figures as offline,
to round-off. The run is recorded in ``--run-dir``; a comparison that does not cover the
whole record says how much is missing and exits 1.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.channels import ChannelSpec
from modal_twin.errors import SignalError
from modal_twin.exit_codes import ExitCode
from modal_twin.paths import atomic_file, check_new

__all__ = ["STALL_S", "last_metrics", "metrics_consistent", "register", "ride_lines", "run"]

STALL_S = 30.0
"""Default ``--stall`` of ``--live``: the replay's own default (``replay_node --stall``)."""
STALL_RANGE_S = (1.0, 3600.0)
"""Allowed ``--stall`` values, s."""

log = logging.getLogger(__name__)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``residual`` parser."""
    p = sub.add_parser("residual", help="the twin on a recorded bag: error per channel")
    p.add_argument("model", type=Path, help="structure, vehicle or model version file")
    p.add_argument("bag", type=Path, help="bag of /measurement/frames (e.g. an imported one)")
    p.add_argument("--top", type=int, default=0, help="print only the N worst channels")
    p.add_argument("--json", type=Path, default=None, help="also write the table as JSON")
    p.add_argument("--force", action="store_true", help="--json: overwrite an existing file")
    p.add_argument("--ride", action="store_true",
                   help="also the Sperling index Wz (record, model) and the floor-PSD band "
                        "error of every vertical acceleration channel")
    p.add_argument("--live", action="store_true",
                   help="replay the bag into a twin node (ROS) instead of simulating offline")
    p.add_argument("--rate", type=float, default=4.0, help="--live: replay rate (x real time)")
    p.add_argument("--stall", type=float, default=STALL_S,
                   help="--live: seconds without an answer from the twin after which the "
                        "replay goes on unpaced (said, and counted)")
    p.add_argument("--run-dir", type=Path, default=None,
                   help="--live: folder of the run (default runs/<time>_twin_<bag>)")
    p.set_defaults(func=run)


def metrics_consistent(msg: Any) -> bool:
    """Whether a ComparisonMetrics message has one value per channel in every array."""
    try:
        n = len(msg.channel_names)
        return all(len(getattr(msg, f)) == n for f in (
            "rms_error", "residual_rms", "rms_measured", "rms_predicted"))
    except (AttributeError, TypeError):
        return False


def last_metrics(bag: Path) -> Any:
    """Return the last usable /twin/metrics message of a bag (None if there is none).

    Messages that do not decode or whose arrays disagree in length are skipped, and the
    count is logged.
    """
    from modal_twin.io.bag import read_messages

    last, bad = None, 0
    for _, _, msg in read_messages(bag, ["/twin/metrics"]):
        if metrics_consistent(msg):
            last = msg
        else:
            bad += 1
    if bad:
        log.warning("bag %s, /twin/metrics: skipped %d message(s) with arrays of unequal "
                    "length", bag, bad)
    return last


def metrics_table(m: Any, top: int = 12) -> str:
    """Worst channels of a ``ComparisonMetrics`` message (by NRMSE), with what it spans."""
    from modal_twin.io.convert import metrics_span

    names = list(m.channel_names)
    err, res = np.asarray(m.rms_error), np.asarray(m.residual_rms)
    span = metrics_span(m)
    where = (f"samples {span[0]}..{span[1]}" if span is not None
             else f"window {m.window_s:.0f} s")
    lines = [f"model {m.model_version}, {where}, {m.samples} samples",
             f"{'channel':<12}{'RMS meas':>12}{'RMS model':>12}{'Eq.8 err %':>12}"
             f"{'resid %':>10}"]
    for i in np.argsort(-np.nan_to_num(res, nan=-1.0))[:top]:
        lines.append(f"{names[i]:<12}{m.rms_measured[i]:12.4g}{m.rms_predicted[i]:12.4g}"
                     f"{err[i]:12.2f}{res[i]:10.2f}")
    return "\n".join(lines)


def error_report(bag: Path, top: int = 12) -> str:
    """Worst channels of the last /twin/metrics of a bag, and the errors by place."""
    m = last_metrics(bag)
    return "no /twin/metrics in the bag" if m is None else metrics_table(m, top)


@dataclass(frozen=True)
class LiveRun:
    """A record replayed into a twin node: its last metrics and what they cover."""

    metrics: Any  # ComparisonMetrics (None when the twin published none)
    record: tuple[int, int, int]  # first and last sample index of the record, samples
    run_dir: Path
    route: str
    stream: str = ""  # the twin's count of what it compared and dropped, the replay's answers

    @property
    def whole(self) -> bool:
        """True when the metrics span the record's first to last sample, every one compared."""
        from modal_twin.io.convert import metrics_span

        first, last, n = self.record
        m = self.metrics
        return m is not None and metrics_span(m) == (first, last) and int(m.samples) == n

    def coverage(self) -> str:
        """One line: the samples compared against the record's."""
        from modal_twin.io.convert import metrics_span

        first, last, n = self.record
        if self.metrics is None:
            return f"no metrics from the twin for the record's samples {first}..{last} ({n})"
        span = metrics_span(self.metrics)
        got = "an unknown span" if span is None else f"samples {span[0]}..{span[1]}"
        return (f"{got}: {int(self.metrics.samples)} of the record's {n} samples "
                f"({first}..{last}) compared" + (" -- the whole record" if self.whole
                                                  else f", {n - int(self.metrics.samples)} "
                                                       f"not compared"))

    def figures(self) -> dict[str, dict[str, float]]:
        """Per channel NRMSE and Eq. (8) of [004] as fractions (as ``residual --json``)."""
        m = self.metrics
        return {c: {"nrmse": float(r) / 100.0, "eq8": float(e) / 100.0}
                for c, r, e in zip(m.channel_names, m.residual_rms, m.rms_error, strict=True)}


def record_span(bag: Path) -> tuple[int, int, int]:
    """First and last sample index of the bag's frames and the samples a twin compares.

    The frames go through the twin's own stream monitor (repeats dropped, overlaps trimmed).
    """
    from modal_twin.acquisition.continuity import StreamMonitor
    from modal_twin.io.bag import read_blocks

    mon, first, n = StreamMonitor(), None, 0
    for blk in read_blocks(bag, "/measurement/frames"):
        v = mon.check(blk)
        if v.block is not None:
            first = v.block.first_index if first is None else first
            n += v.block.n_samples
    if first is None or mon.next_index is None:
        return 0, -1, 0
    return first, mon.next_index - 1, n


def replay_into_twin(model: Path, bag: Path, *, rate: float, run_dir: Path | None,
                     fs_hz: float, say: Any = print, stall_s: float = STALL_S) -> LiveRun:
    """Replay the frames (and channel map) of ``bag`` into a twin node running ``model``.

    The replay is paced by the twin's answers (``/twin/residual``), so every block is
    processed in order at any load (a twin silent for ``stall_s`` lets the replay go on
    unpaced, said in its log); the twin scores the whole stream (``window_s`` 0). The
    run stops once the replay has ended (every block answered) and the twin's metrics have
    spanned the record's first to last sample for one more metrics period (or, when some
    samples never arrive, two metrics periods after the replay's end).

    Raises
    ------
    LaunchError
        When the run fails (a node dies, the graph is not ready).
    KeyboardInterrupt
        When the run was stopped by Ctrl-C.
    """
    import re
    import threading
    import time

    from modal_twin.errors import LaunchError
    from modal_twin.io.convert import metrics_span
    from modal_twin.io.replay import MetricsWatch
    from modal_twin.launch import Launcher
    from modal_twin.scenario import NodeSpec, Scenario

    record = record_span(bag)
    seconds = record[2] / fs_hz
    nodes = (NodeSpec("replay", "replay_node", {},
                      (str(bag), "--rate", str(rate), "--topics", "/measurement/frames",
                       "/measurement/channels", "--paced-by", "/twin/residual",
                       "--stall", str(stall_s)),
                      one_shot=True),
             NodeSpec("twin", "twin_node", {"model_file": str(model.resolve()), "fs_hz": fs_hz,
                                            "window_s": 0.0}))
    plain = re.sub(r"[^A-Za-z0-9._-]", "_", bag.resolve().name)[:40]  # a name of the run
    # an upper bound only: the run stops when the twin has answered the whole record
    sc = Scenario(bag, f"twin_{plain}", f"{model.name} on {bag}", nodes,
                  120.0 + 10.0 * seconds / rate, 60.0, ("/twin/metrics",), {}, {})
    launcher = Launcher(sc, run_dir=run_dir, say=say)
    watch = MetricsWatch(launcher.domain_id)
    ended = threading.Event()

    def supervise() -> None:
        seen_at_exit: tuple[int, float] | None = None
        whole_at: int | None = None
        while not ended.wait(0.05):
            replay = launcher.procs.get("replay")
            if replay is None or replay.poll() is None:  # ends once every block is answered
                continue
            m, count = watch.latest()
            if whole_at is None and m is not None and metrics_span(m) == record[:2] \
                    and int(m.samples) >= record[2]:
                whole_at = count
            seen_at_exit = seen_at_exit or (count, time.monotonic())
            # one metrics period more after the whole record (so the recorder has it too),
            # or two after the replay's end when some samples never came (10 s if no metrics)
            if count >= (seen_at_exit[0] + 2 if whole_at is None else whole_at + 1) or \
                    (count == 0 and time.monotonic() - seen_at_exit[1] > 10.0):
                break
        launcher.request_stop()  # as at the end of the duration: stop the nodes cleanly

    thread = threading.Thread(target=supervise, name="residual_live", daemon=True)
    thread.start()
    try:
        res = launcher.run()
    finally:
        ended.set()
        thread.join()
        watch.close()
    if res.exit_code == ExitCode.INTERRUPTED:  # Ctrl-C: the CLI exits 130
        raise KeyboardInterrupt
    if res.exit_code != 0:
        msg = f"the twin run failed: {res.message} (logs in {res.run_dir / 'logs'})"
        raise LaunchError(msg)
    route = _log_line(res.run_dir / "logs" / "twin.log", "]: inputs ")
    counts = _log_line(res.run_dir / "logs" / "twin.log", "]: final per-channel error, ")
    answered = _log_line(res.run_dir / "logs" / "replay.log", "blocks answered on")
    parts = [counts.removeprefix("final per-channel error, ").rstrip(":")] if counts else []
    if answered:
        parts.append(f"replay: {answered.rpartition('; ')[2]}")
    stream = "; ".join(parts)
    last = watch.latest()[0]
    if last is None and res.bag is not None:
        last = last_metrics(res.bag)
    return LiveRun(last, record, res.run_dir, route, stream)


def _log_line(log: Path, marker: str) -> str:
    """Return the first line of a log holding ``marker``, without its prefix ('' if none)."""
    if not log.is_file():
        return ""
    return next((ln.split("]: ", 1)[-1] for ln in log.read_text(errors="replace").splitlines()
                 if marker in ln), "")


def live(a: argparse.Namespace) -> int:
    """Replay the bag into a twin node running the model; print its per-channel error."""
    import math
    import sys

    from modal_twin.errors import ModalTwinError
    from modal_twin.io.bag import read_messages

    if not (math.isfinite(a.rate) and 0.05 <= a.rate <= 100.0):
        print(f"modal-twin residual: --rate {a.rate} outside [0.05, 100]", file=sys.stderr)
        return ExitCode.USAGE
    lo, hi = STALL_RANGE_S
    if not (math.isfinite(a.stall) and lo <= a.stall <= hi):
        print(f"modal-twin residual: --stall {a.stall} outside [{lo:g}, {hi:g}] s",
              file=sys.stderr)
        return ExitCode.USAGE
    if a.json is not None:
        check_new(a.json, a.force)  # before the work
    first = next((m for _, _, m in read_messages(a.bag, ["/measurement/frames"])), None)
    if first is None or not first.sample_rate_hz > 0:
        print(f"modal-twin residual: {a.bag} holds no /measurement/frames", file=sys.stderr)
        return ExitCode.USAGE
    try:
        run = replay_into_twin(a.model, a.bag, rate=a.rate, run_dir=a.run_dir,
                               fs_hz=float(first.sample_rate_hz), stall_s=a.stall)
    except ModalTwinError as err:
        print(f"modal-twin residual: {err}", file=sys.stderr)
        return ExitCode.FAILED
    if run.metrics is None:
        why = _log_line(run.run_dir / "logs" / "twin.log", " refused: ")
        print(f"modal-twin residual: {run.coverage()}" + (f"; twin node: {why}" if why else "")
              + f" (logs in {run.run_dir / 'logs'})", file=sys.stderr)
        return ExitCode.FAILED
    print("\n".join(([f"twin node: {run.route}"] if run.route else [])
                    + ([f"twin node: {run.stream}"] if run.stream else [])
                    + [f"live twin over {run.coverage()}",
                       metrics_table(run.metrics, top=a.top or 10_000)]))
    if a.json is not None:
        with atomic_file(a.json, force=a.force) as tmp:
            tmp.write_text(json.dumps(run.figures(), indent=1))
        print(f"wrote {a.json}")
    if not run.whole:
        print(f"modal-twin residual: the live twin did not compare the whole record: "
              f"{run.coverage()} (logs in {run.run_dir / 'logs'})", file=sys.stderr)
        return ExitCode.FAILED
    return ExitCode.OK


def run(a: argparse.Namespace) -> int:
    """Run the model on the record and print its error per channel."""
    if a.live:
        return live(a)
    from modal_twin.diagnosis.fitting import simulate_record
    from modal_twin.diagnosis.judge import record_noise_floor
    from modal_twin.diagnosis.noise import error_figures
    from modal_twin.io.records import records_from_bag, settling_samples
    from modal_twin.models.loading import load_model

    if a.json is not None:
        check_new(a.json, a.force)  # before the work
    plant = load_model(a.model).plant()
    recs, frames = records_from_bag(a.bag, plant=plant)
    if not recs:  # a run after a gap is scored after the model's settling time
        msg = (f"{a.bag}: no run of frames long enough to score (every run after a gap "
               f"shorter than the model's settling time; {frames.note()})")
        raise SignalError(msg)
    rec = recs[0]
    have = [c for c in rec.channel_names if c in set(plant.channel_names)]
    left = [c for c in rec.channel_names if c not in set(plant.channel_names)]
    recs = [r.with_channels(have) for r in recs]
    noise = record_noise_floor(plant, max(recs, key=lambda r: r.n_samples))
    pred = np.concatenate([simulate_record(plant, r)[:, r.skip:] for r in recs], axis=1)
    meas = np.concatenate([r.scored for r in recs], axis=1)
    fig = error_figures(pred, meas, recs[0].channel_names, noise, str(a.bag))
    order = np.argsort(-fig.nrmse)
    rows = order[: a.top] if a.top > 0 else order
    note = frames.note()
    if note:
        scored = sum(r.n_samples - r.skip for r in recs)
        warm = settling_samples(plant, rec.fs_hz) / rec.fs_hz
        print(f"modal-twin residual: {a.bag}: {note}; scored {scored} samples in "
              f"{len(recs)} of {len(frames.runs)} runs (a run after a gap from the model's "
              f"settling time, {warm:.1f} s, on)", file=sys.stderr)
    print(f"{plant.name} on {a.bag}: inputs {', '.join(rec.input_names)}; "
          f"{len(have)} channels compared" + (f", {len(left)} not in the model" if left else ""))
    print(f"{'channel':<18} {'NRMSE %':>9} {'noise %':>9} {'x noise':>8} {'Eq. (8) %':>10}")
    for i in rows:
        print(f"{fig.channels[i]:<18} {100 * fig.nrmse[i]:9.2f} {100 * fig.noise[i]:9.2f} "
              f"{fig.over_noise[i]:8.2f} {100 * fig.eq8[i]:10.2f}")
    print(f"median: NRMSE {100 * fig.median_nrmse:.2f} % against a noise floor of "
          f"{100 * float(np.median(fig.noise)):.2f} % (x{fig.median_over_noise:.2f}); "
          f"Eq. (8) of [004] median {100 * float(np.median(fig.eq8)):.2f} %")
    if a.ride:
        print("\n".join(ride_lines(plant.channels, recs[0].channel_names, meas, pred,
                                    recs[0].fs_hz)))
    if a.json is not None:
        with atomic_file(a.json, force=a.force) as tmp:
            tmp.write_text(json.dumps({c: {"nrmse": float(fig.nrmse[i]),
                                           "noise": float(fig.noise[i]),
                                           "eq8": float(fig.eq8[i])}
                                       for i, c in enumerate(fig.channels)}, indent=1))
        print(f"wrote {a.json}")
    return ExitCode.OK


def ride_lines(channels: Sequence[ChannelSpec], names: Sequence[str], measured: FloatArray,
               predicted: FloatArray, fs_hz: float) -> list[str]:
    """Ride figures of every vertical acceleration channel of ``names``, as table lines.

    The Sperling index Wz of the record and of the model (5 s segments, 0.5-40 Hz) and the
    floor-PSD band error (4-15 Hz) of :mod:`modal_twin.models.ride`.
    """
    from modal_twin.models.ride import psd_band_error, sperling_index

    spec = {c.name: c for c in channels}
    rows = [i for i, n in enumerate(names) if n in spec and spec[n].direction == "z"
            and spec[n].quantity == "acceleration"]
    if not rows:
        return ["ride: no vertical acceleration channel"]
    seg = 5.0 if measured.shape[-1] >= 5.0 * fs_hz else None  # a short record: one segment
    band = psd_band_error(measured[rows], predicted[rows], fs_hz)
    out = [f"{'channel':<18} {'Wz record':>10} {'Wz model':>9} {'PSD 4-15 Hz err %':>18}"]
    for k, i in enumerate(rows):
        wm = sperling_index(measured[i], fs_hz, segment_s=seg).W
        wp = sperling_index(predicted[i], fs_hz, segment_s=seg).W
        out.append(f"{names[i]:<18} {wm:10.3f} {wp:9.3f} "
                   f"{100 * float(band.rel_power_error[k]):18.2f}")
    return out
