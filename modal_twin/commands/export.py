"""``modal-twin export modes|frf|model SRC --out FILE``: results for other tools.

- ``modes``: an ``identify`` JSON (``modes.json``) -> UFF 55 (complex modes; the channels'
  nodes, directions and names, and the record's geometry as UFF 15 / 82);
- ``frf``: a bag's H1 FRFs (inputs and outputs by role; Welch blocks as ``identify``
  chooses them) -> UFF 58 (function type 4), each output's multiple coherence after them
  (function type 6, the averages named);
- ``model``: a structure YAML or a matrix file -> NPZ with ``M``, ``K``, ``C``, ``dofs``
  (``"node:dof"`` labels), ``parameter_names``, ``theta0`` and one matrix per parameter
  (``K_<name>`` = dK/dtheta, ``M_<name>``, ``C_<name>``), the matrices sparse (CSR
  members, :func:`modal_twin.models.matrix_model.sparse_members`), readable again by
  :func:`modal_twin.models.matrix_model.load_matrix_model` (``K(theta) = K + sum (theta -
  theta0)_j K_j``).

Every output is written to a temporary file and renamed: nothing half-written; an existing
file is kept unless ``--force``. A model's matrices are checked before anything is written
(:func:`check_matrices`): finite, a mass matrix with mass and no negative diagonal entry,
symmetric ``M`` and stiffnesses.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin.errors import ConfigError, ModelError
from modal_twin.exit_codes import ExitCode
from modal_twin.paths import atomic_file, check_new

__all__ = ["check_matrices", "register", "run", "structure_arrays"]

SYMMETRY_RTOL = 1e-9
"""Largest ``|A - A^T|`` relative to ``max |A|`` a symmetric matrix may show (round-off)."""

def register(sub: argparse._SubParsersAction) -> None:
    """Add ``export`` to the sub-commands."""
    p = sub.add_parser("export", help="modes to UFF 55, FRFs to UFF 58, a model to NPZ")
    p.add_argument("what", choices=("modes", "frf", "model"))
    p.add_argument("src", type=Path, help="modes JSON, bag, or model file")
    p.add_argument("--out", type=Path, required=True, help="file to write (.uff / .npz)")
    p.add_argument("--force", action="store_true", help="overwrite an existing file")
    p.add_argument("--rules", type=Path, default=None,
                   help="model from a matrix file: YAML of the data set's parameter order "
                        "and bounds (e.g. config/matrix_models/pedestrian_bridge.yaml)")
    p.set_defaults(func=run)


def check_matrices(arrays: dict[str, Any], source: str) -> None:
    """Refuse a model whose matrices no tool can use, before it is written.

    Every matrix and parameter value finite; ``M`` with a positive total and no negative
    diagonal entry (massless DOFs allowed); ``M``, ``K`` and every ``K_<name>`` symmetric
    to :data:`SYMMETRY_RTOL`.

    Raises
    ------
    ModelError
        Naming the matrix and what is wrong with it.
    """
    import scipy.sparse as sp

    def entries(a: Any) -> np.ndarray:
        return np.asarray(a.data if sp.issparse(a) else a)

    for k, v in arrays.items():  # the matrices and the parameter values (bounds may be inf)
        a = entries(v)
        if a.dtype.kind in "fc" and (sp.issparse(v) or a.ndim == 2 or k in ("theta", "theta0")
                                      ) and not np.all(np.isfinite(a)):
            msg = f"{source}: {k} holds {int(np.sum(~np.isfinite(a)))} NaN / Inf entries"
            raise ModelError(msg)
    M = arrays["M"]
    d = np.asarray(M.diagonal() if sp.issparse(M) else np.diag(np.asarray(M, dtype=float)),
                   dtype=float)
    if d.size and (d.min() < 0.0 or d.sum() <= 0.0):
        what = f"a negative mass {d.min():.6g}" if d.min() < 0.0 else "no mass (M = 0)"
        msg = f"{source}: M has {what} on its diagonal; expected masses >= 0 with a total > 0"
        raise ModelError(msg)
    for k in [k for k in arrays if k in ("M", "K") or k.startswith("K_")]:
        A = arrays[k]
        A = sp.csr_array(A, dtype=float) if sp.issparse(A) else np.asarray(A, dtype=float)
        scale = float(np.abs(entries(A)).max()) if entries(A).size else 0.0
        asym = float(np.abs(entries(A - A.T)).max()) if entries(A - A.T).size else 0.0
        if asym > SYMMETRY_RTOL * scale:
            msg = (f"{source}: {k} is not symmetric (max |{k} - {k}^T| = {asym:.3g}, "
                   f"{asym / scale:.2g} of its largest entry)")
            raise ModelError(msg)


def structure_arrays(path: Path) -> dict[str, Any]:
    """NPZ arrays of a structure YAML (module docstring)."""
    from modal_twin.models.building import build_building
    from modal_twin.models.fe import DOF_NAMES

    asm = build_building(path).assembly
    par = asm.parametric
    dofs = [f"{asm.nodes[i // 6]}:{DOF_NAMES[i % 6]}" for i in asm.free_dofs]
    out: dict[str, Any] = {"M": asm.M, "K": asm.K, "C": asm.C,
                           "dofs": np.array(dofs), "parameter_names": np.array(par.names),
                           "parameter_kinds": np.array(par.kinds), "theta0": par.theta0}
    for i, (n, kind) in enumerate(zip(par.names, par.kinds, strict=True)):
        out[f"{kind}_{n}"] = par.derivatives[i]
    return out


def _model(src: Path, out: Path, force: bool, rules: Path | None = None) -> str:
    from modal_twin.commands.model_matrix import check_model_kind
    from modal_twin.models.matrix_model import load_matrix_model

    if check_model_kind(src) == "matrix":
        arrays = load_matrix_model(src, rules=rules).to_arrays()
    else:
        arrays = structure_arrays(src)
    check_matrices(arrays, str(src))
    _save_npz(out, arrays, force)
    return (f"{arrays['M'].shape[0]} DOFs, parameters "
            f"{[str(n) for n in arrays['parameter_names']]}")


def _save_npz(out: Path, arrays: dict[str, Any], force: bool) -> None:
    from modal_twin.models.matrix_model import sparse_members

    if out.suffix.lower() != ".npz":
        msg = f"{out}: expected a .npz output file"
        raise ConfigError(msg)
    with atomic_file(out, force=force) as tmp, tmp.open("wb") as fh:
        np.savez_compressed(fh, **sparse_members(arrays))


def _modes(src: Path, out: Path, force: bool) -> str:
    from modal_twin.io.modes_file import read_modes, write_modes_uff

    if src.suffix.lower() != ".json":
        msg = f"{src}: expected a modes JSON written by `modal-twin identify`"
        raise ConfigError(msg)
    m = read_modes(src)
    with atomic_file(out, force=force) as tmp:
        tmp.unlink()
        write_modes_uff(tmp, m.f_hz, m.zeta, m.shapes, m.dofs, m.geometry)
    n_geo = len((m.geometry or {}).get("nodes", {}))
    return (f"{m.f_hz.size} modes at {len(m.dofs)} channels"
            + (f", geometry of {n_geo} nodes" if n_geo else ", no geometry in the JSON"))


def _frf(src: Path, out: Path, force: bool) -> str:
    from modal_twin.acquisition.frf import frf
    from modal_twin.identification.record import welch_segment
    from modal_twin.io.imported import read_imported
    from modal_twin.io.uff import AXIS_CODES, write_uff58_frf

    block, chans = read_imported(src)
    ins = [c for c in chans if c.effective_role == "input"]
    outs = [c for c in chans if c.effective_role == "output"]
    if not ins or not outs:
        msg = f"{src}: FRFs need input and output channels (roles), got {len(ins)} / {len(outs)}"
        raise ConfigError(msg)
    est = frf(block.select([c.name for c in ins]).data,
              block.select([c.name for c in outs]).data, block.fs_hz,
              nperseg=welch_segment(block.n_samples, len(ins)))  # identify's blocks
    nodes = sorted({c.node or c.name for c in chans})

    def dof(c: Any) -> tuple[int, int]:
        return nodes.index(c.node or c.name) + 1, AXIS_CODES.get(c.direction, 1)

    H = np.nan_to_num(est.H1)
    with atomic_file(out, force=force) as tmp:
        tmp.unlink()
        write_uff58_frf(tmp, est.f_hz, H, [dof(c) for c in outs], [dof(c) for c in ins],
                        [c.quantity for c in outs], [c.quantity for c in ins],
                        names=([c.name for c in outs], [c.name for c in ins]),
                        coherence=np.nan_to_num(est.coherence), averages=est.n_averages)
    return (f"{len(outs)} x {len(ins)} FRFs, {est.f_hz.size} lines, H1 over "
            f"{est.n_averages} averages, each output's multiple coherence")


def run(a: argparse.Namespace) -> int:
    """Export (module docstring)."""
    if not a.src.exists():
        msg = f"{a.src}: no such file or bag"
        raise ConfigError(msg)
    check_new(a.out, a.force)  # before the work
    if a.rules is not None and a.what != "model":
        msg = f"--rules: only for export model, not export {a.what}"
        raise ConfigError(msg)
    what = (_model(a.src, a.out, a.force, a.rules) if a.what == "model" else
            {"modes": _modes, "frf": _frf}[a.what](a.src, a.out, a.force))
    print(f"export: wrote {a.out} ({what})")
    return ExitCode.OK
