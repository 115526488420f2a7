"""Identified modes from a file: ``identify`` JSON, UFF 55, or a MATLAB ``.mat``.

All readers return :class:`ModesFile`. ``.mat`` variables (Structural-Model-Updating
conventions): frequencies from ``lambdaExp`` (``(2 pi f)^2``), ``freqExp`` or
``test_frequency`` (Hz); shapes ``psiExp_m`` / ``psiExp`` / ``test_mode`` (channels x
modes); optional ``std_lambdaExp``, ``std_psiExp``, ``dampExp`` and ``measDOFs``
(1-based).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin._types import ComplexArray, FloatArray, IntArray
from modal_twin.array_files import mat_arrays
from modal_twin.errors import ConfigError

__all__ = ["ModesFile", "read_modes"]


@dataclass(frozen=True, slots=True)
class ModesFile:
    """Modes read from a file.

    Attributes
    ----------
    f_hz, zeta, std_f_hz : (m,) float arrays (NaN where unknown)
    shapes : (n_ch, m) complex array
    std_shapes : (n_ch, m) float array (NaN where unknown)
    measured_dofs : (n_ch,) int array, 0-based model DOFs, or None when the file does
        not say.
    dofs : tuple of dict
        Per shape entry, ``{"channel", "node", "direction"}`` where the file says (identify
        JSON), else empty.
    """

    f_hz: FloatArray
    zeta: FloatArray
    std_f_hz: FloatArray
    shapes: ComplexArray
    std_shapes: FloatArray
    measured_dofs: IntArray | None
    dofs: tuple[dict[str, Any], ...] = ()


def _json(p: Path) -> ModesFile:
    try:
        d = json.loads(p.read_text())
        modes = d["modes"]
        f = np.array([m["f_hz"] for m in modes], dtype=float)
        S = np.array([np.asarray(m["shape_re"]) + 1j * np.asarray(m["shape_im"])
                      for m in modes]).T.reshape(len(d["dofs"]), len(modes))
        z = np.array([m["zeta"] for m in modes], dtype=float)
        sf = np.array([np.nan if m.get("std_f_hz") is None else m["std_f_hz"] for m in modes],
                      dtype=float)
        md = [x.get("model_dof") for x in d["dofs"]]
    except (UnicodeDecodeError, json.JSONDecodeError, KeyError, TypeError, ValueError) as err:
        msg = f"{p}: expected a modes JSON written by `modal-twin identify` ({err!r})"
        raise ConfigError(msg) from err
    meas = np.array(md, dtype=np.int64) if all(v is not None for v in md) and md else None
    return ModesFile(f, z, sf, S, np.full(S.shape, np.nan), meas, tuple(d["dofs"]))


def _mat(p: Path) -> ModesFile:
    d = mat_arrays(p)

    def get(*keys: str) -> np.ndarray | None:
        for k in keys:
            if k in d:
                return np.asarray(d[k], dtype=float)
        return None

    lam, fr = get("lambdaExp"), get("freqExp", "test_frequency")
    S = get("psiExp_m", "psiExp", "test_mode")
    if (lam is None and fr is None) or S is None:
        keys = sorted(k for k in d if not k.startswith("__"))
        msg = (f"{p}: expected mode frequencies (lambdaExp / freqExp / test_frequency) and "
               f"shapes (psiExp_m / psiExp / test_mode), found {keys}")
        raise ConfigError(msg)
    f = (np.sqrt(lam.ravel()) / (2 * np.pi)) if lam is not None else fr.ravel()  # type: ignore[union-attr]
    slam = get("std_lambdaExp")
    sf = slam.ravel() / (8 * np.pi**2 * f) if slam is not None else np.full(f.size, np.nan)
    damp = get("dampExp")
    z = damp.ravel() if damp is not None else np.full(f.size, np.nan)
    sp_ = get("std_psiExp")
    meas = get("measDOFs")
    return ModesFile(f, z, sf, S.astype(complex), sp_ if sp_ is not None
                     else np.full(S.shape, np.nan),
                     None if meas is None else meas.ravel().astype(np.int64) - 1)


def _uff(p: Path) -> ModesFile:
    from modal_twin.io.uff import read_uff55

    d = read_uff55(p)
    S = d["shapes"]
    keep = np.flatnonzero(np.any(np.abs(S) > 0, axis=1))  # DOFs that carry a channel
    S = S[keep]
    return ModesFile(d["f_hz"], d["zeta"], np.full(d["f_hz"].size, np.nan), S,
                     np.full(S.shape, np.nan), None)


def read_modes(path: str | Path) -> ModesFile:
    """Modes of a ``.json`` (identify), ``.uff`` / ``.unv`` (dataset 55) or ``.mat`` file.

    Raises
    ------
    ConfigError
        Missing file, unknown kind or a file without modes.
    """
    p = Path(path)
    if not p.is_file():
        msg = f"{p}: no such modes file"
        raise ConfigError(msg)
    readers = {".json": _json, ".mat": _mat, ".uff": _uff, ".unv": _uff}
    reader = readers.get(p.suffix.lower())
    if reader is None:
        msg = f"{p}: unknown modes file kind {p.suffix!r}; expected one of {sorted(readers)}"
        raise ConfigError(msg)
    return reader(p)
