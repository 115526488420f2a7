"""``modal-twin export modes|frf|model SRC --out FILE``: results for other tools.

- ``modes``: an ``identify`` JSON (``modes.json``) -> UFF 55 (complex modes);
- ``frf``: a bag's H1 FRFs (inputs and outputs by role) -> UFF 58 (function type 4);
- ``model``: a structure YAML or a matrix file -> NPZ with ``M``, ``K``, ``C``, ``dofs``
  (``"node:dof"`` labels), ``parameter_names``, ``theta0`` and one matrix per parameter
  (``K_<name>`` = dK/dtheta, ``M_<name>``, ``C_<name>``), readable again by
  :func:`modal_twin.models.matrix_model.load_matrix_model` (``K(theta) = K + sum (theta -
  theta0)_j K_j``).

Every output is written to a temporary file and renamed: nothing half-written.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin.errors import ConfigError
from modal_twin.exit_codes import ExitCode

__all__ = ["register", "run", "structure_arrays"]

def register(sub: argparse._SubParsersAction) -> None:
    """Add ``export`` to the sub-commands."""
    p = sub.add_parser("export", help="modes to UFF 55, FRFs to UFF 58, a model to NPZ")
    p.add_argument("what", choices=("modes", "frf", "model"))
    p.add_argument("src", type=Path, help="modes JSON, bag, or model file")
    p.add_argument("--out", type=Path, required=True, help="file to write (.uff / .npz)")
    p.add_argument("--rules", type=Path, default=None,
                   help="model from a matrix file: YAML of the data set's parameter order "
                        "and bounds (e.g. config/matrix_models/pedestrian_bridge.yaml)")
    p.set_defaults(func=run)


def structure_arrays(path: Path) -> dict[str, Any]:
    """NPZ arrays of a structure YAML (module docstring)."""
    from modal_twin.models.building import build_building
    from modal_twin.models.fe import DOF_NAMES

    asm = build_building(path).assembly
    par = asm.parametric
    dofs = [f"{asm.nodes[i // 6]}:{DOF_NAMES[i % 6]}" for i in asm.free_dofs]
    out: dict[str, Any] = {"M": asm.M.toarray(), "K": asm.K.toarray(), "C": asm.C.toarray(),
                           "dofs": np.array(dofs), "parameter_names": np.array(par.names),
                           "parameter_kinds": np.array(par.kinds), "theta0": par.theta0}
    for i, (n, kind) in enumerate(zip(par.names, par.kinds, strict=True)):
        out[f"{kind}_{n}"] = par.derivatives[i].toarray()
    return out


def _model(src: Path, out: Path, rules: Path | None = None) -> str:
    from modal_twin.commands.model_matrix import check_model_kind
    from modal_twin.models.matrix_model import load_matrix_model

    if check_model_kind(src) == "matrix":
        arrays = load_matrix_model(src, rules=rules).to_arrays()
    else:
        arrays = structure_arrays(src)
    _save_npz(out, arrays)
    return (f"{arrays['M'].shape[0]} DOFs, parameters "
            f"{[str(n) for n in arrays['parameter_names']]}")


def _save_npz(out: Path, arrays: dict[str, Any]) -> None:
    from modal_twin.io.imported import atomic_file

    if out.suffix.lower() != ".npz":
        msg = f"{out}: expected a .npz output file"
        raise ConfigError(msg)
    with atomic_file(out) as tmp, tmp.open("wb") as fh:
        np.savez(fh, **arrays)


def _modes(src: Path, out: Path) -> str:
    from modal_twin.io.imported import atomic_file
    from modal_twin.io.modes_file import read_modes
    from modal_twin.io.uff import AXIS_CODES, write_uff55

    if src.suffix.lower() != ".json":
        msg = f"{src}: expected a modes JSON written by `modal-twin identify`"
        raise ConfigError(msg)
    m = read_modes(src)
    with atomic_file(out) as tmp:
        tmp.unlink()
        write_uff55(tmp, m.f_hz, m.zeta, m.shapes, [int(d["node"]) for d in m.dofs],
                    [AXIS_CODES.get(d["direction"], 1) for d in m.dofs])
    return f"{m.f_hz.size} modes at {len(m.dofs)} DOFs"


def _frf(src: Path, out: Path) -> str:
    from modal_twin.acquisition.frf import frf
    from modal_twin.io.imported import atomic_file, read_imported
    from modal_twin.io.uff import AXIS_CODES, write_uff58_frf

    block, chans = read_imported(src)
    ins = [c for c in chans if c.effective_role == "input"]
    outs = [c for c in chans if c.effective_role == "output"]
    if not ins or not outs:
        msg = f"{src}: FRFs need input and output channels (roles), got {len(ins)} / {len(outs)}"
        raise ConfigError(msg)
    est = frf(block.select([c.name for c in ins]).data,
              block.select([c.name for c in outs]).data, block.fs_hz)
    nodes = sorted({c.node or c.name for c in chans})

    def dof(c: Any) -> tuple[int, int]:
        return nodes.index(c.node or c.name) + 1, AXIS_CODES.get(c.direction, 1)

    H = np.nan_to_num(est.H1)
    with atomic_file(out) as tmp:
        tmp.unlink()
        write_uff58_frf(tmp, est.f_hz, H, [dof(c) for c in outs], [dof(c) for c in ins])
    return f"{len(outs)} x {len(ins)} FRFs, {est.f_hz.size} lines"


def run(a: argparse.Namespace) -> int:
    """Export (module docstring)."""
    if not a.src.exists():
        msg = f"{a.src}: no such file or bag"
        raise ConfigError(msg)
    if a.rules is not None and a.what != "model":
        msg = f"--rules: only for export model, not export {a.what}"
        raise ConfigError(msg)
    what = (_model(a.src, a.out, a.rules) if a.what == "model" else
            {"modes": _modes, "frf": _frf}[a.what](a.src, a.out))
    print(f"export: wrote {a.out} ({what})")
    return ExitCode.OK
