"""Universal File Format (UFF) with pyuff: time data, FRFs, geometry; modes and FRFs out.

Read (:func:`read_uff`):

- dataset 58 / 58b, function type 1 (time response): channels of one record (same
  sample interval and length), SI by the ordinate unit exponents and label;
- dataset 58, function types 4 (FRF), 9 (PSD) and other spectra: kept as spectra;
- datasets 15 / 2411 (nodes), 18 / 2420 (coordinate systems), 82 (trace lines),
  164 / 151 (units, header): the test geometry.

Other dataset types are listed as skipped. Each time channel gets its role from its own
record (:func:`uff_role`): an excitation force (data type 13), or a channel at a reference
node / direction that a 58 record of the file names (an FRF's or a time record's
``ref_node`` / ``ref_dir``), is ``input``; a response (displacement, velocity, acceleration,
reaction force, stress, strain, sound pressure) is ``output``; a temperature is
``reference``; an unknown type cannot be told (no role: the import asks for ``--map``).
Written: dataset 58 time records (:func:`write_uff58_time`: a hammer test's force and
responses with their nodes and directions), dataset 55 (modes, with the geometry as
15 / 82 and the channel names in the id lines; :func:`read_uff55` reads them back) and
58 (FRFs).
The 58 direction code ``rsp_dir`` (1..3 = +x..+z, -1..-3 = -x..-z, 4..6 = rotations) gives
the channel direction.
"""

from __future__ import annotations

import logging
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin._types import ComplexArray, FloatArray
from modal_twin.channels import ChannelSpec
from modal_twin.errors import ConfigError, SignalError
from modal_twin.models.array_files import check_text_file

__all__ = ["AXIS_CODES", "CHANNELS_TAG", "COHERENCE_NOTE", "SI_UNITS", "UffContents",
           "rate_from_increment", "read_uff", "read_uff55", "uff_role", "write_uff55",
           "write_uff58_frf", "write_uff58_time"]

log = logging.getLogger(__name__)

AXIS_CODES = {"x": 1, "y": 2, "z": 3, "-x": -1, "-y": -2, "-z": -3}
"""Direction label -> UFF direction code (58 ``rsp_dir``, 55 column)."""
_DIRS = {1: "x", 2: "y", 3: "z", -1: "-x", -2: "-y", -3: "-z", 4: "rx", 5: "ry", 6: "rz",
         -4: "-rx", -5: "-ry", -6: "-rz"}
# UFF specific data type codes of the ordinate (dataset 58, record 8) -> quantity
_QUANT = {8: "displacement", 11: "velocity", 12: "acceleration", 13: "force",
          21: "pressure", 1: "", 0: ""}
_UNIT_SCALE = {"m/s2": 1.0, "m/s^2": 1.0, "g": 9.80665, "mm/s2": 1e-3, "m": 1.0, "mm": 1e-3,
               "m/s": 1.0, "mm/s": 1e-3, "n": 1.0, "kn": 1e3, "pa": 1.0}
_GEOMETRY = {15, 2411, 18, 2420, 82, 164, 151}
_RESPONSE = {2: "stress", 3: "strain", 8: "displacement", 9: "reaction force",
             11: "velocity", 12: "acceleration", 15: "pressure", 21: "sound pressure"}
"""UFF 58 specific data types (record 8, field 1) of a measured response."""


def uff_role(data_type: int, label: str, at_reference: str = "") -> tuple[str, str]:
    """Role of a UFF 58 time channel from its own record (module docstring).

    Parameters
    ----------
    data_type : int
        Ordinate specific data type (record 8 field 1: 12 acceleration, 13 excitation
        force ...).
    label : str
        Ordinate axis label (``"Acceleration"``), used when the type is 0 / 1 (unknown /
        general).
    at_reference : str
        Non-empty (``"dataset 3"``) when a 58 record of the file names this channel's node and
        direction as its reference.

    Returns
    -------
    (role, why)
        ``role`` is ``""`` where the record cannot tell.
    """
    lab = label.strip().lower()
    if data_type == 13 or (data_type in (0, 1) and lab in ("force", "excitation force")):
        return "input", f"UFF 58 data type {data_type} ({label or 'excitation force'})"
    if at_reference:
        return "input", f"reference node / direction of {at_reference}"
    if data_type in _RESPONSE:
        return "output", f"UFF 58 data type {data_type} ({_RESPONSE[data_type]}): a response"
    if data_type == 5:
        return "reference", "UFF 58 data type 5 (temperature)"
    if data_type in (0, 1) and lab in {*_RESPONSE.values(), "accel"}:
        return "output", f"UFF 58 ordinate label {label!r}: a response"
    return "", f"UFF 58 data type {data_type}, label {label!r}: neither excitation nor response"


