"""``modal-twin diagnose MODEL --train BAG --test BAG``: which effect the model misses.

``--json FILE`` also writes the decision, the effects found (family, the law fitted and
what it does) and every round's ranked candidates with their decision and reason.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from modal_twin.exit_codes import ExitCode

__all__ = ["register", "run"]


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``diagnose`` parser."""
    dg = sub.add_parser("diagnose", help="where the model fails and which effect is missing")
    dg.add_argument("model", type=Path, help="structure or model version file")
    dg.add_argument("--train", type=Path, required=True, help="bag to fit candidates on")
    dg.add_argument("--test", type=Path, required=True, help="bag held out for ranking")
    dg.add_argument("--level", type=Path, action="append",
                    help="another record (e.g. low level) no effect may make worse; repeatable")
    dg.add_argument("--n-fit", type=int, default=3, help="candidates fitted by simulation")
    dg.add_argument("--jobs", default=None,
                    help="fits in parallel: N processes, 1 = serial, dask://HOST:PORT for a "
                    "cluster (default: the free cores)")
    dg.add_argument("--plots", type=Path, default=None, help="folder for force-state maps")
    dg.add_argument("--json", type=Path, default=None,
                    help="also write the decision, the effects found and every round's "
                    "ranked candidates as JSON")
    dg.add_argument("--force", action="store_true", help="overwrite an existing --json file")
    dg.set_defaults(func=run)


def run(a: argparse.Namespace) -> int:
    """Diagnose the model on the records and print the table (and force-state maps)."""
    from modal_twin.diagnosis.workflow import diagnose_model
    from modal_twin.executors import make_executor
    from modal_twin.io.records import record_from_bag
    from modal_twin.models.loading import load_model
    from modal_twin.paths import atomic_file, check_new

    if a.json is not None:
        check_new(a.json, a.force)  # before the work
    plant = load_model(a.model).plant()  # names an imported record's channels by role
    train, test = (record_from_bag(a.train, plant=plant), record_from_bag(a.test, plant=plant))
    levels = [record_from_bag(b, plant=plant) for b in a.level or []]
    t0 = time.perf_counter()
    with make_executor(a.jobs) as ex:
        d = diagnose_model(a.model, train, test, levels=levels, n_fit=a.n_fit, mapper=ex.map,
                           progress=lambda s: print(f"  {s}", file=sys.stderr))
    print(d.format())
    print(f"diagnosis wall time {time.perf_counter() - t0:.1f} s")
    if a.json is not None:
        with atomic_file(a.json, force=a.force) as tmp:
            tmp.write_text(json.dumps(d.to_dict(), indent=1), encoding="utf-8")
        print(f"diagnose: wrote {a.json}")
    if a.plots:
        from modal_twin.viz.force_state import force_state_plots

        for png in force_state_plots(a.model, d, train, a.plots):
            print(f"force-state map: {png}")
    return ExitCode.OK
