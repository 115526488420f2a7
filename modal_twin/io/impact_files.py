"""A hammer test's result on disk: the FRF matrix as UFF 58 and the hits' verdicts as YAML.

Written into a folder (a run's ``impact/``) under fixed names, each to a temporary path
and renamed, so a reader never sees half a file; :func:`read_frf_matrix` reads the FRF
matrix back (any UFF 58 file of FRFs, function type 4), :func:`read_window_tau` the
exponential window the FRFs were taken with, and :func:`frf_modes_document` writes the
modes identified from them as a ``modes.json`` that ``update`` reads.
"""

from __future__ import annotations

import os
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from modal_twin._types import ComplexArray, FloatArray
from modal_twin.acquisition.hammer_test import HammerResult
from modal_twin.channels import ChannelSpec
from modal_twin.errors import ConfigError, SignalError
from modal_twin.io.uff import AXIS_CODES, SI_UNITS, UffContents, read_uff, write_uff58_frf

__all__ = ["FRF_FILE", "SUMMARY_FILE", "channel_geometry", "dof_codes", "frf_modes_document",
           "hit_summary_lines", "measured_points_geometry", "read_frf_coherence",
           "read_frf_matrix", "read_window_tau", "structure_geometry", "write_hammer_result"]

FRF_FILE = "frf.uff"
SUMMARY_FILE = "hits.yaml"


def dof_codes(channels: Sequence[ChannelSpec]) -> list[tuple[int, int]]:
    """(node, UFF direction code) of each channel: its node, else its index + 1; +x if unknown."""
    out = []
    for k, c in enumerate(channels):
        node = int(c.node) if c.node.isdigit() and int(c.node) > 0 else k + 1
        out.append((node, AXIS_CODES.get(c.direction, 1)))
    return out


def channel_geometry(channels: Sequence[ChannelSpec]) -> dict[str, Any] | None:
    """Test geometry of the channels that carry a position: their UFF nodes at it, in metres.

    Nodes only (no trace lines); None when no channel has a position.
    """
    nodes = {str(n): [float(v) for v in c.position_m]
             for c, (n, _) in zip(channels, dof_codes(channels), strict=True)
             if any(v != 0.0 for v in c.position_m)}
    return {"nodes": nodes, "trace_lines": [], "units": dict(SI_UNITS)} if nodes else None


def measured_points_geometry(node_xyz: np.ndarray, measured: Sequence[str],
                             outline: Sequence[int]) -> dict[str, Any]:
    """Test geometry of the measured nodes: their model coordinates (m) and trace lines.

    ``node_xyz`` rows: (node, x, y, z) (a matrix model's ``node_xyz``,
    :func:`~modal_twin.models.tracking_frame.frame_matrices`); ``outline``: node numbers
    joined in order (0 lifts the pen; a frame file's ``trace_nodes``). Each piece of the
    outline becomes a trace line through the measured nodes in its order (closed where the
    piece is), so it draws the structure through the points measured.

    Raises
    ------
    ConfigError
        A measured node without coordinates.
    """
    xyz = {int(r[0]): [float(v) for v in r[1:4]] for r in np.asarray(node_xyz)}
    ids = sorted({int(m) for m in measured if str(m).isdigit()})
    missing = [n for n in ids if n not in xyz]
    if missing:
        msg = f"nodes {missing} are measured but have no coordinates in the model"
        raise ConfigError(msg)
    pieces: list[list[int]] = [[]]
    for n in (int(v) for v in outline):
        if n == 0:
            pieces.append([])
        else:
            pieces[-1].append(n)
    lines: list[dict[str, Any]] = []
    for piece in pieces:
        seq = [n for n in piece if n in ids]
        if len(seq) > 2 and seq[0] != seq[-1] and piece[0] == piece[-1]:
            seq.append(seq[0])
        if len(set(seq)) > 1:
            lines.append({"number": len(lines) + 1, "id": "frame through the measured nodes"
                          if len(pieces) == 1 else f"line {len(lines) + 1} through the "
                          "measured nodes", "nodes": seq})
    return {"nodes": {str(n): xyz[n] for n in ids}, "trace_lines": lines,
            "units": dict(SI_UNITS)}


def structure_geometry(structure: str | Path, channels: Sequence[ChannelSpec]
                       ) -> dict[str, Any] | None:
    """Test geometry of ``channels`` on the structure file a rig names.

    A matrix model or frame file with node coordinates (``node_xyz``, and ``trace_nodes``
    for the lines): the channels' nodes there (:func:`measured_points_geometry`); any other
    structure: the channels' own positions (:func:`channel_geometry`, None without).
    """
    from modal_twin.models.frame_file import is_frame_file
    from modal_twin.models.matrix_model import MATRIX_SUFFIXES, load_matrix_model

    p = Path(structure)
    if is_frame_file(p) or p.suffix.lower() in MATRIX_SUFFIXES:
        mm = load_matrix_model(p)
        if mm.node_xyz is not None:
            return measured_points_geometry(
                mm.node_xyz, [c.node for c in channels],
                mm.trace_nodes.tolist() if mm.trace_nodes is not None else [])
    return channel_geometry(channels)