@dataclass(frozen=True, slots=True)
class UffContents:
    """What a UFF file holds, in SI where the file says its units.

    Attributes
    ----------
    time : tuple of (ChannelSpec, fs_hz, start_s, samples)
        Time-response channels (58 function type 1).
    spectra : tuple of dict
        Other 58 functions: ``{"name", "func_type", "f_hz", "data" (complex), "ref", "rsp"}``.
    geometry : dict
        ``nodes`` (id -> xyz), ``coordinate_systems``, ``trace_lines``, ``units``, ``header``.
    skipped : tuple of int
        Dataset types present but not read.
    """

    time: tuple[tuple[ChannelSpec, float, float, FloatArray], ...]
    spectra: tuple[dict[str, Any], ...]
    geometry: dict[str, Any] = field(default_factory=dict)
    skipped: tuple[int, ...] = ()


def _sets(path: Path) -> list[dict[str, Any]]:
    import pyuff

    check_text_file(path)  # pyuff reads the whole file and parses it into lists
    try:
        u = pyuff.UFF(str(path))
        types = [int(t) for t in u.get_set_types()]
    except Exception as err:
        msg = f"{path}: not a readable UFF file ({type(err).__name__}: {err})"
        raise ConfigError(msg) from err
    if not types:
        msg = f"{path}: expected UFF datasets, found none"
        raise ConfigError(msg)
    out = []
    for k, t in enumerate(types):
        if t not in (58, *_GEOMETRY):
            out.append({"type": t, "_skipped": True})
            continue
        try:
            s = u.read_sets(k)
        except Exception as err:
            msg = f"{path}: dataset {k} (type {t}) could not be read ({err})"
            raise ConfigError(msg) from err
        out.append(s)
    return out


def _time_channel(s: dict[str, Any], path: Path, k: int) -> tuple[ChannelSpec, float, float,
                                                                  FloatArray]:
    dt = float(s.get("abscissa_inc", 0.0))
    if not dt > 0:
        x = np.asarray(s["x"], dtype=float)
        dt = float(np.median(np.diff(x))) if x.size > 1 else 0.0
    if not dt > 0:
        msg = f"{path}: dataset {k} time data has no positive sample interval"
        raise SignalError(msg)
    unit = str(s.get("ordinate_axis_units_lab", "")).strip()
    quantity = _QUANT.get(int(s.get("ordinate_spec_data_type", 0)), "") or str(
        s.get("ordinate_axis_lab", "")).strip().lower() or "unknown"
    scale = _UNIT_SCALE.get(unit.lower().replace(" ", ""), 1.0)
    name = str(s.get("rsp_ent_name") or s.get("id1") or f"ch{k}").strip()
    node = int(s.get("rsp_node", 0))
    direction = _DIRS.get(int(s.get("rsp_dir", 0)), "")
    meta = (("file", path.name), ("dataset", k), ("unit_in_file", unit),
            ("id1", str(s.get("id1", ""))), ("id3", str(s.get("id3", ""))))
    spec = ChannelSpec(name, quantity, "", direction, node=str(node) if node else "",
                       meta=meta)
    raw = np.asarray(s["data"])
    if np.iscomplexobj(raw) and np.any(raw.imag != 0):
        msg = (f"{path}: dataset {k} ({name}) holds complex time samples; a record is a real "
               f"time series and no channel role takes complex data")
        raise SignalError(msg)
    data = np.real(raw).astype(np.float64) * scale
    return spec, rate_from_increment(dt), float(s.get("abscissa_min", 0.0)), data


