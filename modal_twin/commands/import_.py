"""``modal-twin import FILE... --out BAG``: measured files to a bag and its channel map.

Formats by file name: ``.uff`` / ``.unv`` (UFF 58 / 58b time data and spectra, UFF
geometry, UFF 55 modes kept as ``modes_<file>.json``), ``.zip`` / ``.v1`` / ``.v2`` /
``.smc`` (CSMIP and USGS strong-motion records, rotated to one structure frame),
``.csv`` and ``.npz`` (a channel table with units). Time channels of all files must share
the sample rate and length. Roles: a user map (``--map``) first; else the file's own
headers (strong-motion sensor locations:
:func:`modal_twin.io.channel_map.roles_from_locations`; UFF 58 data types and reference
nodes: :func:`modal_twin.io.uff.uff_role`); else :func:`modal_twin.channels.default_role`
(CSV, NPZ). The assignment is printed with the header words that decided each channel; a
channel the headers cannot tell and no map names is refused in one line (exit 2).
"""

from __future__ import annotations

import argparse
import re
import sys
from collections import Counter
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin.channels import ChannelSpec
from modal_twin.errors import ConfigError, OptionError, SignalError
from modal_twin.exit_codes import ExitCode
from modal_twin.validation import FILE_UNPACKED_MAX_BYTES, check_array_budget, check_field

__all__ = ["register", "run"]

