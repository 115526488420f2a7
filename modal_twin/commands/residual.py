"""``modal-twin residual MODEL BAG``: the twin offline on a record, its error per channel.

The model (any structure, vehicle or version file) is run on the record's measured inputs
(an imported bag's channels by their roles: any subset of the model's inputs, the others
zero) and compared with every response it has: per channel the NRMSE, RMS(measured -
model) / RMS(measured), against the noise floor estimated from the record itself, and
Eq. (8) of [004] (a difference of RMS values) beside it, labelled. ``--ride`` adds the ride
figures of every vertical acceleration channel (a vehicle's floor): the Sperling index Wz
of the record and of the model, and the floor-PSD band error
(:mod:`modal_twin.models.ride`, Sec. 5.2 of [002]).

With ``--live`` the bag is instead replayed (``replay_node``, every topic: the latched
channel map tells the twin the channels' roles) into a twin node (``twin_node``) running the
model, as it would run beside a structure in service; the run is recorded in ``--run-dir``
and the twin's last ``/twin/metrics`` (over the whole record) is printed per channel.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.channels import ChannelSpec
from modal_twin.exit_codes import ExitCode

__all__ = ["register", "ride_lines", "run"]


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``residual`` parser."""
    p = sub.add_parser("residual", help="the twin on a recorded bag: error per channel")
    p.add_argument("model", type=Path, help="structure, vehicle or model version file")
    p.add_argument("bag", type=Path, help="bag of /measurement/frames (e.g. an imported one)")
    p.add_argument("--top", type=int, default=0, help="print only the N worst channels")
    p.add_argument("--json", type=Path, default=None, help="also write the table as JSON")
    p.add_argument("--ride", action="store_true",
                   help="also the Sperling index Wz (record, model) and the floor-PSD band "
                        "error of every vertical acceleration channel")
    p.add_argument("--live", action="store_true",
                   help="replay the bag into a twin node (ROS) instead of simulating offline")
    p.add_argument("--rate", type=float, default=4.0, help="--live: replay rate (x real time)")
    p.add_argument("--run-dir", type=Path, default=None,
                   help="--live: folder of the run (default runs/<time>_twin_<bag>)")
    p.set_defaults(func=run)


def last_metrics(bag: Path) -> Any:
    """Return the last /twin/metrics message of a bag (None if there is none)."""
    from modal_twin.io.bag import read_messages

    last = None
    for _, _, msg in read_messages(bag, ["/twin/metrics"]):
        last = msg
    return last


def error_report(bag: Path, top: int = 12) -> str:
    """Worst channels of the last /twin/metrics of a bag, and the errors by place."""
    m = last_metrics(bag)
    if m is None:
        return "no /twin/metrics in the bag"
    names = list(m.channel_names)
    err, res = np.asarray(m.rms_error), np.asarray(m.residual_rms)
    lines = [f"model {m.model_version}, window {m.window_s:.0f} s, {m.samples} samples",
             f"{'channel':<12}{'RMS meas':>12}{'RMS model':>12}{'Eq.8 err %':>12}"
             f"{'resid %':>10}"]
    for i in np.argsort(-np.nan_to_num(res, nan=-1.0))[:top]:
        lines.append(f"{names[i]:<12}{m.rms_measured[i]:12.4g}{m.rms_predicted[i]:12.4g}"
                     f"{err[i]:12.2f}{res[i]:10.2f}")
    return "\n".join(lines)


def live(a: argparse.Namespace) -> int:
    """Replay the bag into a twin node running the model; print its per-channel error."""
    import sys

    from modal_twin.io.bag import bag_info, read_messages
    from modal_twin.launch import Launcher
    from modal_twin.scenario import NodeSpec, Scenario

    if not 0.05 <= a.rate <= 100.0:
        print(f"modal-twin residual: --rate {a.rate} outside [0.05, 100]", file=sys.stderr)
        return ExitCode.USAGE
    first = next((m for _, _, m in read_messages(a.bag, ["/measurement/frames"])), None)
    if first is None or not first.sample_rate_hz > 0:
        print(f"modal-twin residual: {a.bag} holds no /measurement/frames", file=sys.stderr)
        return ExitCode.USAGE
    fs = float(first.sample_rate_hz)
    seconds = bag_info(a.bag).duration_s + int(first.n_samples) / fs
    nodes = (NodeSpec("replay", "replay_node", {}, (str(a.bag), "--rate", str(a.rate)),
                      one_shot=True),
             NodeSpec("twin", "twin_node", {"model_file": str(a.model.resolve()),
                                            "fs_hz": fs,
                                            "window_s": min(86_400.0, seconds)}))
    sc = Scenario(a.bag, f"twin_{a.bag.name}", f"{a.model.name} on {a.bag}", nodes,
                  seconds / a.rate + 15.0, 60.0, ("/twin/metrics",), {}, {})
    res = Launcher(sc, run_dir=a.run_dir).run()
    if res.exit_code != 0 or res.bag is None:
        print(f"modal-twin residual: the twin run failed: {res.message} (logs in "
              f"{res.run_dir / 'logs'})", file=sys.stderr)
        return ExitCode.FAILED
    log = res.run_dir / "logs" / "twin.log"
    route = [ln.split("]: ", 1)[-1] for ln in log.read_text(errors="replace").splitlines()
             if "]: inputs " in ln] if log.is_file() else []
    print("\n".join(["twin node: " + r for r in route[:1]] + [error_report(
        res.bag, top=a.top or 10_000)]))
    return ExitCode.OK


def run(a: argparse.Namespace) -> int:
    """Run the model on the record and print its error per channel."""
    if a.live:
        return live(a)
    from modal_twin.diagnosis.fitting import simulate_record
    from modal_twin.diagnosis.judge import record_noise_floor
    from modal_twin.diagnosis.noise import error_figures
    from modal_twin.io.records import record_from_bag
    from modal_twin.models.loading import load_model

    plant = load_model(a.model).plant()
    rec = record_from_bag(a.bag, plant=plant)
    have = [c for c in rec.channel_names if c in set(plant.channel_names)]
    left = [c for c in rec.channel_names if c not in set(plant.channel_names)]
    rec = rec.with_channels(have)
    noise = record_noise_floor(plant, rec)
    pred = simulate_record(plant, rec)[:, rec.skip:]
    fig = error_figures(pred, rec.scored, rec.channel_names, noise, str(a.bag))
    order = np.argsort(-fig.nrmse)
    rows = order[: a.top] if a.top > 0 else order
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
        print("\n".join(ride_lines(plant.channels, rec.channel_names, rec.scored, pred,
                                    rec.fs_hz)))
    if a.json is not None:
        a.json.write_text(json.dumps({c: {"nrmse": float(fig.nrmse[i]),
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