def write_hammer_result(folder: str | Path, res: HammerResult,
                        geometry: dict[str, Any] | None = None) -> tuple[Path, Path]:
    """Write ``frf.uff`` (UFF 58, function type 4) and ``hits.yaml`` into ``folder``.

    The FRFs are written from the first line above 0 Hz, after the test geometry (UFF 164,
    15, 82: ``geometry``, else the channels' positions, :func:`channel_geometry`);
    ``hits.yaml`` lists the counts, each point's hits with verdict and reason, and the
    channels' UFF node / direction.
    """
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    keep = res.f_hz > 0
    frf_path = out / FRF_FILE
    tmp = out / f".{FRF_FILE}.tmp"
    rsp, ref = dof_codes(res.outputs), dof_codes(res.inputs)
    write_uff58_frf(tmp, res.f_hz[keep], res.H[:, :, keep], rsp, ref,
                    [c.quantity for c in res.outputs], [c.quantity for c in res.inputs],
                    names=([c.name for c in res.outputs], [c.name for c in res.inputs]),
                    geometry=geometry if geometry is not None
                    else channel_geometry([*res.outputs, *res.inputs]))
    os.replace(tmp, frf_path)
    summary = {
        "estimator": res.estimator, "block_s": res.block_s,
        "tau_s": res.per_point[0].tau_s if res.per_point else None,
        "hits_averaged": res.n_accepted, "hits_rejected": res.n_rejected,
        "outputs": [{"name": c.name, "node": n, "dir": d}
                    for c, (n, d) in zip(res.outputs, rsp, strict=True)],
        "points": [{"name": c.name, "node": n, "dir": d, "averaged": p.n_averages,
                    "min_coherence": float(np.min(p.coherence[:, keep])) if keep.any() else 0.0,
                    "hits": [{"start_sample": h.start, "accepted": h.accepted,
                              "reason": h.reason, "peak_n": round(h.peak_n, 6)}
                             for h in p.hits]}
                   for c, (n, d), p in zip(res.inputs, ref, res.per_point, strict=True)],
    }
    sum_path = out / SUMMARY_FILE
    tmp2 = out / f".{SUMMARY_FILE}.tmp"
    tmp2.write_text(yaml.safe_dump(summary, sort_keys=False))
    os.replace(tmp2, sum_path)
    return frf_path, sum_path


_PLACE = re.compile(r"^(?P<node>\d+)(?P<dir>-?r?[xyz])$")


def _place(text: str, where: str) -> tuple[str, str]:
    m = _PLACE.match(text)
    if m is None:
        msg = f"{where}: a FRF at {text!r}, expected a node and direction (like 402z)"
        raise ConfigError(msg)
    return m["node"], m["dir"]


def read_frf_matrix(path: str | Path, contents: UffContents | None = None
                    ) -> tuple[FloatArray, ComplexArray, list[tuple[str, str]],
                               list[tuple[str, str]]]:
    """FRF matrix of a UFF 58 file (function type 4): ``f_hz, H (n_out, n_in, n_f)``.

    With the (node, direction) of each response and of each reference (hit point), in the
    order of first appearance. ``contents``: the file as :func:`read_uff` read it already
    (a caller that also wants its geometry reads it once).

    Raises
    ------
    ConfigError
        No FRF in the file, a FRF without node and direction, or an incomplete matrix
        (a response / reference pair missing, repeated, or on other frequency lines).
    """
    frfs = [s for s in (contents or read_uff(path)).spectra if s["func_type"] == 4]
    if not frfs:
        msg = (f"{path}: no FRF (UFF 58 function type 4) in the file; time records of a "
               "hammer test go through `modal-twin import` and `modal-twin impact` first")
        raise ConfigError(msg)
    outs: list[tuple[str, str]] = []
    ins: list[tuple[str, str]] = []
    cells: dict[tuple[int, int], Any] = {}
    f = np.asarray(frfs[0]["f_hz"], dtype=float)
    for s in frfs:
        o, i = _place(s["rsp"], str(path)), _place(s["ref"], str(path))
        for lst, v in ((outs, o), (ins, i)):
            if v not in lst:
                lst.append(v)
        key = (outs.index(o), ins.index(i))
        if key in cells or s["f_hz"].shape != f.shape or not np.allclose(s["f_hz"], f):
            msg = (f"{path}: FRF {s['rsp']}/{s['ref']} repeated or on other frequency lines "
                   "than the first")
            raise ConfigError(msg)
        cells[key] = s["data"]
    if len(cells) != len(outs) * len(ins):
        msg = (f"{path}: {len(cells)} FRFs, expected every one of {len(outs)} responses x "
               f"{len(ins)} references")
        raise ConfigError(msg)
    H = np.zeros((len(outs), len(ins), f.size), dtype=complex)
    for (ko, ki), d in cells.items():
        H[ko, ki] = d
    if not np.all(np.isfinite(H)):
        msg = f"{path}: FRFs with NaN or inf values"
        raise SignalError(msg)
    return f, H, outs, ins