def rate_from_increment(dt: float, digits: int = 6) -> float:
    """Sample rate of a UFF 58 record from its abscissa increment.

    Record 7 holds the increment in E13.5 (six significant digits), so 1 / 4096 s is read
    as 2.44141e-4 s and its reciprocal as 4095.99 Hz. The increment only fixes the rate to
    within the field's half last digit; where a whole number of hertz lies in that interval
    it is the rate (the one the writer most likely meant), otherwise ``1 / dt``.

    Parameters
    ----------
    dt : float
        Abscissa increment as read, s (> 0).
    digits : int
        Significant digits the field carries (6 for E13.5).

    Returns
    -------
    float
        Sample rate, Hz.
    """
    half = 0.5 * 10.0 ** (np.floor(np.log10(dt)) - (digits - 1))
    lo, hi = 1.0 / (dt + half), 1.0 / (dt - half) if dt > half else np.inf
    whole = float(np.round(1.0 / dt))
    return whole if lo <= whole <= hi else 1.0 / dt


def _geometry(sets: list[dict[str, Any]]) -> dict[str, Any]:
    g: dict[str, Any] = {"nodes": {}, "coordinate_systems": [], "trace_lines": [],
                         "units": {}, "header": {}}
    for s in sets:
        t = s["type"]
        if t in (15, 2411):
            for n, x, y, z in zip(s["node_nums"], s["x"], s["y"], s["z"], strict=True):
                g["nodes"][str(int(n))] = [float(x), float(y), float(z)]
        elif t in (18, 2420):
            for k, num in enumerate(np.atleast_1d(s.get("cs_num", []))):
                g["coordinate_systems"].append({
                    "number": int(num),
                    "origin": np.asarray(s["ref_o"])[k].tolist() if "ref_o" in s else None,
                    "x_point": np.asarray(s["x_point"])[k].tolist() if "x_point" in s else None,
                    "xz_point": np.asarray(s["xz_point"])[k].tolist()
                    if "xz_point" in s else None})
        elif t == 82:
            g["trace_lines"].append({"number": int(s["trace_num"]), "id": str(s.get("id", "")),
                                     "nodes": [int(v) for v in np.asarray(s["nodes"])]})
        elif t == 164:
            g["units"] = {k: (float(v) if isinstance(v, (int, float)) else str(v))
                          for k, v in s.items() if k != "type"}
        elif t == 151:
            g["header"] = {k: str(v) for k, v in s.items() if k != "type"}
    return g


def _with_roles(time: list[tuple[ChannelSpec, float, float, FloatArray]],
                sets: list[dict[str, Any]]) -> list[tuple[ChannelSpec, float, float, FloatArray]]:
    """Each time channel with its :func:`uff_role` (and ``role_from`` in its meta)."""
    refs: dict[tuple[int, int], int] = {}
    for k, s in enumerate(sets):
        if s["type"] == 58 and int(s.get("ref_node", 0) or 0) > 0:
            refs.setdefault((int(s["ref_node"]), int(s.get("ref_dir", 0) or 0)), k)
    out = []
    for c, fs, t0, x in time:
        m = dict(c.meta)
        s = sets[int(m["dataset"])]
        dof = (int(s.get("rsp_node", 0) or 0), int(s.get("rsp_dir", 0) or 0))
        at = f"dataset {refs[dof]}" if dof in refs and dof[0] > 0 else ""
        role, why = uff_role(int(s.get("ordinate_spec_data_type", 0) or 0),
                             str(s.get("ordinate_axis_lab", "")), at)
        m["role_from"] = f"{m['file']} dataset {m['dataset']}: {why}"
        out.append((replace(c, role=role, meta=tuple(m.items())), fs, t0, x))
    return out


def read_uff(path: str | Path) -> UffContents:
    """Read a UFF file (module docstring).

    Raises
    ------
    ConfigError
        Not a UFF file, or a dataset that pyuff cannot read.
    SignalError
        Time data without a sample interval.
    """
    p = Path(path)
    sets = _sets(p)
    time: list[tuple[ChannelSpec, float, float, FloatArray]] = []
    spectra: list[dict[str, Any]] = []
    skipped: list[int] = []
    for k, s in enumerate(sets):
        if s.get("_skipped"):
            skipped.append(int(s["type"]))
        elif s["type"] == 58 and int(s.get("func_type", 0)) == 1:
            ch = _time_channel(s, p, k)
            if ch[0].name in {t[0].name for t in time}:  # two channels at one node and dir
                ch = (replace(ch[0], name=f"{ch[0].name}#{k}"), *ch[1:])
            time.append(ch)
        elif s["type"] == 58:
            spectra.append({"name": str(s.get("id1", "")).strip(),
                            "func_type": int(s["func_type"]),
                            "f_hz": np.asarray(s["x"], dtype=float),
                            "data": np.asarray(s["data"]).astype(complex),
                            "rsp": f"{s.get('rsp_node', 0)}{_DIRS.get(s.get('rsp_dir', 0), '')}",
                            "ref": f"{s.get('ref_node', 0)}{_DIRS.get(s.get('ref_dir', 0), '')}",
                            "unit": str(s.get("ordinate_axis_units_lab", "")).strip(),
                            "note": str(s.get("id2", "")).strip()})
    time = _with_roles(time, sets)
    geo = _geometry([s for s in sets if s["type"] in _GEOMETRY and not s.get("_skipped")])
    if set(skipped) - {55}:  # modes are read by read_uff55 (import does), not skipped
        log.info("%s: dataset types %s skipped (not read)", p, sorted(set(skipped) - {55}))
    return UffContents(tuple(time), tuple(spectra), geo, tuple(skipped))


