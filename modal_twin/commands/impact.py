"""``modal-twin impact BAG... --block-s S --out DIR``: a hammer test's records to FRFs.

Each bag (a record of ``modal-twin import``: UFF 58 time records of force and responses,
a CSV, ...; or a run's bag) holds the force of one or more hit points and the responses.
Its hits are found, double hits and overloads rejected (counted and said), the accepted
hits averaged per point (:class:`modal_twin.acquisition.hammer_test.HammerTest`, as the
acquisition node's impact mode); several bags (one per hit point, the same responses) join
into one FRF matrix. Written: ``DIR/frf.uff`` (UFF 58 FRFs at the channels' nodes and
directions, for ``identify`` / PolyMAX; after the bags' test geometry, UFF 164 / 15 / 82,
when ``import`` kept one) and ``DIR/hits.yaml`` (every hit's verdict).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from modal_twin.errors import OptionError
from modal_twin.exit_codes import ExitCode

__all__ = ["register", "run"]

HELP = "hammer test records to an FRF matrix (hits checked, double hits / overloads rejected)"


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``impact`` parser."""
    p = sub.add_parser("impact", help=HELP, description=HELP)
    p.add_argument("bags", type=Path, nargs="+", help="records (bags), one or more hit points")
    p.add_argument("--block-s", type=float, required=True,
                   help="one hit's block, s (frequency resolution 1 / block)")
    p.add_argument("--estimator", choices=("H1", "H2", "Hv"), default="H1")
    p.add_argument("--tau-s", type=float, default=None,
                   help="exponential window on the responses, s (damping to correct)")
    p.add_argument("--force-range", type=float, default=None,
                   help="force channel range, N (a hit at it is an overload)")
    p.add_argument("--out", type=Path, required=True, help="output folder")
    p.add_argument("--force", action="store_true", help="overwrite existing outputs")
    p.set_defaults(func=run)


def _positive(x: float) -> bool:
    return math.isfinite(x) and x > 0


def _bag_geometry(bags: list[Path]) -> dict[str, Any] | None:
    """Return the test geometry ``import`` kept in the bags (merged); None without one."""
    from modal_twin.io.modes_file import read_geometry_files

    g: dict[str, Any] = {"nodes": {}, "trace_lines": []}
    for bag in bags:
        one = read_geometry_files(bag) if Path(bag).is_dir() else {}
        g["nodes"].update(one.get("nodes", {}))
        g["trace_lines"] += [t for t in one.get("trace_lines", []) if t not in g["trace_lines"]]
        if one.get("units") and "units" not in g:
            g["units"] = one["units"]
    return g if g["nodes"] else None


def run(a: argparse.Namespace) -> int:
    """Process the records and write ``frf.uff`` and ``hits.yaml`` (module docstring)."""
    from modal_twin.acquisition.hammer_test import HammerTest, merge_points
    from modal_twin.io.impact_files import FRF_FILE, SUMMARY_FILE, write_hammer_result
    from modal_twin.io.imported import read_imported
    from modal_twin.paths import check_new_in

    if not _positive(a.block_s) or (a.tau_s is not None and not _positive(a.tau_s)):
        msg = f"--block-s and --tau-s: expected > 0, got {a.block_s} and {a.tau_s}"
        raise OptionError(msg)
    if a.force_range is not None and not _positive(a.force_range):
        msg = f"--force-range: expected a range > 0 N, got {a.force_range}"
        raise OptionError(msg)
    check_new_in(a.out, (FRF_FILE, SUMMARY_FILE), a.force)
    results = []
    for bag in a.bags:
        block, channels = read_imported(bag)
        if round(a.block_s * block.fs_hz) > block.n_samples:
            msg = (f"--block-s {a.block_s}: expected at most the record's "
                   f"{block.n_samples / block.fs_hz:.6g} s ({bag})")
            raise OptionError(msg)
        test = HammerTest(channels, block_s=a.block_s, estimator=a.estimator,
                          tau_s=a.tau_s, force_range=a.force_range)
        print(f"impact: {bag}: forces {[c.name for c in test.inputs]}, responses "
              f"{[c.name for c in test.outputs]}")
        test.add(block)
        results.append(test.finish())
    res = merge_points(results)
    geo = _bag_geometry(a.bags)
    frf, hits = write_hammer_result(a.out, res, geometry=geo)
    for line in res.lines():
        print(line)
    print(f"wrote {frf}\nwrote {hits} (every hit's verdict)")
    return ExitCode.OK
