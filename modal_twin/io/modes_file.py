"""Identified modes in files: written here (``identify`` JSON and UFF 55) and read here.

:func:`write_modes` writes the modes of
:func:`~modal_twin.identification.record.identify_record` as ``modes.json`` and
``modes.uff`` (UFF 55); :func:`read_modes` reads those, or a MATLAB ``.mat``, into a
:class:`ModesFile`. ``.mat`` variables (Structural-Model-Updating
conventions): frequencies from ``lambdaExp`` (``(2 pi f)^2``), ``freqExp`` or
``test_frequency`` (Hz); shapes ``psiExp_m`` / ``psiExp`` / ``test_mode`` (channels x
modes); optional ``std_lambdaExp``, ``std_psiExp``, ``dampExp`` and ``measDOFs``
(1-based).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin._types import ComplexArray, FloatArray, IntArray
from modal_twin.errors import ConfigError
from modal_twin.identification.metrics import complexity, mpc
from modal_twin.identification.record import RecordModes
from modal_twin.models.array_files import mat_arrays
from modal_twin.yaml_files import read_text

__all__ = ["ModesFile", "read_geometry_files", "read_modes", "uff_modes_document",
           "uff_nodes", "write_modes",
           "write_modes_uff"]


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
        Per shape entry, ``{"channel", "node", "node_label", "direction"}`` where the file
        says (identify JSON, UFF 55), else empty.
    geometry : dict, optional
        The test geometry written with the modes (``nodes``: UFF node number -> xyz,
        ``trace_lines``), when there is one.
    """

    f_hz: FloatArray
    zeta: FloatArray
    std_f_hz: FloatArray
    shapes: ComplexArray
    std_shapes: FloatArray
    measured_dofs: IntArray | None
    dofs: tuple[dict[str, Any], ...] = ()
    geometry: dict[str, Any] | None = None


def _json(p: Path) -> ModesFile:
    try:
        d = json.loads(read_text(p, "modes file"))  # bounded before parsing
        modes = d["modes"]
        f = np.array([m["f_hz"] for m in modes], dtype=float)
        S = np.array([np.asarray(m["shape_re"], dtype=float)  # null: not measured, NaN
                      + 1j * np.asarray(m["shape_im"], dtype=float)
                      for m in modes]).T.reshape(len(d["dofs"]), len(modes))
        z = np.array([m["zeta"] for m in modes], dtype=float)
        sf = np.array([np.nan if m.get("std_f_hz") is None else m["std_f_hz"] for m in modes],
                      dtype=float)
        md = [x.get("model_dof") for x in d["dofs"]]
    except ConfigError:
        raise
    except (UnicodeDecodeError, json.JSONDecodeError, KeyError, TypeError, ValueError) as err:
        msg = f"{p}: expected a modes JSON written by `modal-twin identify` ({err!r})"
        raise ConfigError(msg) from err
    meas = np.array(md, dtype=np.int64) if all(v is not None for v in md) and md else None
    geo = d.get("geometry") if isinstance(d.get("geometry"), dict) else None
    return ModesFile(f, z, sf, S, np.full(S.shape, np.nan), meas, tuple(d["dofs"]), geo)


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
    S = d["channel_shapes"]
    dofs = tuple({"channel": name, "node": n, "node_label": str(n), "direction": dr}
                 for name, n, dr in d["channels"])
    geo = d["geometry"] if d["geometry"].get("nodes") else None
    return ModesFile(d["f_hz"], d["zeta"], np.full(d["f_hz"].size, np.nan), S,
                     np.full(S.shape, np.nan), None, dofs, geo)


def uff_modes_document(path: str | Path) -> dict[str, Any]:
    """Return the modes of a UFF 55 file as a ``modes.json`` document (``import``)."""
    m = _uff(Path(path))
    return {"method": f"UFF 55 ({Path(path).name})", "dofs": list(m.dofs),
            "geometry": m.geometry, "inputs": [], "notes": [], "not_reported": [],
            "modes": [{"f_hz": float(m.f_hz[k]), "std_f_hz": None, "zeta": float(m.zeta[k]),
                       "shape_re": m.shapes[:, k].real.tolist(),
                       "shape_im": m.shapes[:, k].imag.tolist()} for k in range(m.f_hz.size)]}