CHANNELS_TAG = "ch:"
"""Start of the UFF 55 id lines (id3..id5) that name the channels: ``name@node dir``."""
_ID_LEN = 80
_ENTRY = re.compile(r"^(?P<name>.+)@(?P<node>\d+)(?P<dir>-?r?[xyz])$")


def _channel_lines(names: Sequence[str], nodes: Sequence[int], dirs: Sequence[int]
                   ) -> tuple[list[str], int]:
    """Pack ``name@<node><dir>`` entries into three 80-character id lines.

    Returns the lines and how many channels they name (the first ones; a channel whose
    entry does not fit is read back as ``N<node><dir>``).
    """
    lines: list[str] = []
    cur = CHANNELS_TAG
    kept = 0
    for name, n, d in zip(names, nodes, dirs, strict=True):
        entry = f"{str(name).replace(' ', '_').replace(';', '_')}@{int(n)}{_DIRS.get(d, 'x')};"
        if len(cur) + len(entry) > _ID_LEN:
            lines.append(cur)
            if len(lines) == 3:
                return lines, kept
            cur = CHANNELS_TAG
            if len(cur) + len(entry) > _ID_LEN:  # a name too long for a line
                return lines, kept
        cur += entry
        kept += 1
    lines.append(cur)
    return (lines + ["NONE"] * 3)[:3], kept


def _geometry_sets(geometry: Mapping[str, Any] | None, nodes: Sequence[int]) -> list[Any]:
    """UFF 15 (nodes with coordinates) and 82 (trace lines) of a test geometry."""
    import pyuff

    g = dict(geometry or {})
    xyz = {int(k): [float(v) for v in c[:3]] for k, c in dict(g.get("nodes", {})).items()
           if str(k).lstrip("-").isdigit() and int(k) > 0}
    if not xyz:
        return []
    ids = sorted(xyz)
    out = [pyuff.prepare_15(node_nums=np.array(ids), def_cs=np.zeros(len(ids), int),
                            disp_cs=np.zeros(len(ids), int), color=np.full(len(ids), 8),
                            x=np.array([xyz[n][0] for n in ids]),
                            y=np.array([xyz[n][1] for n in ids]),
                            z=np.array([xyz[n][2] for n in ids]), return_full_dict=True)]
    for k, line in enumerate(g.get("trace_lines", [])):
        seq = [int(v) for v in line.get("nodes", [])]
        seq = [v for i, v in enumerate(seq) if i == 0 or v != seq[i - 1]]  # pyuff counts changes
        if len(seq) < 2:
            continue
        out.append(pyuff.prepare_82(trace_num=int(line.get("number", k + 1)),
                                    n_nodes=len(seq), color=0,
                                    id=str(line.get("id", "") or "NONE")[:_ID_LEN],
                                    nodes=np.array(seq), return_full_dict=True))
    units = dict(g.get("units") or {})
    if "units_code" in units:  # dataset 164 first: the lengths of the nodes above
        out.insert(0, pyuff.prepare_164(
            units_code=int(units["units_code"]),
            units_description=str(units.get("units_description", "SI"))[:20],
            temp_mode=int(units.get("temp_mode", 2)), length=float(units.get("length", 1.0)),
            force=float(units.get("force", 1.0)), temp=float(units.get("temp", 1.0)),
            temp_offset=float(units.get("temp_offset", 273.15)), return_full_dict=True))
    missing = sorted(set(nodes) - set(xyz))
    if missing:
        log.info("UFF: nodes %s carry channels but have no coordinates", missing[:10])
    return out


