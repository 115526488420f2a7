"""Readers for strong-motion records: CSMIP Volume 2 (``.v2``) and USGS NSMP SMC (``.smc``).

Everything the data needs is read from the headers, not assumed:

- **CSMIP V2** (California Strong Motion Instrumentation Program, corrected data): the
  channel line ``Chan  4:  Long    (Sta Chn:  6)     Location: Bent 3: ...`` gives the
  orientation, station channel number and location; the start line gives the UTC start;
  the data line ``13000 points of accel data equally spaced at 0.005 sec, in cm/sec2.
  (8f10.6)`` gives the count, the sample interval, the unit and the fixed-width format.
- **SMC** (USGS National Strong-Motion Project): 11 text lines (line 1 = data type code,
  ``2 CORRECTED ACCELEROGRAM``; ``station = ... component= 351`` gives the azimuth),
  48 integers in 8I10 (I(16) = number of comment lines, I(17) = number of samples),
  50 reals in 5E15.7 (R(2) = sample rate in samples/s), the comments (``<loclbl=>...<end>``
  gives the sensor location), then the samples in 8E10.4. The format fixes the unit of
  corrected acceleration to cm/s^2; the reader checks it against the peak stated in
  the text header (``pk acc = ...``) and refuses a file where they disagree.

Data are returned in SI (m/s^2).
"""

from __future__ import annotations

import re
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.errors import SignalError
from modal_twin.models.array_files import read_text_bounded, regular_file, zip_texts

__all__ = [
    "StrongMotionChannel",
    "StructureFrame",
    "read_record",
    "read_smc",
    "read_v2",
    "read_v3",
    "read_zip",
    "start_ns",
    "to_structure_frame",
]

_UNIT_TO_SI = {"cm/sec2": 0.01, "cm/sec/sec": 0.01, "cm/s2": 0.01, "m/sec2": 1.0,
               "g": 9.80665, "mm/sec2": 0.001}

_CHAN = r"^Chan\s+(\d+):\s+(\S+)(?:\s+Deg)?\s+(?:\(Sta Chn:\s*(\d+)\))?\s*Location"
"""CSMIP channel line: number, orientation (Up / Long / Tran / azimuth), station channel."""


@dataclass(frozen=True, slots=True)
class StrongMotionChannel:
    """One acceleration channel of a strong-motion record, data in m/s^2.

    Attributes
    ----------
    name : str
        Channel id: ``"58658.ch06"`` (station.station-channel) or the SMC SCNL code.
    station : str
        Station number or name as written in the header.
    location : str
        Sensor location (``"Bent 3: South Column, Grnd Level"``).
    orientation : str
        ``"Up"``, ``"Long"``, ``"Tran"`` (CSMIP) or the SMC component (azimuth or ``"UP"``).
    azimuth_deg : float
        Azimuth of a horizontal component in degrees from north (NaN when not stated or
        vertical).
    fs_hz : float
        Sample rate in Hz.
    start_utc : str
        Start time as written in the header.
    unit_in_file : str
        Unit of the file's samples (converted to m/s^2 in ``data``).
    data : ndarray, shape (n_samples,)
        Acceleration in m/s^2.
    """

    name: str
    station: str
    location: str
    orientation: str
    azimuth_deg: float
    fs_hz: float
    start_utc: str
    unit_in_file: str
    data: FloatArray
    filter_hz: tuple[float, float] = (np.nan, np.nan)
    volume: str = "V2"
    structure: str = ""
    """Station description as written (``"Hayward - Hwy 580/238 Interchange Bridge"``)."""


_V2_START = re.compile(r"^(\d{1,2})/(\d{1,2})/(\d{2,4}),?\s+(\d{1,2}):(\d{2}):(\d{2}(?:\.\d*)?)")
_ISO_START = re.compile(r"^(\d{4})-(\d{2})-(\d{2})[ T](\d{2}):(\d{2}):(\d{2}(?:\.\d*)?)")


def start_ns(start_utc: str) -> int | None:
    """UTC start of a record as nanoseconds since 1970-01-01, from its header's start line.

    Reads a CSMIP V2 start (``4/26/21, 17:09:54.0 UTC (GPS)``: month / day / two-digit year,
    20xx) and the SMC start :func:`read_smc` writes (``2018-01-04 10:39:00.164``).
    Returns None when the line is empty or in another form (the record then starts at 0).
    """
    from datetime import UTC, datetime

    text = start_utc.strip()
    m = _V2_START.match(text)
    if m is not None:
        mo, d, y, hh, mi, sec = m.groups()
        year = int(y) + (2000 if len(y) == 2 else 0)
        ymd = (year, int(mo), int(d))
    else:
        m = _ISO_START.match(text)
        if m is None:
            return None
        y, mo, d, hh, mi, sec = m.groups()
        ymd = (int(y), int(mo), int(d))
    try:
        t = datetime(*ymd, int(hh), int(mi), tzinfo=UTC)
    except ValueError:
        return None
    return int(t.timestamp()) * 1_000_000_000 + round(float(sec) * 1e9)


