"""CSV and NPZ records with a channel table.

**CSV**: one header row of ``name [unit]`` cells (``t [s], a1 [m/s^2], F [N]``) or two
header rows (names, then units); the first column is time in s (uniform sampling is
checked) unless every column is a channel and ``fs_hz`` is given. Units are required:
a CSV without them is refused, because a number without a unit cannot enter the pipeline.

**NPZ**: arrays ``data`` (n_channels, n_samples), ``fs_hz`` (scalar), ``names`` and
``units`` (string arrays, one per channel); optional ``quantities``, ``roles``.

Units are converted to SI with :data:`UNITS`.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.channels import ROLES, ChannelSpec
from modal_twin.errors import ConfigError
from modal_twin.models.array_files import MAX_CHANNELS, npz_arrays, npz_members, read_csv_numbers

__all__ = ["UNITS", "read_csv", "read_npz"]

UNITS: dict[str, tuple[str, float]] = {
    "m/s^2": ("acceleration", 1.0), "m/s2": ("acceleration", 1.0),
    "g": ("acceleration", 9.80665), "cm/s^2": ("acceleration", 0.01),
    "cm/s2": ("acceleration", 0.01), "mm/s^2": ("acceleration", 1e-3),
    "m/s": ("velocity", 1.0), "mm/s": ("velocity", 1e-3), "cm/s": ("velocity", 0.01),
    "m": ("displacement", 1.0), "mm": ("displacement", 1e-3), "cm": ("displacement", 0.01),
    "n": ("force", 1.0), "kn": ("force", 1e3), "pa": ("pressure", 1.0),
    "rad/s^2": ("angular_acceleration", 1.0),
}
"""Unit (lower case) -> (quantity, factor to SI)."""

_CELL = re.compile(r"^\s*(.*?)\s*[\[(]\s*([^\])]+?)\s*[\])]\s*$")


def _unit(path: Path, name: str, unit: str) -> tuple[str, float]:
    u = unit.strip().lower().replace(" ", "")
    if u not in UNITS:
        msg = (f"{path}: column {name!r} has unit {unit!r}; expected one of "
               f"{sorted({k for k in UNITS})}")
        raise ConfigError(msg)
    return UNITS[u]


def _header(path: Path, rows: list[list[str]]) -> int:
    """Return the number of header rows (1: ``name [unit]`` cells, 2: names, units)."""
    cells = [_CELL.match(c.strip()) for c in rows[0]]
    if all(cells):
        return 1
    if len(rows) > 1:
        try:
            [float(c) for c in rows[1]]
        except ValueError:
            return 2
    msg = (f"{path}: CSV without units: write the header as 'name [unit]' "
           f"(e.g. 't [s], a1 [m/s^2]') or add a second header row of units")
    raise ConfigError(msg)


def _names_units(rows: list[list[str]]) -> tuple[list[str], list[str]]:
    first = [c.strip() for c in rows[0]]
    if len(rows) == 1:
        cells = [_CELL.match(c) for c in first]
        return [m.group(1) for m in cells if m], [m.group(2) for m in cells if m]
    return first, [c.strip() for c in rows[1]]


def read_csv(path: str | Path, fs_hz: float | None = None
             ) -> tuple[list[ChannelSpec], float, FloatArray]:
    """Channels, sample rate and SI samples ``(n_ch, n_s)`` of a CSV (module docstring).

    Raises
    ------
    ConfigError
        No units, an unknown unit, missing or non-numeric cells, a ragged row, no time
        column and no ``fs_hz``, non-uniform time.
    """
    p = Path(path)
    head, values = read_csv_numbers(p, lambda rows: _header(p, rows))
    names, units = _names_units(head)
    if len(names) != len(units):
        msg = f"{p}: {len(names)} column names but {len(units)} units"
        raise ConfigError(msg)
    X = values.T
    if X.shape[1] < 2:
        msg = f"{p}: expected at least 2 samples, got {X.shape[1]}"
        raise ConfigError(msg)
    if units[0].strip().lower() == "s":
        t = X[0]
        dt = np.diff(t)
        if not (np.all(dt > 0) and np.ptp(dt) <= 1e-6 * np.mean(dt) + 1e-12):
            msg = f"{p}: time column {names[0]!r} is not uniformly increasing"
            raise ConfigError(msg)
        fs, names, units, X = 1.0 / float(np.mean(dt)), names[1:], units[1:], X[1:]
    elif fs_hz is None:
        msg = f"{p}: expected a first column of time in [s], or give the sample rate (--fs)"
        raise ConfigError(msg)
    else:
        fs = float(fs_hz)
    chans = []
    for k, (n, u) in enumerate(zip(names, units, strict=True)):
        q, f = _unit(p, n, u)
        X[k] *= f
        chans.append(ChannelSpec(n, q, meta=(("file", p.name), ("unit_in_file", u))))
    return chans, fs, X


def read_npz(path: str | Path) -> tuple[list[ChannelSpec], float, FloatArray]:
    """Channels, sample rate and SI samples of an NPZ record (module docstring).

    Raises
    ------
    ConfigError
        A missing array, shapes that disagree, an unknown unit or role.
    """
    p = Path(path)
    members = npz_members(p)
    missing = [k for k in ("data", "fs_hz", "names", "units") if k not in members]
    if missing:
        msg = f"{p}: NPZ record lacks arrays {missing} (has {sorted(members)})"
        raise ConfigError(msg)
    shape, dtype = members["data"]
    if dtype.kind == "c":
        msg = (f"{p}: data holds complex samples; a record is real time series (give the "
               f"real and imaginary parts as separate channels)")
        raise ConfigError(msg)
    if len(shape) != 2 or not 1 <= shape[0] <= MAX_CHANNELS:
        msg = (f"{p}: expected data (n_channels, n_samples) with 1 to {MAX_CHANNELS} "
               f"channels, got shape {shape}")
        raise ConfigError(msg)
    z = npz_arrays(p, keys=("data", "fs_hz", "names", "units", "roles"))
    X = np.array(z["data"], dtype=np.float64)
    names = [str(v) for v in np.atleast_1d(z["names"])]
    units = [str(v) for v in np.atleast_1d(z["units"])]
    if X.shape[0] != len(names) or len(units) != len(names):
        msg = (f"{p}: expected data (n_ch, n_s) with n_ch = len(names) = len(units) = "
               f"{len(names)}, got data {X.shape} and {len(units)} units")
        raise ConfigError(msg)
    if z["fs_hz"].size != 1 or z["fs_hz"].dtype.kind not in "iuf":
        msg = f"{p}: fs_hz: expected one number, got {z['fs_hz']!r}"[:300]
        raise ConfigError(msg)
    roles = [str(v) for v in np.atleast_1d(z["roles"])] if "roles" in z else [""] * len(names)
    bad = sorted({r for r in roles if r and r not in ROLES})
    if bad:
        msg = f"{p}: roles {bad} unknown; expected {ROLES}"
        raise ConfigError(msg)
    chans = []
    for k, (n, u) in enumerate(zip(names, units, strict=True)):
        q, f = _unit(p, n, u)
        X[k] *= f
        chans.append(ChannelSpec(n, q, role=roles[k], meta=(("file", p.name),
                                                            ("unit_in_file", u))))
    return chans, float(z["fs_hz"].ravel()[0]), X
