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
modal-twin impact BAG... --block-s S --out DIR            (hammer test records -> FRFs)
modal-twin hammer config/hammer_tests/tracking_frame.yaml --out DIR   (test to updated model)
modal-twin setups MODES1.json MODES2.json... [--references CH,CH] --out DIR   (roving setups)
modal-twin update MODEL --modes FILE [--out DIR]           (structure, version, .mat, .npz)
modal-twin export modes|frf|model SRC --out FILE
modal-twin view MODEL [--modes FILE | --bag BAG] [--html OUT]   (or a UFF test geometry)
modal-twin report RUN_DIR [--out FILE]
modal-twin residual MODEL BAG [--top N] [--live]          (the twin on a record, per channel)
modal-twin sdof RECORD [--period N] [--test RECORD] [--out DIR] [--json FILE]   (one-DOF fits)
modal-twin ride [VEHICLE_3D] --speed KMH [--duration S] [--sweep A:B:STEP]   (Sperling, hunting)
modal-twin demo
"""

from __future__ import annotations

import argparse
import logging
import os
import re
import sys

from modal_twin import demo
from modal_twin.commands import (
    bag,
    campaign,
    diagnose,
    effects,
    export,
    hammer,
    identify,
    impact,
    import_,
    launch,
    model,
    report,
    residual,
    ride,
    sdof,
    setups,
    update,
    view,
)
from modal_twin.errors import ModalTwinError
from modal_twin.exit_codes import ExitCode
from modal_twin.paths import private_files
from modal_twin.progress import Verbosity, set_verbosity
from modal_twin.runtime import THREAD_ENV

# one BLAS thread (modal_twin.runtime), set before numpy loads (neither import above does)
for _k, _v in THREAD_ENV.items():
    os.environ.setdefault(_k, _v)

__all__ = ["main"]


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="modal-twin", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    _verbosity_flags(p)
    sub = p.add_subparsers(dest="cmd", required=True)
    launch.register(sub)
    sub.add_parser("record", help="record topics to a bag", add_help=False)
    sub.add_parser("replay", help="republish a bag", add_help=False)
    for mod in (bag, model, diagnose, effects, view, report, demo, import_, identify, export,
                update, campaign, residual, ride, sdof, impact, hammer, setups):
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


_NUMBER_LIST = re.compile(r"^-[0-9.][0-9.eE+-]*(,[-+]?[0-9.][0-9.eE+-]*)+$")


def _negative_lists_joined(argv: list[str]) -> list[str]:
    """``--opt -0.7,1.5`` as ``--opt=-0.7,1.5``.

    argparse reads a value that starts with a minus as an option unless it is one plain
    negative number, so a list such as ``--bounds -0.7,1.5`` failed with "expected one
    argument". A comma-separated list of numbers after a long option is its value.
    """
    out: list[str] = []
    for token in argv:
        if (out and out[-1].startswith("--") and "=" not in out[-1]
                and _NUMBER_LIST.match(token)):
            out[-1] = f"{out[-1]}={token}"
        else:
            out.append(token)
    return out


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
    a = _parser().parse_args(_negative_lists_joined(argv))
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