def _fixed(lines: list[str], n: int, width: int, what: str) -> FloatArray:
    """``n`` fixed-width numbers from ``lines`` (fields may touch: ``-0.0046972-0.0099594``)."""
    vals: list[str] = []
    for ln in lines:
        s = ln.rstrip("\n\r")
        vals.extend(s[k : k + width] for k in range(0, len(s.rstrip()), width))
        if len(vals) >= n:
            break
    if len(vals) < n:
        msg = f"{what}: expected {n} samples, found {len(vals)}"
        raise SignalError(msg)
    try:
        return np.array([float(v) for v in vals[:n]], dtype=np.float64)
    except ValueError as err:
        msg = f"{what}: malformed sample field ({err})"
        raise SignalError(msg) from err


def _search(pattern: str, text: str, what: str, name: str) -> re.Match[str]:
    m = re.search(pattern, text, flags=re.MULTILINE)
    if m is None:
        msg = f"{name}: expected a {what} line in the header, found none"
        raise SignalError(msg)
    return m


def read_v2(text: str, name: str = "v2") -> StrongMotionChannel:
    """Parse the acceleration section of a CSMIP Volume 2 file.

    Parameters
    ----------
    text : str
        File contents.
    name : str
        File name for messages.

    Returns
    -------
    StrongMotionChannel

    Raises
    ------
    SignalError
        A header line is missing, the unit is unknown, or samples are missing / malformed.
    """
    lines = text.splitlines()
    ch = _search(_CHAN + r":\s*(.*?)\s*$", text, "channel ('Chan n: ... Location:')", name)
    sta = _search(r"Station No\.\s+(\d+)", text, "station ('Station No.')", name).group(1)
    start = re.search(r"Start time:\s*(.*?)\s*$", text, flags=re.MULTILINE)
    acc = _search(
        r"^\s*(\d+)\s+points of (?:accel )?data equally spaced at\s+([\d.Ee+-]+)\s+sec,\s+in\s+"
        r"(\S+?)\.?\s+\((\d+)[fFeE](\d+)\.\d+\)",
        text, "accel data ('N points of accel data ...')", name,
    )
    n, dt, unit, width = int(acc.group(1)), float(acc.group(2)), acc.group(3), int(acc.group(5))
    if unit.lower() not in _UNIT_TO_SI:
        msg = f"{name}: expected an acceleration unit in {sorted(_UNIT_TO_SI)}, got {unit!r}"
        raise SignalError(msg)
    if not dt > 0:
        msg = f"{name}: expected a positive sample interval, got {dt}"
        raise SignalError(msg)
    first = text[: acc.end()].count("\n") + 1
    data = _fixed(lines[first:], n, width, name) * _UNIT_TO_SI[unit.lower()]
    st_ch = int(ch.group(3)) if ch.group(3) else int(ch.group(1))
    orient = ch.group(2)
    deg = re.match(r"^(\d+(?:\.\d*)?)$", orient)
    az = float(deg.group(1)) % 360.0 if deg else np.nan
    corners = re.search(r"3 dB pts at\s+([\d.]+)\s+and\s+([\d.]+)\s+cyc/sec", text)
    filt = (float(corners.group(1)), float(corners.group(2))) if corners else (np.nan, np.nan)
    vol = "V1" if re.match(r"\s*Uncorrected accelerogram", text, flags=re.IGNORECASE) else "V2"
    desc = re.search(r"^Station No\..*\n(?!Chan\s)(.*?)(?:\s{2,}|$)", text, flags=re.MULTILINE)
    return StrongMotionChannel(
        f"{sta}.ch{st_ch:02d}", sta, ch.group(4), orient, az, 1.0 / dt,
        start.group(1) if start else "", unit, data, filt, vol,
        desc.group(1).strip() if desc else "",
    )


