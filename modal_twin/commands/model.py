"""``modal-twin model info FILE``: DOFs, mass, lowest modes of a structure or vehicle."""

from __future__ import annotations

import argparse
from pathlib import Path

from modal_twin.exit_codes import ExitCode

__all__ = ["register", "run"]


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``model`` parser and its ``info`` sub-command."""
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
    mi.add_argument("--carbody", choices=("rigid", "shell"), default=None,
                    help="3D vehicle file: the carbody model (default: the file's "
                         "carbody.model)")
    mi.add_argument("--carbody-params", type=Path, default=None, metavar="FILE",
                    help="3D vehicle file: zone factors of the shell carbody "
                         "(carbody_zone_factors, the carbody updating's result); implies "
                         "--carbody shell")
    mi.add_argument("--rules", type=Path, default=None,
                    help="matrix file: YAML of the data set's parameter order and bounds "
                         "(e.g. config/matrix_models/pedestrian_bridge.yaml)")
    mi.add_argument("--condense", action="store_true",
                    help="matrix file: condense the massless DOFs exactly (sensors kept) and "
                         "print the DOF count and lowest frequencies before and after")
    mo.set_defaults(func=run)


def run(a: argparse.Namespace) -> int:
    """Print the model's summary (``--json``: as one JSON document)."""
    import json

    from modal_twin.commands import ride
    from modal_twin.commands.model_matrix import MATRIX_SUFFIXES, check_model_kind, matrix_info
    from modal_twin.errors import OptionError
    from modal_twin.models.building import build_building, modal_reduction
    from modal_twin.models.carbody3d_file import is_carbody3d_file
    from modal_twin.models.model_info import model_info
    from modal_twin.models.vehicle3d_spec import is_vehicle3d_file
    from modal_twin.models.vehicle_spec import is_vehicle_file

    if check_model_kind(a.file) == "matrix":  # .mat / .npz from the user's FE tool
        return matrix_info(a)
    if getattr(a, "condense", False):
        msg = f"--condense: only for matrix models {MATRIX_SUFFIXES}, got {a.file}"
        raise OptionError(msg)
    if is_vehicle3d_file(a.file):  # config/vehicles/*_3d.yaml (kind: vehicle3d)
        return ride.vehicle3d_info(a)
    if getattr(a, "carbody_params", None) is not None:
        msg = f"--carbody-params: only for a 3D vehicle file (kind: vehicle3d), got {a.file}"
        raise OptionError(msg)
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
