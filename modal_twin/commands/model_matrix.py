"""``modal-twin model info`` for matrix files (.mat / .npz) and the kind check of model files.

Used by :func:`modal_twin.commands.model.run`; not a sub-command of its own.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any, Literal

import numpy as np

from modal_twin.errors import ConfigError
from modal_twin.exit_codes import ExitCode

__all__ = ["MATRIX_SUFFIXES", "YAML_SUFFIXES", "check_model_kind", "matrix_info"]

MATRIX_SUFFIXES = (".mat", ".npz")
YAML_SUFFIXES = (".yaml", ".yml")


def check_model_kind(path: Path) -> str:
    """``"matrix"`` (a frame file too) or ``"yaml"``; a ConfigError naming anything else."""
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
        from modal_twin.models.frame_file import is_frame_file

        return "matrix" if is_frame_file(path) else "yaml"
    msg = (f"{path}: unknown model file kind {suf!r}; expected a structure / vehicle YAML "
           f"{YAML_SUFFIXES} or matrices {MATRIX_SUFFIXES}")
    raise ConfigError(msg)


def matrix_info(a: argparse.Namespace) -> int:
    """DOFs, parameters, measured DOFs and lowest modes of a matrix model.

    With ``a.condense`` the massless DOFs are condensed exactly
    (:func:`modal_twin.models.fe.condensation.condense_massless`, the sensors' DOFs kept) and
    the lowest frequencies of the condensed model are printed beside the full model's.
    """
    from modal_twin.models.fe import solve_modes
    from modal_twin.models.matrix_model import load_matrix_model

    mm = load_matrix_model(a.file, rules=a.rules)
    n_show = min(a.modes or a.show, mm.n_dof - 2)
    s = solve_modes(mm.K0, mm.M, n_show)
    info: dict[str, Any] = {
        "file": str(a.file), "n_dof": mm.n_dof, "parameters": list(mm.names),
        "n_measured_dofs": int(mm.measured_dofs.size), "damping": mm.C is not None,
        "bounds": None if mm.lower is None or mm.upper is None
        else [list(mm.lower), list(mm.upper)],
        "f_hz": [float(f) for f in s.f_hz]}
    if getattr(a, "condense", False):
        info["condensed"] = _condensed(mm, n_show)
    if a.json:
        print(json.dumps(info, indent=1))
        return ExitCode.OK
    print(f"{a.file.name}: {mm.n_dof} DOFs, {len(mm.names)} stiffness parameters "
          f"{list(mm.names)}, {mm.measured_dofs.size} measured DOFs, "
          f"damping {'given' if mm.C is not None else 'none'}")
    cd = info.get("condensed")
    if cd is None:
        print(f"{'mode':>4} {'f [Hz]':>9}")
        for k, f in enumerate(np.asarray(s.f_hz)):
            print(f"{k + 1:>4d} {f:9.4f}")
        return ExitCode.OK
    print(f"condensed: {cd['n_dof_before']} -> {cd['n_dof_after']} DOFs "
          f"({cd['n_condensed']} massless DOFs in {cd['n_groups']} groups; "
          f"{cd['n_kept_mixed']} massless DOFs kept where parameters mix)")
    print(f"{'mode':>4} {'f full [Hz]':>12} {'f condensed [Hz]':>17} {'rel. diff':>10}")
    for k, (f, fc) in enumerate(zip(info["f_hz"], cd["f_hz"], strict=False)):
        print(f"{k + 1:>4d} {f:12.6f} {fc:17.6f} {abs(fc - f) / f if f else 0.0:10.1e}")
    return ExitCode.OK


def _condensed(mm: Any, n_show: int) -> dict[str, Any]:
    """Condense the massless DOFs of ``mm`` (sensors kept) and return counts and modes."""
    import scipy.sparse as sp

    from modal_twin.models.fe import solve_modes
    from modal_twin.models.fe.condensation import condense_massless
    from modal_twin.models.fe.parametric import ParametricMatrices

    n = mm.n_dof
    # K0 + sum_j theta_j K_j (theta = 0 nominal) written as K0 + sum_j K_j (t_j - 1) with
    # t_j = 1 + theta_j: the condensation scales a group with t_p / t_p0 (its docstring)
    kinds: tuple[Literal["K"], ...] = tuple("K" for _ in mm.names)
    par = ParametricMatrices(
        names=tuple(mm.names), kinds=kinds, theta0=np.ones(len(mm.names)),
        K0=mm.K0, M0=mm.M, C0=mm.C if mm.C is not None else sp.csr_array((n, n)),
        derivatives=tuple(mm.K_j))
    c = condense_massless(par, keep=mm.measured_dofs)
    m_c = c.masters.size
    fc: list[float] = ([float(f) for f in solve_modes(c.par.K0, c.par.M0,
                                                      min(n_show, m_c - 2)).f_hz]
                       if m_c > 2 else [])
    return {"n_dof_before": n, "n_dof_after": int(m_c), "n_condensed": int(n - m_c),
            "n_groups": c.n_groups, "n_kept_mixed": c.n_kept_mixed,
            "f_hz": fc}
