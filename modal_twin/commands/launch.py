"""``modal-twin launch SCENARIO``: run a scenario's nodes (and record them)."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from modal_twin.scenario import Scenario

__all__ = ["apply_sets", "register", "run", "scenario_path"]

ROOT = Path(__file__).resolve().parents[2]


def scenario_path(name: str) -> Path:
    """Find a scenario file by path, or by name in ``config/scenarios`` (source or installed)."""
    p = Path(name)
    if p.is_file():
        return p
    for base in (ROOT / "config" / "scenarios", Path(sys.prefix) / "share" / "modal_twin"
                 / "config" / "scenarios"):
        for cand in (base / name, base / f"{name}.yaml"):
            if cand.is_file():
                return cand
    return p


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``launch`` parser."""
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
    la.add_argument("--set", action="append", default=[], metavar="NODE.PARAM=VALUE",
                    help="override one node parameter (VALUE read as YAML, e.g. "
                    "excitation.seed=32); repeatable")
    la.set_defaults(func=run)


def apply_sets(sc: Scenario, sets: list[str]) -> Scenario:
    """Return the scenario with each ``NODE.PARAM=VALUE`` of ``sets`` applied.

    Raises
    ------
    ConfigError
        A malformed item, a node the scenario does not launch or a value that is not YAML.
    """
    import yaml

    from modal_twin.errors import ConfigError
    from modal_twin.scenario import with_parameters

    for item in sets:
        key, eq, text = item.partition("=")
        node, dot, param = key.partition(".")
        if not (eq and dot and node and param.isidentifier()):
            msg = f"--set {item!r}: expected NODE.PARAM=VALUE, e.g. excitation.seed=32"
            raise ConfigError(msg)
        try:
            value = yaml.safe_load(text)
        except yaml.YAMLError as err:
            msg = f"--set {item!r}: VALUE is not YAML: {str(err).splitlines()[0]}"
            raise ConfigError(msg) from err
        sc = with_parameters(sc, node, **{param: value})
    return sc


def run(a: argparse.Namespace) -> int:
    """Launch the scenario; the launcher's exit code."""
    from modal_twin.launch import Launcher
    from modal_twin.scenario import load_scenario

    sc = load_scenario(scenario_path(a.scenario), allow_external=a.allow_external)
    if a.network:
        from modal_twin.io.ros import dds_env

        dds_env(os.environ, network=True)
    sc = apply_sets(sc, a.set)
    if a.duration is not None:
        from dataclasses import replace

        sc = replace(sc, duration_s=a.duration)
    res = Launcher(sc, run_dir=a.run_dir, domain_id=a.domain_id, record=not a.no_record).run()
    if res.bag is not None and res.exit_code == 0:
        print(f"launch: bag {res.bag}")
    from modal_twin.io.impact_files import hit_summary_lines

    for line in hit_summary_lines(res.run_dir / "impact"):  # an impact test's verdicts
        print(f"launch: {line}")
    return res.exit_code