SI_UNITS: dict[str, Any] = {"units_code": 1, "units_description": "SI", "temp_mode": 2,
                            "length": 1.0, "force": 1.0, "temp": 1.0, "temp_offset": 273.15}
"""UFF 164 of a geometry in metres (SI: length, force and temperature factors 1)."""


def write_uff55(path: str | Path, f_hz: FloatArray, zeta: FloatArray, shapes: ComplexArray,
                nodes: list[int], dirs: list[int], names: Sequence[str] | None = None,
                geometry: Mapping[str, Any] | None = None) -> Path:
    """Write modes as UFF 55 (complex eigenvalue, one dataset per mode), with their geometry.

    ``shapes`` is ``(n_ch, n_modes)``; channel ``c`` sits at ``nodes[c]`` in direction
    ``dirs[c]`` (:data:`AXIS_CODES`; a negative code flips the sign). Nodes with several
    channels get them in their columns. ``names`` (the channels' names) go into the id
    lines id3..id5 (``ch:name@<node><dir>;...``, as many as fit in 3 x 80 characters);
    ``geometry`` (``nodes``: id -> xyz, ``trace_lines``, as :func:`read_uff` gives) is
    written first as UFF 15 and 82. :func:`read_uff55` reads all of it back.
    """
    import pyuff

    p = Path(path)
    un = sorted(set(nodes))
    if any(n < 1 for n in un):
        msg = f"UFF 55 node numbers must be positive, got {un[:5]}"
        raise ConfigError(msg)
    ids, kept = _channel_lines(list(names) if names is not None else
                               [f"N{n}{_DIRS.get(d, 'x')}" for n, d in zip(nodes, dirs,
                                                                            strict=True)],
                               nodes, dirs)
    if kept < len(nodes):
        log.info("UFF 55 id lines name %d of %d channels (3 x 80 characters)", kept,
                 len(nodes))
    sets = _geometry_sets(geometry, un)
    for m in range(len(f_hz)):
        r = np.zeros((len(un), 3), complex)
        for c, (n, d) in enumerate(zip(nodes, dirs, strict=True)):
            r[un.index(n), (abs(d) - 1) % 3] = np.sign(d) * shapes[c, m]
        w = 2 * np.pi * f_hz[m]
        lam = complex(-zeta[m] * w, w * np.sqrt(max(1 - zeta[m] ** 2, 0.0)))
        sets.append(pyuff.prepare_55(
            model_type=1, id1="modal_twin modes",
            id2=f"mode {m + 1}: {f_hz[m]:.6g} Hz, zeta {zeta[m]:.4g}"[:_ID_LEN],
            id3=ids[0], id4=ids[1], id5=ids[2], analysis_type=3, data_ch=3,
            spec_data_type=12, data_type=5, n_data_per_node=3,
            node_nums=np.array(un, dtype=int), r1=r[:, 0], r2=r[:, 1], r3=r[:, 2],
            load_case=1, mode_n=m + 1, eig=lam, modal_a=0.0 + 0j,
            modal_b=0.0 + 0j))  # not the full dict: its None r4..r6 would make pyuff
        # write 6 values per node, which it cannot read back
    u = pyuff.UFF(str(p))
    u.write_sets(sets, mode="overwrite")
    return p


def _named_channels(s: Mapping[str, Any]) -> list[tuple[str, int, str]]:
    """Return the ``(name, node, direction)`` entries of a dataset 55's id lines."""
    out = []
    for key in ("id3", "id4", "id5"):
        text = str(s.get(key, "")).strip()
        if not text.startswith(CHANNELS_TAG):
            continue
        for entry in text[len(CHANNELS_TAG):].split(";"):
            hit = _ENTRY.match(entry.strip())
            if hit:
                out.append((hit["name"], int(hit["node"]), hit["dir"]))
    return out