UFF = (".uff", ".unv")
STRONG_MOTION = (".zip", ".v1", ".v2", ".smc")
LARGE_MB = 2.0
"""Files and records from this size on get progress lines (stderr)."""
PRINT_ROLES_MAX = 64
"""Up to this many channels the roles are printed one line each, above it one per reason."""


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``import`` to the sub-commands."""
    p = sub.add_parser("import", help="measured files (UFF, CSMIP/SMC, CSV, NPZ) to a bag")
    p.add_argument("files", nargs="+", type=Path, help="data files")
    p.add_argument("--out", type=Path, required=True, help="bag folder to write (new)")
    p.add_argument("--map", type=Path, default=None,
                   help="channel map (JSON/YAML) overriding role, quantity, node, direction")
    p.add_argument("--structure-frame", type=float, default=None, metavar="AZ_DEG",
                   help="azimuth of the structure's x axis from north (default: the most "
                        "common sensor axis)")
    p.add_argument("--fs", type=float, default=None, help="sample rate of a CSV without time")
    p.set_defaults(func=run)


def _progress(text: str) -> None:
    end = "\r" if sys.stderr.isatty() else "\n"
    print(f"import: {text}", file=sys.stderr, end=end, flush=True)


Part = tuple[list[ChannelSpec], float, np.ndarray]


def _strong_motion(path: Path, az: float | None, meta: dict[str, Any]) -> Part:
    from modal_twin.io.channel_map import roles_from_locations
    from modal_twin.io.strong_motion import StructureFrame, read_record, to_structure_frame

    raw, spectra = read_record(path)
    chans, dirs, frame = to_structure_frame(raw, None if az is None else StructureFrame(az))
    meta.setdefault("structure_frame", {"x_azimuth_deg": frame.x_azimuth_deg,
                                        "y_azimuth_deg": (frame.x_azimuth_deg - 90) % 360,
                                        "z": "up"})
    n = min(c.data.size for c in chans)
    if max(c.data.size for c in chans) != n:
        lens = sorted({c.data.size for c in chans})
        msg = f"{path}: channels differ in length {lens}; expected one record length"
        raise SignalError(msg)
    fs = {c.fs_hz for c in chans}
    if len(fs) != 1:
        msg = f"{path}: channels differ in sample rate {sorted(fs)}"
        raise SignalError(msg)
    roles = roles_from_locations([c.location for c in raw], [c.orientation for c in raw],
                                 [float(np.max(np.abs(c.data))) for c in raw])
    specs = []
    for c, d, (role, why) in zip(chans, dirs, roles, strict=True):
        m = {"file": path.name, "volume": c.volume, "orientation": c.orientation,
             "azimuth_deg": c.azimuth_deg, "filter_hz": list(c.filter_hz),
             "unit_in_file": c.unit_in_file, "start_utc": c.start_utc, "station": c.station,
             "structure": c.structure, "role_from": f"{c.location!r}: {why}"}
        if c.name in spectra:
            m["spectra_file"] = spectra[c.name]["file"]
        specs.append(ChannelSpec(c.name, "acceleration", c.location, d, node=c.location,
                                 role=role, meta=tuple(sorted(m.items()))))
    return specs, fs.pop(), np.array([c.data for c in chans])


def _uff(path: Path, extra: dict[str, Any]) -> Part | None:
    from modal_twin.io.uff import read_uff

    u = read_uff(path)
    if u.geometry.get("nodes") or u.geometry.get("trace_lines"):
        stem = path.stem if path.stem.startswith("geometry_") else f"geometry_{path.stem}"
        extra[f"{stem}.json"] = u.geometry
    if u.spectra:
        extra[f"spectra_{path.stem}.npz"] = {
            "names": np.array([s["name"] for s in u.spectra]),
            "func_type": np.array([s["func_type"] for s in u.spectra]),
            **{f"f_hz_{k}": s["f_hz"] for k, s in enumerate(u.spectra)},
            **{f"data_{k}": s["data"] for k, s in enumerate(u.spectra)}}
    if 55 in u.skipped:  # modes (as `identify` / `export modes` write them)
        from modal_twin.io.modes_file import uff_modes_document

        extra[f"modes_{path.stem}.json"] = uff_modes_document(path)
    if set(u.skipped) - {55}:
        _progress(f"{path.name}: dataset types {sorted(set(u.skipped) - {55})} not read")
    if not (u.time or u.spectra or extra):
        msg = (f"{path}: no supported UFF dataset (found types {sorted(set(u.skipped))}; "
               f"import reads 55, 58 / 58b, 15, 18, 82, 151, 164, 2411, 2420)")
        raise ConfigError(msg)
    if not u.time:
        return None
    fs = {round(t[1], 9) for t in u.time}
    ns = {t[3].size for t in u.time}
    if len(fs) != 1 or len(ns) != 1:
        msg = (f"{path}: time channels differ in sample rate {sorted(fs)} or length "
               f"{sorted(ns)}; expected one record")
        raise SignalError(msg)
    return [t[0] for t in u.time], u.time[0][1], np.array([t[3] for t in u.time])


def _read(path: Path, a: argparse.Namespace, meta: dict[str, Any],
          extra: dict[str, Any]) -> Part | None:
    from modal_twin.io.tabular import read_csv, read_npz

    suf = path.suffix.lower()
    if not path.is_file():
        msg = f"{path}: no such file"
        raise ConfigError(msg)
    if suf in UFF:
        return _uff(path, extra)
    if suf in STRONG_MOTION:
        return _strong_motion(path, a.structure_frame, meta)
    if suf == ".csv":
        return read_csv(path, a.fs)
    if suf == ".npz":
        return read_npz(path)
    msg = (f"{path}: unknown file kind {suf!r}; expected one of "
           f"{sorted((*UFF, *STRONG_MOTION, '.csv', '.npz'))}")
    raise ConfigError(msg)


def check_record(n_channels: int, n_samples: int, fs_hz: float, source: str) -> None:
    """Refuse a record nothing downstream can use, before it is joined or written.

    Raises
    ------
    OptionError
        A sample rate outside ``LIMITS["sample_rate_hz"]``, fewer than 2 samples, more
        than ``LIMITS["n_channels"]`` channels or more than ``FILE_UNPACKED_MAX_BYTES`` of
        samples (:mod:`modal_twin.validation`).
    """
    check_field(fs_hz, f"{source}: sample rate", "sample_rate_hz")
    check_field(n_channels, f"{source}: number of channels", "n_channels")
    if n_channels < 1 or n_samples < 2:
        msg = (f"{source}: an empty record ({n_channels} channels x {n_samples} samples); "
               f"expected at least 1 channel and 2 samples")
        raise OptionError(msg)
    check_array_budget((n_channels, n_samples), f"{source}: record",
                       FILE_UNPACKED_MAX_BYTES)


def _join(parts: list[tuple[Path, Part]]) -> Part:
    fs = {round(p[1], 9) for _, p in parts}
    ns = {p[2].shape[1] for _, p in parts}
    if len(fs) != 1 or len(ns) != 1:
        msg = (f"files {[str(f) for f, _ in parts]} differ in sample rate {sorted(fs)} or "
               f"length {sorted(ns)}; import them into separate bags")
        raise SignalError(msg)
    chans = [c for _, p in parts for c in p[0]]
    check_record(len(chans), ns.pop(), parts[0][1][1], str(parts[0][0]))
    if any(np.iscomplexobj(p[2]) for _, p in parts):
        msg = (f"{[str(f) for f, _ in parts]}: complex samples; a record is a real time "
               "series and no channel role takes complex data")
        raise SignalError(msg)
    dup = [n for n, k in Counter(c.name for c in chans).items() if k > 1]
    if dup:
        chans = [replace(c, name=f"{f.stem}.{c.name}") for f, p in parts for c in p[0]]
    return chans, parts[0][1][1], np.concatenate([p[2] for _, p in parts], axis=0)


def _positions(chans: list[ChannelSpec], extra: dict[str, Any]) -> list[ChannelSpec]:
    """Sensor positions from imported UFF geometry (a channel's node among its nodes)."""
    nodes: dict[str, list[float]] = {}
    for name, obj in extra.items():
        if name.startswith("geometry_"):
            nodes.update(obj.get("nodes", {}))
    def at(c: ChannelSpec) -> ChannelSpec:
        x, y, z = (float(v) for v in nodes[c.node][:3])
        return replace(c, position_m=(x, y, z))

    return [at(c) if c.node in nodes else c for c in chans]


def _mapped(chans: list[ChannelSpec], before: list[ChannelSpec], given: Path,
            keys: list[set[str]], names: list[str]) -> list[ChannelSpec]:
    """Mark the channels whose role the map states (``role_from``; what the headers said)."""
    by_map = {n for n, k in zip(names, keys, strict=True) if "role" in k}
    out = []
    for c, b in zip(chans, before, strict=True):
        if c.name in by_map:
            m = dict(c.meta)
            was = f"; headers: {b.role or 'cannot tell'}" if "role_from" in m else ""
            m["role_from"] = f"--map {given}{was}"
            c = replace(c, meta=tuple(sorted(m.items())))
        out.append(c)
    return out


def _check_roles(chans: list[ChannelSpec], given: Path | None) -> None:
    """Refuse channels the headers cannot give a role and no map names (one line)."""
    untold = [c for c in chans if not c.role and "role_from" in dict(c.meta)]
    if untold:
        first = untold[0]
        msg = (f"cannot tell the role of {len(untold)} channel(s) {[c.name for c in untold]} "
               f"from their headers ({first.name}: {dict(first.meta)['role_from']}); give "
               f"them a role with --map FILE ({{channels: [{{name, role}}]}})"
               + (f" (not in {given})" if given is not None else ""))
        raise ConfigError(msg)


def _print_roles(chans: list[ChannelSpec], given: Path | None) -> None:
    """One line per channel: role and the header words (or the map) that decided it."""
    structures = sorted({str(dict(c.meta)["structure"]) for c in chans
                         if dict(c.meta).get("structure")})
    if structures:
        print(f"import: roles from the headers of {', '.join(structures)}"
              + (f" and {given}" if given is not None else ""))
    rule = "name rule (table_* input, *_dx/_dy, *_fx/_fy device, others output)"
    rows = [(c.name, c.effective_role, str(dict(c.meta).get("role_from") or rule))
            for c in chans]
    if len(rows) > PRINT_ROLES_MAX:  # one line per role and reason (dataset numbers aside)
        groups: dict[tuple[str, str], list[str]] = {}
        for name, role, why in rows:
            groups.setdefault((role, re.sub(r"dataset \d+", "dataset n", why)), []).append(name)
        rows = [(f"{len(v)} channel{'s' * (len(v) > 1)} ({', '.join(v[:3])}"
                 f"{', ...' if len(v) > 3 else ''})", role, why)
                for (role, why), v in groups.items()]
    width = max(len(r[0]) for r in rows)
    for name, role, why in rows:
        print(f"  {name:<{width}}  {role:<9}  {why}")


def record_start(chans: list[ChannelSpec]) -> int:
    """Return the UTC start (ns since 1970) from the channels' header start lines, or 0.

    Strong-motion headers state the start (``start_utc`` in a channel's meta,
    :func:`modal_twin.io.strong_motion.start_ns`); the earliest is the record's, so events
    of a campaign sit at their real times. Files without a start line begin at 0.
    """
    from modal_twin.io.strong_motion import start_ns

    starts = [start_ns(str(dict(c.meta).get("start_utc", ""))) for c in chans]
    known = [t for t in starts if t is not None]
    return min(known) if known else 0


def run(a: argparse.Namespace) -> int:
    """Import the files (module docstring)."""
    from modal_twin.io.channel_map import apply_map, map_keys, read_channel_map
    from modal_twin.io.imported import write_imported, write_side_files
    from modal_twin.signal_block import SignalBlock

    az = a.structure_frame
    if az is not None and not (np.isfinite(az) and 0.0 <= az < 360.0):
        msg = f"--structure-frame: expected an azimuth in [0, 360) deg from north, got {az}"
        raise OptionError(msg)
    meta: dict[str, Any] = {"files": [str(f) for f in a.files]}
    extra: dict[str, Any] = {}
    parts = []
    held = 0
    for k, f in enumerate(a.files):
        size = f.stat().st_size / 1e6 if f.is_file() else 0.0
        if size >= LARGE_MB and sys.stderr.isatty():  # a refusal stays one line in a log
            _progress(f"[{k + 1}/{len(a.files)}] reading {f} ({size:.1f} MB)")
        part = _read(f, a, meta, extra)
        if part is not None:
            X = np.asarray(part[2])
            check_record(X.shape[0], X.shape[-1] if X.ndim == 2 else 0, part[1], str(f))
            held += X.size
            check_array_budget((held,), f"{f}: the files' samples together",
                               FILE_UNPACKED_MAX_BYTES)
            parts.append((f, part))
    if not parts:
        out = write_side_files(a.out, extra)
        print(f"import: no time data in {[str(f) for f in a.files]}; wrote "
              f"{sorted(extra)} into {out}")
        return ExitCode.OK
    chans, fs, X = _join(parts)
    chans = _positions(chans, extra)
    if a.map is not None:
        user, keys = read_channel_map(a.map), map_keys(a.map)
        chans = _mapped(apply_map(chans, user, keys, str(a.map)), chans, a.map, keys,
                        [u.name for u in user])
    _check_roles(chans, a.map)
    bad = [c.name for c, x in zip(chans, X, strict=True) if not np.all(np.isfinite(x))]
    if bad:
        msg = f"{a.files[0]}: channels {bad} hold NaN or Inf samples"
        raise SignalError(msg)
    t0 = record_start(chans)
    if t0:
        from datetime import UTC, datetime

        meta["start_utc"] = datetime.fromtimestamp(t0 / 1e9, tz=UTC).isoformat()
    block = SignalBlock(tuple(c.name for c in chans), fs, 0, X, stamp_ns=t0,
                        source=a.files[0].name)
    large = X.nbytes / 1e6 >= LARGE_MB
    out = write_imported(a.out, block, chans, extra_files=extra, record_meta=meta,
                         progress=(lambda q: _progress(f"writing {a.out}: {100 * q:.0f} %"))
                         if large else None)
    _print_roles(chans, a.map)
    roles: dict[str, int] = {}
    for c in chans:
        roles[c.effective_role] = roles.get(c.effective_role, 0) + 1
    print(f"import: {out}: {len(chans)} channels x {block.n_samples} samples at "
          f"{fs:g} Hz ({block.n_samples / fs:.1f} s"
          + (f" from {meta['start_utc']}" if t0 else "") + f"); roles {roles}; "
          f"channel map {out / 'channel_map.json'}"
          + (f"; also {sorted(extra)}" if extra else ""))
    return ExitCode.OK