def read_smc(text: str, name: str = "smc") -> StrongMotionChannel:
    """Parse a USGS SMC file of corrected acceleration (data type code 2).

    Raises
    ------
    SignalError
        Not corrected acceleration, truncated header or data, or the data peak disagrees
        with the peak stated in the header (a unit other than cm/s^2).
    """
    lines = text.splitlines()
    if len(lines) < 27 or not lines[0].strip().startswith("2 "):
        head = lines[0].strip() if lines else ""
        msg = f"{name}: expected an SMC file of type '2 CORRECTED ACCELEROGRAM', got {head!r}"
        raise SignalError(msg)
    ints = _fixed(lines[11:17], 48, 10, name).astype(np.int64)
    reals = _fixed(lines[17:27], 50, 15, name)
    n_comment, n = int(ints[15]), int(ints[16])
    fs = float(reals[1])
    if not (n > 0 and 0 < fs < 1e6):
        msg = f"{name}: expected samples > 0 and a sample rate in (0, 1e6), got {n}, {fs}"
        raise SignalError(msg)
    comments = lines[27 : 27 + n_comment]
    data_cm = _fixed(lines[27 + n_comment :], n, 10, name)
    header = "\n".join(lines[:11])
    pk = re.search(r"pk acc\s*=\s*([-+\d.Ee]+)", header)
    if pk is not None:
        stated, found = abs(float(pk.group(1))), float(np.max(np.abs(data_cm)))
        if not abs(found - stated) <= 0.02 * stated:  # 3 significant digits in the header
            msg = (f"{name}: expected the data peak to match the header 'pk acc' "
                   f"{stated} cm/s^2, got {found}")
            raise SignalError(msg)
    comp = re.search(r"component=\s*(\S+)", header)
    orient = comp.group(1) if comp else ""
    try:
        az = float(orient)
    except ValueError:
        az = np.nan
    stam = re.search(r"station\s*=\s*(.*?)\s+component=", header)
    loc = re.search(r"<loclbl=>(.*?)<end>", "\n".join(comments))
    scnl = re.search(r"<SCNL>(\S+)", "\n".join(comments))
    start = "{:04d}-{:02d}-{:02d} {:02d}:{:02d}:{:02d}.{:03d}".format(*(int(v) for v in ints[1:8]))
    return StrongMotionChannel(
        scnl.group(1) if scnl else name, stam.group(1).strip() if stam else "",
        loc.group(1).strip() if loc else "", orient, az % 360.0, fs, start, "cm/s^2",
        data_cm * 0.01, (np.nan, np.nan), "SMC", stam.group(1).strip() if stam else "",
    )


def read_v3(text: str, name: str = "v3") -> dict[str, object]:
    """Header of a CSMIP Volume 3 file (response and Fourier spectra): what it belongs to.

    The spectra themselves are not used by the pipeline; the import keeps, per channel,
    the V3 file name, its damping values and its period range as metadata.

    Raises
    ------
    SignalError
        No channel line in the header.
    """
    ch = _search(_CHAN, text, "channel ('Chan n: ... Location:')", name)
    sta = _search(r"Station No\.\s+(\d+)", text, "station ('Station No.')", name).group(1)
    st_ch = int(ch.group(3)) if ch.group(3) else int(ch.group(1))
    rng = re.search(r"periods,\s*([\d.]+)\s*-\s*([\d.]+)\s*sec", text)
    return {"channel": f"{sta}.ch{st_ch:02d}", "file": name, "kind": "response spectra (V3)",
            "periods_s": [float(rng.group(1)), float(rng.group(2))] if rng else []}


def read_record(path: str | Path) -> tuple[tuple[StrongMotionChannel, ...],
                                           dict[str, dict[str, object]]]:
    """Acceleration channels and V3 spectra headers of a zip or of one V1 / V2 / SMC file.

    A zip may hold V1 (uncorrected), V2 (corrected) and V3 (spectra) files; a channel with
    both a V1 and a V2 file is taken from the V2. SMC files other than acceleration
    (``_v``, ``_d``, spectra) are ignored.

    Returns
    -------
    channels : tuple of StrongMotionChannel
    spectra : dict
        Channel name -> :func:`read_v3` header.

    Raises
    ------
    SignalError
        No V1, V2 or SMC acceleration data found.
    """
    p = regular_file(path)
    texts: list[tuple[str, str]] = []
    if zipfile.is_zipfile(p):
        texts = zip_texts(p, lambda fn: fn.lower().endswith((".v1", ".v2", ".v3", ".smc")))
    else:
        texts = [(p.name, read_text_bounded(p).decode("latin-1"))]
    by_name: dict[str, StrongMotionChannel] = {}
    spectra: dict[str, dict[str, object]] = {}
    for fn, text in texts:
        low = fn.lower()
        if low.endswith((".v1", ".v2")):
            c = read_v2(text, fn)
            if low.endswith(".v2") or c.name not in by_name:
                by_name[c.name] = c
        elif low.endswith(".v3"):
            h = read_v3(text, fn)
            spectra[str(h["channel"])] = h
        elif low.endswith("_a.smc") or (low.endswith(".smc") and not zipfile.is_zipfile(p)):
            c = read_smc(text, fn)
            by_name[c.name] = c
    if not by_name:
        msg = f"{p}: expected V1 / V2 or _a.smc acceleration files, found none"
        raise SignalError(msg)
    return tuple(by_name[k] for k in sorted(by_name)), spectra


