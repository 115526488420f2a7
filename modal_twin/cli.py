"""``modal-twin``: the command line of modal_twin.

modal-twin launch config/scenarios/<name>.yaml [--domain-id N] [--run-dir DIR]
modal-twin record -o BAG /topic [/topic:pkg/msg/Type ...]
modal-twin replay BAG [--rate R]
modal-twin bag info BAG | modal-twin bag salvage BAG [--out DIR]
modal-twin model info config/structures/building.yaml [--json]   (or config/vehicles/...)
modal-twin diagnose MODEL --train BAG --test BAG
modal-twin effects add MODEL --train BAG --test BAG --out DIR (--auto | --component C --law L)
modal-twin effects history DIR [--png FILE]
modal-twin import FILE... --out BAG [--map MAP.yaml]       (UFF, CSMIP / SMC, CSV, NPZ)
modal-twin identify BAG [--method n4sid|ssi-cov|polymax] [--out DIR]
modal-twin update MODEL --modes FILE [--out DIR]           (structure, version, .mat, .npz)
modal-twin export modes|frf|model SRC --out FILE
modal-twin view MODEL [--modes FILE | --bag BAG] [--html OUT]   (or a UFF test geometry)
modal-twin report RUN_DIR [--out FILE]
modal-twin residual MODEL BAG [--top N] [--live]          (the twin on a record, per channel)
modal-twin ride [VEHICLE_3D] --speed KMH [--duration S] [--sweep A:B:STEP]   (Sperling, hunting)
modal-twin demo
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import time
from pathlib import Path

from modal_twin.commands import (
    campaign,
    export,
    identify,
    import_,
    report,
    residual,
    ride,
    update,
    view,
)
from modal_twin.commands.model_matrix import check_model_kind, matrix_info
from modal_twin.errors import ModalTwinError
from modal_twin.exit_codes import ExitCode
from modal_twin.paths import private_files
from modal_twin.progress import Verbosity, set_verbosity
from modal_twin.runtime import THREAD_ENV

# one BLAS thread (modal_twin.runtime), set before numpy loads (neither import above does)
for _k, _v in THREAD_ENV.items():
    os.environ.setdefault(_k, _v)

__all__ = ["main"]

ROOT = Path(__file__).resolve().parents[1]
DEMO_SCENARIO = "demo.yaml"


def _scenario_path(name: str) -> Path:
    p = Path(name)
    if p.is_file():
        return p
    for base in (ROOT / "config" / "scenarios", Path(sys.prefix) / "share" / "modal_twin"
                 / "config" / "scenarios"):
        for cand in (base / name, base / f"{name}.yaml"):
            if cand.is_file():
                return cand
    return p


def _cmd_launch(a: argparse.Namespace) -> int:
    from modal_twin.launch import Launcher
    from modal_twin.scenario import load_scenario

    sc = load_scenario(_scenario_path(a.scenario), allow_external=a.allow_external)
    if a.network:
        from modal_twin.io.ros import dds_env

        dds_env(os.environ, network=True)
    if a.duration is not None:
        from dataclasses import replace

        sc = replace(sc, duration_s=a.duration)
    res = Launcher(sc, run_dir=a.run_dir, domain_id=a.domain_id, record=not a.no_record).run()
    if res.bag is not None and res.exit_code == 0:
        print(f"launch: bag {res.bag}")
    return res.exit_code


def _cmd_bag(a: argparse.Namespace) -> int:
    from modal_twin.io.bag import bag_info, salvage

    if a.bag_cmd == "info":
        info = bag_info(a.bag)
        if a.json:
            import json

            print(json.dumps({
                "path": str(info.path), "parts": len(info.parts), "duration_s": info.duration_s,
                "size_bytes": info.size_bytes,
                "topics": [{"name": t.name, "type": t.msgtype, "count": t.count}
                           for t in info.topics],
            }))
        else:
            print(info.format())
        return ExitCode.OK
    info = salvage(a.bag, a.out)
    print(f"salvaged into {info.path}\n{info.format()}")
    return ExitCode.OK


def _cmd_model(a: argparse.Namespace) -> int:
    import json

    from modal_twin.models.building import build_building, modal_reduction
    from modal_twin.models.carbody3d_file import is_carbody3d_file
    from modal_twin.models.model_info import model_info
    from modal_twin.models.vehicle3d_spec import is_vehicle3d_file
    from modal_twin.models.vehicle_spec import is_vehicle_file

    if check_model_kind(a.file) == "matrix":  # .mat / .npz from the user's FE tool
        return matrix_info(a)
    if is_vehicle3d_file(a.file):  # config/vehicles/*_3d.yaml (kind: vehicle3d)
        return ride.vehicle3d_info(a)
    if is_vehicle_file(a.file):  # config/vehicles
        return _vehicle_info(a)
    if is_carbody3d_file(a.file):  # config/carbodies: the 3D shell carbody
        return _carbody3d_info(a)
    bld = build_building(a.file)
    red = modal_reduction(bld, a.modes)
    info = model_info(bld.assembly, red.f_hz, red.Phi, red.zeta, name=bld.spec.name,
                      groups=[f.nodes for f in bld.spec.floors], n_show=a.show)
    print(json.dumps(info.to_dict(), indent=1) if a.json else info.table())
    return ExitCode.OK


def _carbody3d_info(a: argparse.Namespace) -> int:
    import json

    from modal_twin.models.carbody3d import build_carbody
    from modal_twin.models.carbody3d_file import (
        carbody3d_info,
        format_carbody3d_info,
        load_carbody3d,
    )

    name, params, n_modes = load_carbody3d(a.file)
    info = carbody3d_info(build_carbody(params), a.modes or n_modes, name=name, n_show=a.show)
    print(json.dumps(info, indent=1) if a.json else format_carbody3d_info(info))
    return ExitCode.OK


def _vehicle_info(a: argparse.Namespace) -> int:
    import json

    from modal_twin.models.vehicle import assemble_vehicle, load_vehicle, vehicle_info

    info = vehicle_info(assemble_vehicle(load_vehicle(a.file)), n_show=a.show)
    if a.json:
        print(json.dumps(info, indent=1))
        return ExitCode.OK
    print(f"{info['name']}: {info['n_dof']} DOFs ({info['n_cb_modes']} CB modes), total "
          f"mass {info['total_mass_kg'] / 1e3:.2f} t, free-free carbody "
          + ", ".join(f"{f:.2f}" for f in info["carbody_f_free_hz"]) + " Hz")
    print(f"{'mode':>4} {'f [Hz]':>9} {'zeta [%]':>8}  part")
    for m in info["modes"]:
        print(f"{m['number']:>4d} {m['f_hz']:9.4f} {100 * m['zeta']:8.2f}  {m['part']}")
    return ExitCode.OK


def _cmd_diagnose(a: argparse.Namespace) -> int:
    from modal_twin.diagnosis.workflow import diagnose_model
    from modal_twin.executors import make_executor
    from modal_twin.io.records import record_from_bag
    from modal_twin.models.loading import load_model

    plant = load_model(a.model).plant()  # names an imported record's channels by role
    train, test = (record_from_bag(a.train, plant=plant), record_from_bag(a.test, plant=plant))
    levels = [record_from_bag(b, plant=plant) for b in a.level or []]
    t0 = time.perf_counter()
    with make_executor(a.jobs) as ex:
        d = diagnose_model(a.model, train, test, levels=levels, n_fit=a.n_fit, mapper=ex.map,
                           progress=lambda s: print(f"  {s}", file=sys.stderr))
    print(d.format())
    print(f"diagnosis wall time {time.perf_counter() - t0:.1f} s")
    if a.plots:
        from modal_twin.viz.force_state import force_state_plots

        for png in force_state_plots(a.model, d, train, a.plots):
            print(f"force-state map: {png}")
    return ExitCode.OK


def _cmd_effects(a: argparse.Namespace) -> int:
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
        for v in history(a.folder):
            mean = sum(v.errors.values()) / max(len(v.errors), 1)
            print(f"{v.label:>5}  mean held-out NRMSE {mean:8.3f} %  {v.note}")
        if a.png:
            print(f"plot: {plot_error_history(a.folder, a.png)}")
        return ExitCode.OK
    plant = load_model(a.model).plant()  # names an imported record's channels by role
    train, test = (record_from_bag(a.train, plant=plant), record_from_bag(a.test, plant=plant))
    levels = [record_from_bag(b, plant=plant) for b in a.level or []]
    if a.auto:
        from modal_twin.executors import make_executor

        with make_executor(a.jobs) as ex:
            d = diagnose_model(a.model, train, test, levels=levels, mapper=ex.map)
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


def _cmd_demo(a: argparse.Namespace) -> int:
    from modal_twin.demo import run_demo

    return run_demo(run_dir=a.run_dir)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="modal-twin", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    _verbosity_flags(p)
    sub = p.add_subparsers(dest="cmd", required=True)
    la = sub.add_parser("launch", help="run a scenario's nodes")
    la.add_argument("scenario", help="scenario YAML (path or name in config/scenarios)")
    la.add_argument("--domain-id", type=int, default=None)
    la.add_argument("--run-dir", type=Path, default=None)
    la.add_argument("--duration", type=float, default=None, help="override launch.duration_s")
    la.add_argument("--no-record", action="store_true")
    la.add_argument("--allow-external", action="store_true",
                    help="let the scenario start executables that are not this package's nodes")
    la.add_argument("--network", action="store_true",
                    help="discover nodes on the network, not only this host (see README)")
    la.set_defaults(func=_cmd_launch)
    sub.add_parser("record", help="record topics to a bag", add_help=False)
    sub.add_parser("replay", help="republish a bag", add_help=False)
    bag = sub.add_parser("bag", help="bag tools")
    bsub = bag.add_subparsers(dest="bag_cmd", required=True)
    bi = bsub.add_parser("info", help="topics, types, counts, duration")
    bi.add_argument("bag", type=Path)
    bi.add_argument("--json", action="store_true")
    bs = bsub.add_parser("salvage", help="make a bag cut by a crash readable")
    bs.add_argument("bag", type=Path)
    bs.add_argument("--out", type=Path, default=None)
    bag.set_defaults(func=_cmd_bag)
    mo = sub.add_parser("model", help="structural model tools")
    msub = mo.add_subparsers(dest="model_cmd", required=True)
    mi = msub.add_parser("info", help="DOF count, total mass, lowest modes")
    mi.add_argument("file", type=Path,
                    help="structure, vehicle or 3D carbody YAML (config/structures/..., "
                         "config/vehicles/..., config/carbodies/...) or M, K (K_j, C) "
                         "matrices in a .mat / .npz file")
    mi.add_argument("--json", action="store_true")
    mi.add_argument("--modes", type=int, default=None, help="modes to compute")
    mi.add_argument("--show", type=int, default=12, help="modes to list")
    mo.set_defaults(func=_cmd_model)
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
    dg.set_defaults(func=_cmd_diagnose)
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
    ef.set_defaults(func=_cmd_effects)
    view.register(sub)
    report.register(sub)
    de = sub.add_parser("demo", help="the main job: run the demo scenario and report")
    de.add_argument("--run-dir", type=Path, default=None)
    de.set_defaults(func=_cmd_demo)
    for mod in (import_, identify, export, update, campaign, residual, ride):
        mod.register(sub)
    _flags_on_commands(sub)  # also after the command: modal-twin demo --quiet
    return p


def _flags_on_commands(sub: argparse._SubParsersAction) -> None:
    for name, sp in sub.choices.items():
        if name in ("record", "replay"):  # parsed by their own mains
            continue
        nested = [a for a in sp._actions if isinstance(a, argparse._SubParsersAction)]
        for n in nested:
            _flags_on_commands(n)
        if not nested:
            _verbosity_flags(sp, default=argparse.SUPPRESS)


def _verbosity_flags(p: argparse.ArgumentParser, default: object = False) -> None:
    talk = p.add_mutually_exclusive_group()
    talk.add_argument("-v", "--verbose", action="store_true", default=default,
                      help="debug logging; progress lines every second")
    talk.add_argument("-q", "--quiet", action="store_true", default=default,
                      help="no progress and no info logging (errors only)")


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``modal-twin``."""
    argv = sys.argv[1:] if argv is None else argv
    private_files()  # one file-mode policy: outputs 0600, folders 0700 (README)
    if "--network" not in argv:  # discovery stays on this host unless asked (README: network)
        os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    if argv and argv[0] == "record":
        from modal_twin.io.recorder import main as record_main

        return record_main(argv[1:])
    if argv and argv[0] == "replay":
        from modal_twin.io.replay import main as replay_main

        return replay_main(argv[1:])
    a = _parser().parse_args(argv)
    level = Verbosity.QUIET if a.quiet else Verbosity.VERBOSE if a.verbose else Verbosity.NORMAL
    set_verbosity(level)
    logging.basicConfig(level={Verbosity.QUIET: logging.WARNING, Verbosity.NORMAL: logging.INFO,
                               Verbosity.VERBOSE: logging.DEBUG}[level],
                        format="%(levelname)s %(name)s: %(message)s")
    try:
        return int(a.func(a))
    except KeyboardInterrupt:
        return ExitCode.INTERRUPTED
    except ModalTwinError as err:
        print(f"modal-twin {a.cmd}: {_one_line(err)}", file=sys.stderr)
        return ExitCode.USAGE
    except UnicodeDecodeError as err:
        print(f"modal-twin {a.cmd}: an input file is not UTF-8 text (binary or UTF-16?): "
              f"{err.reason} at byte {err.start}", file=sys.stderr)
        return ExitCode.USAGE
    except Exception as err:  # unreadable or foreign input: one line, never a traceback
        print(f"modal-twin {a.cmd}: {type(err).__name__}: {_one_line(err)}", file=sys.stderr)
        return ExitCode.USAGE


def _one_line(err: BaseException) -> str:
    lines = str(err).strip().splitlines()
    return lines[0][:500] if lines else ""


if __name__ == "__main__":
    sys.exit(main())
