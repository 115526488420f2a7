"""``modal-twin effects add`` (fit an effect, write version n+1) and ``effects history``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from modal_twin.exit_codes import ExitCode
from modal_twin.paths import check_new

__all__ = ["register", "run"]


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``effects`` parser and its ``add`` / ``history`` sub-commands."""
    ef = sub.add_parser("effects", help="add an effect to a model; error history")
    esub = ef.add_subparsers(dest="effects_cmd", required=True)
    ea = esub.add_parser("add", help="fit an effect and write model version n+1")
    ea.add_argument("model", type=Path, help="structure or model version file")
    ea.add_argument("--train", type=Path, required=True)
    ea.add_argument("--test", type=Path, required=True)
    ea.add_argument("--out", type=Path, required=True, help="model version folder")
    ea.add_argument("--level", type=Path, action="append",
                    help="another record no effect may make worse; repeatable")
    ea.add_argument("--jobs", default=None, help="as for diagnose")
    ea.add_argument("--auto", action="store_true",
                    help="write every effect the diagnosis finds (accepted, unflagged)")
    ea.add_argument("--component")
    ea.add_argument("--law")
    ea.add_argument("--param", action="append", help="starting value, name=value")
    eh = esub.add_parser("history", help="versions and their held-out errors")
    eh.add_argument("folder", type=Path)
    eh.add_argument("--png", type=Path, default=None)
    eh.add_argument("--force", action="store_true", help="--png: overwrite an existing file")
    ef.set_defaults(func=run)


def run(a: argparse.Namespace) -> int:
    """Print the history, or fit an effect (given or diagnosed) and write the next version."""
    from modal_twin.diagnosis.workflow import (
        add_diagnosed,
        add_effect,
        choose_start,
        diagnose_model,
    )
    from modal_twin.io.records import record_from_bag
    from modal_twin.models.loading import load_model
    from modal_twin.models.versions import history
    from modal_twin.viz.error_history import plot_error_history

    if a.effects_cmd == "history":
        if a.png:
            check_new(a.png, a.force)  # before the work
        for v in history(a.folder):
            mean = sum(v.errors.values()) / max(len(v.errors), 1)
            print(f"{v.label:>5}  mean held-out NRMSE {mean:8.3f} %  {v.note}")
        if a.png:
            print(f"plot: {plot_error_history(a.folder, a.png, force=a.force)}")
        return ExitCode.OK
    plant = load_model(a.model).plant()  # names an imported record's channels by role
    train, test = (record_from_bag(a.train, plant=plant), record_from_bag(a.test, plant=plant))
    levels = [record_from_bag(b, plant=plant) for b in a.level or []]
    if a.auto:
        from modal_twin.executors import make_executor

        with make_executor(a.jobs) as ex:  # one diagnosis: its table, then what it found
            d = diagnose_model(a.model, train, test, levels=levels, mapper=ex.map)
        print("\n".join(d.table()))
        for why in d.dropped:  # backward elimination after the joint refit
            print(f"dropped after the joint refit: {why}")
        mv = add_diagnosed(a.model, d, test, a.out)
        if mv is None:
            print(f"nothing to add: {d.summary}")
            return ExitCode.OK
        print(f"wrote {mv.path}: {mv.note}")
        return ExitCode.OK
    if not (a.component and a.law):
        print("modal-twin effects add: give --component and --law, or --auto", file=sys.stderr)
        return ExitCode.USAGE
    start: dict[str, float] = {}
    for item in a.param or []:
        key, _, value = item.partition("=")
        start[key] = float(value)
    if not start:
        start = choose_start(load_model(a.model), a.component, a.law, train)
    mv, fitted = add_effect(a.model, a.component, a.law, start, train, test, a.out,
                            levels=levels)
    print(f"wrote {mv.path}: {mv.note}")
    print(f"parameters {fitted.parameter_text()}")
    return ExitCode.OK