@dataclass(frozen=True, slots=True)
class StructureFrame:
    """Horizontal axes of the structure: x at ``x_azimuth_deg`` from north, y at x - 90.

    (x, y, z up) is right-handed; a sensor at azimuth ``a`` measures
    ``cos(a - ax) a_x - sin(a - ax) a_y``.
    """

    x_azimuth_deg: float


def default_frame(channels: tuple[StrongMotionChannel, ...]) -> StructureFrame:
    """x along the most common horizontal sensor axis (azimuth mod 180, smallest on ties)."""
    axes = [round(c.azimuth_deg % 180.0, 3) for c in channels if np.isfinite(c.azimuth_deg)]
    if not axes:
        return StructureFrame(0.0)
    vals, counts = np.unique(axes, return_counts=True)
    return StructureFrame(float(vals[np.argmax(counts)]))


def _axis(c: StrongMotionChannel) -> str:
    o = c.orientation.lower()
    return {"long": "x", "tran": "y", "up": "z", "vert": "z", "dn": "-z"}.get(o, "")


def to_structure_frame(channels: tuple[StrongMotionChannel, ...],
                       frame: StructureFrame | None = None
                       ) -> tuple[list[StrongMotionChannel], list[str], StructureFrame]:
    """Rotate the horizontal sensors into the structure frame.

    Sensors labelled Long / Tran / Up (CSMIP bridges) are in the structure frame already
    (x, y, z). Sensors with an azimuth are grouped by location: a group with two
    non-parallel horizontal sensors is rotated, ``[d1; d2] (a_x, a_y) = (s1, s2)`` with
    ``d = (cos(a - ax), -sin(a - ax))``, the sensor nearer to x carrying a_x and the other
    a_y (names kept); a single sensor along +-x or +-y (within 1 degree) is sign-corrected;
    any other single sensor keeps its data and gets its unit vector as direction.

    Returns
    -------
    channels : list of StrongMotionChannel
        Same names and order, data in the structure frame.
    directions : list of str
        ``"x"``, ``"y"``, ``"z"`` or ``"cx,cy,0"``.
    frame : StructureFrame
    """
    fr = frame or default_frame(channels)
    out = list(channels)
    dirs = [_axis(c) for c in channels]
    groups: dict[str, list[int]] = {}
    for k, c in enumerate(channels):
        if np.isfinite(c.azimuth_deg):
            groups.setdefault(c.location or c.name, []).append(k)
    tol = np.cos(np.radians(1.0))
    for idx in groups.values():
        th = np.radians([channels[k].azimuth_deg - fr.x_azimuth_deg for k in idx])
        D = np.column_stack([np.cos(th), -np.sin(th)])
        if len(idx) == 2 and abs(np.linalg.det(D)) > 1e-3:
            S = np.array([channels[k].data for k in idx])
            A = np.linalg.solve(D, S)
            kx = int(np.argmax(np.abs(D[:, 0])))
            for j, k in enumerate(idx):
                comp = 0 if j == kx else 1
                out[k] = _replace_data(channels[k], A[comp])
                dirs[k] = "xy"[comp]
            continue
        for j, k in enumerate(idx):
            d = D[j]
            ax = int(np.argmax(np.abs(d)))
            if abs(d[ax]) >= tol:
                out[k] = _replace_data(channels[k], np.sign(d[ax]) * channels[k].data)
                dirs[k] = "xy"[ax]
            else:
                dirs[k] = f"{d[0]:.4f},{d[1]:.4f},0"
    for k, c in enumerate(channels):
        if not dirs[k] and c.orientation.upper() == "UP":
            dirs[k] = "z"
    return out, dirs, fr


def _replace_data(c: StrongMotionChannel, data: FloatArray) -> StrongMotionChannel:
    from dataclasses import replace

    return replace(c, data=np.ascontiguousarray(data, dtype=np.float64))


def read_zip(path: str | Path) -> tuple[StrongMotionChannel, ...]:
    """Every acceleration channel of a zip of V2 files or of SMC files (``*_a.smc``).

    Raises
    ------
    SignalError
        The zip holds no V2 or SMC acceleration file.
    """
    out = []
    for fn, text in zip_texts(path, lambda fn: fn.lower().endswith((".v2", "_a.smc"))):
        if fn.lower().endswith(".v2"):
            out.append(read_v2(text, fn))
        else:
            out.append(read_smc(text, fn))
    if not out:
        msg = f"{path}: expected .v2 or _a.smc files in the zip, found none"
        raise SignalError(msg)
    return tuple(out)