def read_uff55(path: str | Path) -> dict[str, Any]:
    """Modes of a UFF 55 file and the geometry written with them.

    Returns ``f_hz``, ``zeta``, ``shapes`` (n_node*3, n_modes: x, y, z per node),
    ``dofs`` ((node, direction) of each row), ``channels`` (``(name, node, direction)``
    as the id lines name them, :func:`write_uff55`; then the channels whose node and
    direction are absent from the id lines, named ``N<node><dir>``, for every nonzero row),
    ``channel_shapes`` (n_channels, n_modes, signed by the direction) and ``geometry``
    (as :func:`read_uff`).

    Raises
    ------
    ConfigError
        The file holds no dataset 55, or modes on different nodes.
    """
    import pyuff

    p = Path(path)
    check_text_file(p)
    try:
        u = pyuff.UFF(str(p))
        types = [int(t) for t in u.get_set_types()]
    except Exception as err:
        msg = f"{p}: not a readable UFF file ({err})"
        raise ConfigError(msg) from err
    idx = [k for k, t in enumerate(types) if t == 55]
    if not idx:
        msg = f"{p}: expected UFF dataset 55 (modes), found types {types}"
        raise ConfigError(msg)
    try:
        geo = _geometry([u.read_sets(k) for k, t in enumerate(types) if t in _GEOMETRY])
        sets = [u.read_sets(k) for k in idx]
    except Exception as err:
        msg = f"{p}: a dataset could not be read ({type(err).__name__}: {err})"
        raise ConfigError(msg) from err
    f, z, cols = [], [], []
    nn = np.asarray(sets[0]["node_nums"]).astype(int)
    for s in sets:
        if int(s.get("analysis_type", 0)) == 3:
            lam = complex(s["eig"])
            wn = abs(lam)
            f.append(wn / (2 * np.pi))
            z.append(-lam.real / wn if wn > 0 else 0.0)
        else:
            f.append(float(s.get("freq", 0.0)))
            z.append(float(s.get("modal_damp_vis", 0.0)))
        if not np.array_equal(np.asarray(s["node_nums"]).astype(int), nn):
            msg = f"{p}: the modes of dataset 55 are given on different nodes"
            raise ConfigError(msg)
        cols.append(np.column_stack([s["r1"], s["r2"], s["r3"]]).ravel())
    shapes = np.column_stack(cols).astype(complex)
    dofs = [(int(n), d) for n in nn for d in ("x", "y", "z")]
    row = {dof: i for i, dof in enumerate(dofs)}
    chans = [c for c in _named_channels(sets[0]) if (c[1], c[2].lstrip("-")) in row]
    named = {(c[1], c[2].lstrip("-")) for c in chans}
    chans += [(f"N{n}{d}", n, d) for i, (n, d) in enumerate(dofs)
              if (n, d) not in named and np.any(np.abs(shapes[i]) > 0)]
    ch_shapes = np.array([(-1.0 if d.startswith("-") else 1.0) * shapes[row[(n, d.lstrip("-"))]]
                          for _, n, d in chans]).reshape(len(chans), len(sets))
    return {"f_hz": np.array(f), "zeta": np.array(z), "shapes": shapes, "dofs": dofs,
            "channels": chans, "channel_shapes": ch_shapes, "geometry": geo}


_TIME_TYPES = {"force": (13, "N"), "acceleration": (12, "m/s2"), "velocity": (11, "m/s"),
               "displacement": (8, "m")}
"""Quantity -> UFF 58 ordinate data type and unit label (record 9 / 10) written."""


