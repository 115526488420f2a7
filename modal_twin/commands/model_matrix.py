"""``modal-twin model info`` for matrix files (.mat / .npz) and the kind check of model files.

Used by :func:`modal_twin.commands.model.run`; not a sub-command of its own.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from modal_twin.errors import ConfigError
from modal_twin.exit_codes import ExitCode

__all__ = ["MATRIX_SUFFIXES", "YAML_SUFFIXES", "check_model_kind", "matrix_info"]

MATRIX_SUFFIXES = (".mat", ".npz")
YAML_SUFFIXES = (".yaml", ".yml")


def check_model_kind(path: Path) -> str:
    """``"matrix"`` or ``"yaml"``; a ConfigError naming the file for anything else."""
    if not path.is_file():
        msg = f"{path}: no such model file"
        raise ConfigError(msg)
    suf = path.suffix.lower()
    if suf in MATRIX_SUFFIXES:
        return "matrix"
    if suf in YAML_SUFFIXES:
        try:
            path.read_text(encoding="utf-8")
        except UnicodeDecodeError as err:
            msg = f"{path}: expected a YAML text file, got binary data ({err.reason})"
            raise ConfigError(msg) from err
        return "yaml"
    msg = (f"{path}: unknown model file kind {suf!r}; expected a structure / vehicle YAML "
           f"{YAML_SUFFIXES} or matrices {MATRIX_SUFFIXES}")
    raise ConfigError(msg)


def matrix_info(a: argparse.Namespace) -> int:
    """DOFs, parameters, measured DOFs and lowest modes of a matrix model."""
    from modal_twin.models.fe import solve_modes
    from modal_twin.models.matrix_model import load_matrix_model

    mm = load_matrix_model(a.file, rules=a.rules)
    n_show = min(a.modes or a.show, mm.n_dof - 2)
    s = solve_modes(mm.K0, mm.M, n_show)
    info = {"file": str(a.file), "n_dof": mm.n_dof, "parameters": list(mm.names),
            "n_measured_dofs": int(mm.measured_dofs.size),
            "damping": mm.C is not None,
            "bounds": None if mm.lower is None or mm.upper is None
            else [list(mm.lower), list(mm.upper)],
            "f_hz": [float(f) for f in s.f_hz]}
    if a.json:
        print(json.dumps(info, indent=1))
        return ExitCode.OK
    print(f"{a.file.name}: {mm.n_dof} DOFs, {len(mm.names)} stiffness parameters "
          f"{list(mm.names)}, {mm.measured_dofs.size} measured DOFs, "
          f"damping {'given' if mm.C is not None else 'none'}")
    print(f"{'mode':>4} {'f [Hz]':>9}")
    for k, f in enumerate(np.asarray(s.f_hz)):
        print(f"{k + 1:>4d} {f:9.4f}")
    return ExitCode.OK