def read_modes(path: str | Path) -> ModesFile:
    """Modes of a ``.json`` (identify), ``.uff`` / ``.unv`` (dataset 55) or ``.mat`` file.

    A JSON file is bounded before parsing (:func:`modal_twin.yaml_files.read_text`), a
    ``.mat`` or UFF file by what it unpacks to (:mod:`modal_twin.models.array_files`).

    Raises
    ------
    ConfigError
        Missing file, unknown kind, too large, or a file without modes.
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


def uff_nodes(labels: list[str]) -> dict[str, int]:
    """Return the UFF node number of each node label.

    The label itself when every label is a positive integer below 1e9 (nodes of an
    imported UFF geometry), else 1.. in sorted order.
    """
    un = sorted(set(labels))
    if un and all(x.isdigit() and 0 < int(x) < 10**9 for x in un):  # UFF: 10 columns
        return {x: int(x) for x in un}
    return {x: k + 1 for k, x in enumerate(un)}


def read_geometry_files(folder: str | Path) -> dict[str, Any]:
    """Return the test geometry ``modal-twin import`` kept in a bag (``geometry_*.json``, merged).

    Returns ``{"nodes": {id: xyz}, "trace_lines": [...]}`` (empty when there is none), and
    ``units`` (the first file's UFF 164) when a file has them.
    """
    g: dict[str, Any] = {"nodes": {}, "trace_lines": []}
    for f in sorted(Path(folder).glob("geometry_*.json")):
        try:
            d = json.loads(read_text(f, "geometry file"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
            msg = f"{f}: not a geometry JSON written by `modal-twin import` ({err})"
            raise ConfigError(msg) from err
        g["nodes"].update({str(k): v for k, v in dict(d.get("nodes", {})).items()})
        g["trace_lines"] += list(d.get("trace_lines", []))
        if isinstance(d.get("units"), dict) and d["units"] and "units" not in g:
            g["units"] = dict(d["units"])
    return g


def modes_document(rec: RecordModes, geometry: dict[str, Any] | None = None) -> dict[str, Any]:
    """Return the ``modes.json`` content of an identification (what :func:`read_modes` reads).

    Each shape entry's ``node`` is its UFF node number (:func:`uff_nodes`). ``geometry``
    (the bag's, :func:`read_geometry_files`) is kept when the node numbers are its node ids,
    and the channels' own positions (``position_m``) fill nodes it lacks.
    """
    mm, s, diag = rec.modes, rec.settings, rec.diagram
    mp, cx = mpc(mm.shapes), complexity(mm.shapes)
    labels = [c.node or c.location or c.name for c in rec.outputs]
    number = uff_nodes(labels)
    dofs = [{"channel": c.name, "node": number[lab], "node_label": c.node or c.location,
             "direction": c.direction} for c, lab in zip(rec.outputs, labels, strict=True)]
    by_label = all(str(v) == k for k, v in number.items())
    g = dict(geometry or {}) if by_label else {}
    nodes = {str(k): list(v) for k, v in dict(g.get("nodes", {})).items()}
    for c, lab in zip(rec.outputs, labels, strict=True):
        if str(number[lab]) not in nodes and any(v != 0.0 for v in c.position_m):
            nodes[str(number[lab])] = [float(v) for v in c.position_m]
    geo = {"nodes": nodes, "trace_lines": list(g.get("trace_lines", []))} if nodes else None
    return {"method": rec.method,
            "settings": {"band_hz": list(s.band_hz), "decimation": s.factor,
                         "fs_hz": s.fs_hz, "block_rows": s.block_rows,
                         "orders": list(s.orders)},
            "thresholds": {"rel_tol_f": diag.rel_tol_f, "rel_tol_zeta": diag.rel_tol_zeta,
                           "mac_min": diag.mac_min},
            "inputs": [c.name for c in rec.inputs], "dofs": dofs, "geometry": geo,
            "notes": list(rec.notes),
            "not_reported": [{"f_hz": d.f_hz, "zeta": d.zeta, "n_poles": d.n_poles,
                              "orders": list(d.orders), "reason": d.reason}
                             for d in rec.dropped],
            "modes": [{"f_hz": float(mm.f_hz[k]), "std_f_hz": float(mm.std_f_hz[k]),
                       "zeta": float(mm.zeta[k]), "std_zeta": float(mm.std_zeta[k]),
                       "mpc": float(mp[k]), "complexity": float(cx[k]),
                       "order": int(mm.mode_orders[k]), "support": int(mm.n_support[k]),
                       "shape_re": mm.shapes[:, k].real.tolist(),
                       "shape_im": mm.shapes[:, k].imag.tolist()}
                      for k in range(mm.f_hz.size)]}


def write_modes(folder: str | Path, rec: RecordModes,
                geometry: dict[str, Any] | None = None, *, force: bool = True) -> list[Path]:
    """Write ``modes.json`` and ``modes.uff`` (UFF 55) of ``rec`` into ``folder``.

    ``geometry`` is the bag's test geometry (:func:`read_geometry_files`); both files carry
    it with the channels' nodes, directions and names (:func:`write_uff55`). Each file is
    written to a temporary name and renamed: an interrupted write leaves the previous file
    or none. Without ``force`` an existing file is refused.
    """
    from modal_twin.io.imported import atomic_file

    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    doc = modes_document(rec, geometry)
    text = json.dumps(doc, indent=1).replace("NaN", "null")
    with atomic_file(out / "modes.json", force=force) as tmp:
        tmp.write_text(text)
    mm = rec.modes
    with atomic_file(out / "modes.uff", force=force) as tmp:
        tmp.unlink()
        write_modes_uff(tmp, mm.f_hz, mm.zeta, mm.shapes, doc["dofs"], doc["geometry"])
    return [out / "modes.json", out / "modes.uff"]


def write_modes_uff(path: Path, f_hz: FloatArray, zeta: FloatArray, shapes: ComplexArray,
                    dofs: Sequence[dict[str, Any]], geometry: dict[str, Any] | None) -> Path:
    """Write modes and their ``dofs`` (``channel``, ``node``, ``direction``) as UFF 55."""
    from modal_twin.io.uff import AXIS_CODES, write_uff55

    return write_uff55(path, f_hz, zeta, shapes, [int(d["node"]) for d in dofs],
                       [AXIS_CODES.get(str(d["direction"]).lower(), 1) for d in dofs],
                       names=[str(d.get("channel") or "") or f"N{d['node']}" for d in dofs],
                       geometry=geometry)