def write_uff58_frf(path: str | Path, f_hz: FloatArray, H: ComplexArray,
                    rsp: list[tuple[int, int]], ref: list[tuple[int, int]],
                    rsp_quantity: Sequence[str] | None = None,
                    ref_quantity: Sequence[str] | None = None,
                    names: tuple[Sequence[str], Sequence[str]] | None = None,
                    geometry: Mapping[str, Any] | None = None,
                    coherence: FloatArray | None = None, averages: int = 0) -> Path:
    """Write FRFs ``H (n_out, n_in, n_f)`` as UFF 58 function type 4.

    ``coherence`` (``(n_out, n_f)``: each output's multiple coherence with the inputs) is
    written after the FRFs as function type 6 (coherence; pyuff writes no type 26, multiple
    coherence: id line 1 says which), at the output's node and direction, reference node
    0, id line 2 ``H1 over <averages> averages of <n_in> inputs`` (:data:`COHERENCE_NOTE`).

    ``geometry`` (``nodes``: id -> xyz, ``trace_lines``, ``units``; as :func:`write_uff55`)
    is written first as UFF 164, 15 and 82.

    ``names`` (the outputs' and the inputs' channel names) go into id lines 3 and 4
    (``rsp <name>``, ``ref <name>``, 80 characters at most), so another tool shows which
    channel each node and direction is.

    ``rsp[o]`` / ``ref[i]`` are (node, direction code) of output o / input i. The ordinate
    numerator's specific data type (record 9) is output o's quantity, the denominator's
    (record 10) input i's: by default acceleration over excitation force (12 / 13, an
    accelerance); a base-driven record's FRF of acceleration over ground acceleration says
    12 / 12. A quantity without a code is written as 0 (unknown).
    """
    import pyuff

    n_q = rsp_quantity if rsp_quantity is not None else ["acceleration"] * len(rsp)
    d_q = ref_quantity if ref_quantity is not None else ["force"] * len(ref)
    if len(n_q) != len(rsp) or len(d_q) != len(ref):
        msg = (f"write_uff58_frf: {len(rsp)} outputs / {len(ref)} inputs, "
               f"{len(n_q)} / {len(d_q)} quantities")
        raise SignalError(msg)
    if names is not None and (len(names[0]) != len(rsp) or len(names[1]) != len(ref)):
        msg = (f"write_uff58_frf: {len(rsp)} outputs / {len(ref)} inputs, "
               f"{len(names[0])} / {len(names[1])} names")
        raise SignalError(msg)
    p = Path(path)
    u = pyuff.UFF(str(p))
    sets = _geometry_sets(geometry, sorted({n for n, _ in [*rsp, *ref]}))
    for o, (rn, rd) in enumerate(rsp):
        num_type, num_unit = _TIME_TYPES.get(n_q[o], (0, "NONE"))
        for i, (qn, qd) in enumerate(ref):
            den_type, den_unit = _TIME_TYPES.get(d_q[i], (0, "NONE"))
            sets.append(pyuff.prepare_58(
                binary=0, id1=f"FRF {rn}{_DIRS.get(rd, '')}/{qn}{_DIRS.get(qd, '')}",
                id2="modal_twin H1",
                id3=f"rsp {names[0][o]}"[:_ID_LEN] if names is not None else "NONE",
                id4=f"ref {names[1][i]}"[:_ID_LEN] if names is not None else "NONE", id5="NONE",
                func_type=4, ver_num=0, load_case_id=0, rsp_ent_name=f"N{rn}", rsp_node=rn,
                rsp_dir=rd, ref_ent_name=f"N{qn}", ref_node=qn, ref_dir=qd,
                ord_data_type=6, num_pts=len(f_hz), abscissa_spacing=1,
                abscissa_min=float(f_hz[0]), abscissa_inc=float(f_hz[1] - f_hz[0]),
                z_axis_value=0.0, abscissa_spec_data_type=18, abscissa_len_unit_exp=0,
                abscissa_force_unit_exp=0, abscissa_temp_unit_exp=0,
                abscissa_axis_units_lab="Hz", ordinate_spec_data_type=num_type,
                ordinate_len_unit_exp=0, ordinate_force_unit_exp=0, ordinate_temp_unit_exp=0,
                ordinate_axis_units_lab=num_unit, orddenom_spec_data_type=den_type,
                orddenom_len_unit_exp=0, orddenom_force_unit_exp=0, orddenom_temp_unit_exp=0,
                orddenom_axis_units_lab=den_unit, z_axis_spec_data_type=0, z_axis_len_unit_exp=0,
                z_axis_force_unit_exp=0, z_axis_temp_unit_exp=0, z_axis_axis_units_lab="NONE",
                data=np.asarray(H[o, i], dtype=complex), x=np.asarray(f_hz, dtype=float),
                return_full_dict=True))
    if coherence is not None:
        coh = np.asarray(coherence, dtype=float)
        if coh.shape != (len(rsp), len(f_hz)):
            msg = (f"write_uff58_frf: coherence of shape {coh.shape}, expected "
                   f"{(len(rsp), len(f_hz))}")
            raise SignalError(msg)
        for o, (rn, rd) in enumerate(rsp):
            sets.append(pyuff.prepare_58(
                binary=0, id1=f"multiple coherence {rn}{_DIRS.get(rd, '')}",
                id2=COHERENCE_NOTE.format(averages=int(averages), n_in=len(ref)),
                id3=f"rsp {names[0][o]}"[:_ID_LEN] if names is not None else "NONE",
                id4="NONE", id5="NONE", func_type=6, ver_num=0, load_case_id=0,
                rsp_ent_name=f"N{rn}", rsp_node=rn, rsp_dir=rd, ref_ent_name="NONE",
                ref_node=0, ref_dir=0, ord_data_type=4, num_pts=len(f_hz),
                abscissa_spacing=1, abscissa_min=float(f_hz[0]),
                abscissa_inc=float(f_hz[1] - f_hz[0]), z_axis_value=0.0,
                abscissa_spec_data_type=18, abscissa_axis_units_lab="Hz",
                ordinate_spec_data_type=0, ordinate_axis_units_lab="NONE",
                orddenom_spec_data_type=0, orddenom_axis_units_lab="NONE",
                z_axis_spec_data_type=0, z_axis_axis_units_lab="NONE",
                **{f"{a}_{q}_unit_exp": 0 for a in ("abscissa", "ordinate", "orddenom",
                                                    "z_axis") for q in ("len", "force", "temp")},
                data=coh[o], x=np.asarray(f_hz, dtype=float), return_full_dict=True))
    u.write_sets(sets, mode="overwrite")
    return p