def read_frf_coherence(contents: UffContents, outputs: Sequence[tuple[str, str]],
                       f_hz: FloatArray) -> tuple[FloatArray, int, int] | None:
    """Each output's multiple coherence a FRF file carries (UFF 58 function type 6).

    As :func:`~modal_twin.io.uff.write_uff58_frf` writes it (``export frf``): returns
    ``(coherence (n_out, n_f), averages, n_in)`` in the order of ``outputs`` (the FRF
    matrix's responses), or None when the file lacks one for some output, its lines differ
    from the FRFs' or its id line 2 does not name the averages.
    """
    note = re.compile(r"over (\d+) averages of (\d+) inputs")
    got: dict[tuple[str, str], tuple[Any, int, int]] = {}
    for s in contents.spectra:
        m = note.search(str(s.get("note", "")))
        if s["func_type"] != 6 or m is None or not _PLACE.match(s["rsp"]):
            continue
        if s["f_hz"].shape != np.shape(f_hz) or not np.allclose(s["f_hz"], f_hz):
            return None
        got[_place(s["rsp"], "coherence")] = (np.real(s["data"]), int(m[1]), int(m[2]))
    if not outputs or any(o not in got for o in outputs):
        return None
    first = got[outputs[0]]
    return (np.array([got[o][0] for o in outputs], dtype=float), first[1], first[2])


def read_window_tau(frf_file: str | Path) -> float | None:
    """Time constant of the exponential window of a hammer test's FRFs, from ``hits.yaml``.

    The summary written beside ``frf.uff`` (:func:`write_hammer_result`); None when there is
    none or it names no window.
    """
    p = Path(frf_file).parent / SUMMARY_FILE
    if not p.is_file():
        return None
    from modal_twin.yaml_files import read_yaml

    tau = read_yaml(p, "hits summary").get("tau_s")
    return float(tau) if isinstance(tau, (int, float)) and tau > 0 else None


def frf_modes_document(f_hz: FloatArray, zeta: FloatArray, shapes: ComplexArray,
                       outputs: Sequence[tuple[str, str, str]], source: str,
                       geometry: dict[str, Any] | None = None) -> dict[str, Any]:
    """Return modes identified from FRFs as a ``modes.json`` document (``update`` reads it).

    ``outputs``: (channel name, node, direction) of each shape entry; ``geometry`` the test
    geometry (``nodes``: UFF node -> xyz, ``trace_lines``), kept as ``identify`` keeps it.
    """
    return {"method": "polymax", "source": source, "geometry": geometry,
            "dofs": [{"channel": name, "node": int(node) if node.isdigit() else None,
                      "node_label": node, "direction": d} for name, node, d in outputs],
            "modes": [{"f_hz": float(f_hz[k]), "zeta": float(zeta[k]), "std_f_hz": None,
                       "shape_re": shapes[:, k].real.tolist(),
                       "shape_im": shapes[:, k].imag.tolist()}
                      for k in range(np.size(f_hz))]}


def hit_summary_lines(folder: str | Path) -> list[str]:
    """Return the counts of a hammer test in ``folder`` and one line per rejected hit.

    Empty when the folder holds no ``hits.yaml`` (not an impact test); a summary that does
    not read is said in one line.
    """
    p = Path(folder) / SUMMARY_FILE
    if not p.is_file():
        return []
    from modal_twin.yaml_files import read_yaml

    try:
        doc = read_yaml(p, "hits summary")
        out = [f"impact: {doc['hits_averaged']} hits averaged, {doc['hits_rejected']} "
               f"rejected; FRF matrix {Path(folder) / FRF_FILE}, every hit's verdict {p}"]
        out += [f"  rejected at {pt['name']}, sample {h['start_sample']}: {h['reason']}"
                for pt in doc["points"] for h in pt["hits"] if not h["accepted"]]
    except (ConfigError, KeyError, TypeError) as err:
        return [f"impact: {p} does not read ({type(err).__name__}: {err})"]
    return out
