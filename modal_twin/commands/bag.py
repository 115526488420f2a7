"""``modal-twin bag info BAG`` and ``modal-twin bag salvage BAG``."""

from __future__ import annotations

import argparse
from pathlib import Path

from modal_twin.exit_codes import ExitCode

__all__ = ["register", "run"]


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``bag`` parser and its ``info`` / ``salvage`` sub-commands."""
    bag = sub.add_parser("bag", help="bag tools")
    bsub = bag.add_subparsers(dest="bag_cmd", required=True)
    bi = bsub.add_parser("info", help="topics, types, counts, duration")
    bi.add_argument("bag", type=Path)
    bi.add_argument("--json", action="store_true")
    bs = bsub.add_parser("salvage", help="make a bag cut by a crash readable")
    bs.add_argument("bag", type=Path)
    bs.add_argument("--out", type=Path, default=None)
    bag.set_defaults(func=run)


def run(a: argparse.Namespace) -> int:
    """Print a bag's summary, or salvage it into ``--out``."""
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