COHERENCE_NOTE = "H1 over {averages} averages of {n_in} inputs"
"""Id line 2 of a multiple coherence :func:`write_uff58_frf` writes (the estimate's bias
depends on both: :func:`~modal_twin.identification.record.debiased_coherence`)."""


def write_uff58_time(path: str | Path, channels: Sequence[ChannelSpec], fs_hz: float,
                     data: FloatArray, geometry: Mapping[str, Any] | None = None) -> Path:
    """Write time records (UFF 58 ASCII, function type 1), one per channel, in SI.

    ``geometry`` (as :func:`write_uff58_frf`) is written first as UFF 164, 15 and 82.

    Each record's response node is the channel's ``node`` (its index + 1 when not a number),
    its direction the channel's (``+x`` when not given), its data type the quantity's
    (13 force, 12 acceleration, 11 velocity, 8 displacement; 0 otherwise), so that
    :func:`read_uff` gives back name, node, direction, quantity and role.
    """
    import pyuff

    x = np.atleast_2d(np.asarray(data, dtype=float))
    if x.shape[0] != len(channels):
        msg = f"write_uff58_time: {len(channels)} channels, data of shape {x.shape}"
        raise SignalError(msg)
    nodes = [int(c.node) if c.node.isdigit() and int(c.node) > 0 else k + 1
             for k, c in enumerate(channels)]
    sets = _geometry_sets(geometry, sorted(set(nodes)))
    for k, c in enumerate(channels):
        node = nodes[k]
        dtype, unit = _TIME_TYPES.get(c.quantity, (0, "SI"))
        sets.append(pyuff.prepare_58(
            binary=0, id1=c.name, id2=c.quantity, id3="NONE", id4="NONE", id5="NONE",
            func_type=1, ver_num=0, load_case_id=0, rsp_ent_name=c.name, rsp_node=node,
            rsp_dir=AXIS_CODES.get(c.direction, 1), ref_ent_name="NONE", ref_node=0,
            ref_dir=0, ord_data_type=4, num_pts=x.shape[1], abscissa_spacing=1,
            abscissa_min=0.0, abscissa_inc=1.0 / fs_hz, z_axis_value=0.0,
            abscissa_spec_data_type=17, abscissa_len_unit_exp=0, abscissa_force_unit_exp=0,
            abscissa_temp_unit_exp=0, abscissa_axis_units_lab="s",
            ordinate_spec_data_type=dtype, ordinate_len_unit_exp=0,
            ordinate_force_unit_exp=0, ordinate_temp_unit_exp=0,
            ordinate_axis_units_lab=unit, orddenom_spec_data_type=0, orddenom_len_unit_exp=0,
            orddenom_force_unit_exp=0, orddenom_temp_unit_exp=0,
            orddenom_axis_units_lab="NONE", z_axis_spec_data_type=0, z_axis_len_unit_exp=0,
            z_axis_force_unit_exp=0, z_axis_temp_unit_exp=0, z_axis_axis_units_lab="NONE",
            data=x[k], x=np.arange(x.shape[1]) / fs_hz, return_full_dict=True))
    p = Path(path)
    pyuff.UFF(str(p)).write_sets(sets, mode="overwrite")
    return p
