"""``modal-twin residual MODEL BAG``: the twin offline on a record, its error per channel.

The model (any structure, vehicle or version file) is run on the record's measured inputs
(an imported bag's channels by their roles: any subset of the model's inputs, the others
zero) and compared with every response it has: per channel the NRMSE, RMS(measured -
model) / RMS(measured), against the noise floor estimated from the record itself, and
Eq. (8) of [004] (a difference of RMS values) beside it, labelled.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from modal_twin.exit_codes import ExitCode

__all__ = ["register", "run"]


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``residual`` parser."""
    p = sub.add_parser("residual", help="the twin on a recorded bag: error per channel")
    p.add_argument("model", type=Path, help="structure, vehicle or model version file")
    p.add_argument("bag", type=Path, help="bag of /measurement/frames (e.g. an imported one)")
    p.add_argument("--top", type=int, default=0, help="print only the N worst channels")
    p.add_argument("--json", type=Path, default=None, help="also write the table as JSON")
    p.set_defaults(func=run)


def run(a: argparse.Namespace) -> int:
    """Run the model on the record and print its error per channel."""
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
    fig = error_figures(simulate_record(plant, rec)[:, rec.skip:], rec.scored, rec.channel_names,
                        noise, str(a.bag))
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
    if a.json is not None:
        a.json.write_text(json.dumps({c: {"nrmse": float(fig.nrmse[i]),
                                          "noise": float(fig.noise[i]),
                                          "eq8": float(fig.eq8[i])}
                                      for i, c in enumerate(fig.channels)}, indent=1))
        print(f"wrote {a.json}")
    return ExitCode.OK
