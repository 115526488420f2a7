"""The force and response of a single-DOF test record, for ``modal-twin sdof``.

Read from (by file name; ``FILE:GROUP`` picks a group of an HDF5 file):

- ``.h5`` / ``.hdf5``: a group (default: the first, by name, holding ``u`` and ``y``) with
  the force ``u`` (N), the response ``y`` and the sample rate ``fs`` (Hz), as the Bouc-Wen
  benchmark of Noel and Schoukens (``../shared/benchmarks/boucwen``);
- ``.mat`` (MATLAB 4 to 7.3): variables ``u``, ``y`` and ``fs``;
- ``.csv`` / ``.npz``: a channel table with units (:mod:`modal_twin.io.tabular`): the force
  is the one channel of role ``input`` or else of quantity force; the response the one other
  channel of quantity displacement or acceleration (role ``output`` first).

``--force-channel`` / ``--response-channel`` name the channels (variables) instead; ``--fs``
gives a rate the file lacks. The response quantity comes from the units (CSV / NPZ) or is
displacement (``--response-quantity`` says otherwise). An acceleration is integrated twice
in the frequency domain (:func:`displacement_from_acceleration`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.channels import ChannelSpec
from modal_twin.errors import ConfigError, OptionError
from modal_twin.models.array_files import hdf5_datasets, mat_arrays
from modal_twin.paths import check_regular

__all__ = ["RESPONSE_QUANTITIES", "SDOFRecord", "displacement_from_acceleration",
           "force_band_edge", "high_pass", "read_sdof_record"]

RESPONSE_QUANTITIES = ("displacement", "acceleration")
"""Response quantities the single-DOF fits take (an acceleration is integrated)."""
HDF5_SUFFIXES = (".h5", ".hdf5")
TABLE_SUFFIXES = (".csv", ".npz")


@dataclass(frozen=True, slots=True)
class SDOFRecord:
    """One single-DOF record.

    Attributes
    ----------
    u : FloatArray
        Force, shape (nt,), N.
    y : FloatArray
        Response, shape (nt,), m or m/s^2 (``quantity``).
    fs_hz : float
        Sample rate, Hz.
    quantity : str
        ``"displacement"`` or ``"acceleration"``.
    source : str
        File (and group) and the channel names, for the printout.
    """

    u: FloatArray
    y: FloatArray
    fs_hz: float
    quantity: str
    source: str


def _split(spec: str) -> tuple[Path, str | None]:
    p = Path(spec)
    if p.exists() or ":" not in spec:
        return p, None
    head, group = spec.rsplit(":", 1)
    return Path(head), group or None


def _variable(arrays: dict[str, Any], name: str, path: Path) -> FloatArray:
    if name not in arrays:
        msg = f"{path}: no variable {name!r}; it holds {sorted(arrays)}"
        raise ConfigError(msg)
    a = np.asarray(arrays[name], dtype=float)
    if a.ndim > 2 or (a.ndim == 2 and 1 not in a.shape):
        msg = f"{path}: variable {name!r}: expected one channel, got shape {a.shape}"
        raise ConfigError(msg)
    return a.ravel()


def _pick(chans: list[ChannelSpec], name: str | None, what: str, path: Path,
          ok: tuple[str, ...], exclude: str = "") -> int:
    names = [c.name for c in chans]
    if name is not None:
        if name not in names:
            msg = f"{path}: no channel {name!r} for the {what}; channels {names}"
            raise ConfigError(msg)
        return names.index(name)
    cands = [i for i, c in enumerate(chans) if c.name != exclude and c.quantity in ok]
    role = "input" if what == "force" else "output"
    by_role = [i for i in cands if chans[i].effective_role == role]
    pick = by_role if len(by_role) == 1 else cands
    if len(pick) != 1:
        flag = f"--{what}-channel"
        msg = (f"{path}: {len(pick)} channels could be the {what} "
               f"({[names[i] for i in pick]}); name one with {flag}")
        raise ConfigError(msg)
    return pick[0]


def read_sdof_record(spec: str, *, force: str | None = None, response: str | None = None,
                     fs_hz: float | None = None, quantity: str | None = None) -> SDOFRecord:
    """Read a single-DOF record (module docstring).

    Parameters
    ----------
    spec : str
        ``FILE`` or ``FILE:GROUP`` (HDF5).
    force, response : str, optional
        Channel or variable names (default: by role and quantity, or ``u`` / ``y``).
    fs_hz : float, optional
        Sample rate when the file lacks it (CSV without time, .mat without ``fs``).
    quantity : str, optional
        Response quantity, one of :data:`RESPONSE_QUANTITIES` (default: from the units, or
        displacement).

    Returns
    -------
    SDOFRecord

    Raises
    ------
    ConfigError
        Unknown file kind, missing variable or channel, ambiguous channels, no sample rate.
    OptionError
        Unknown response quantity.
    """
    if quantity is not None and quantity not in RESPONSE_QUANTITIES:
        msg = f"response quantity: expected one of {RESPONSE_QUANTITIES}, got {quantity!r}"
        raise OptionError(msg)
    path, group = _split(spec)
    check_regular(path, "record")
    suf = path.suffix.lower()
    if suf in TABLE_SUFFIXES:
        from modal_twin.io.tabular import read_csv, read_npz

        chans, fs, X = read_csv(path, fs_hz) if suf == ".csv" else read_npz(path)
        i_u = _pick(chans, force, "force", path, ("force",))
        i_y = _pick(chans, response, "response", path, RESPONSE_QUANTITIES,
                    exclude=chans[i_u].name)
        q = quantity or chans[i_y].quantity
        if q not in RESPONSE_QUANTITIES:
            msg = (f"{path}: response {chans[i_y].name!r} is a {chans[i_y].quantity}; "
                   f"expected one of {RESPONSE_QUANTITIES}")
            raise ConfigError(msg)
        return SDOFRecord(X[i_u].copy(), X[i_y].copy(), float(fs), q,
                          f"{path.name}: force {chans[i_u].name}, response {chans[i_y].name}")
    if suf in HDF5_SUFFIXES:
        arrays, where = hdf5_datasets(path, group=group, needs=("u", "y"))
        source = f"{path.name}:{where}"
    elif suf == ".mat":
        arrays, source = mat_arrays(path), path.name
    else:
        msg = (f"{path}: unknown record kind {suf!r}; expected "
               f"{(*HDF5_SUFFIXES, '.mat', *TABLE_SUFFIXES)}")
        raise ConfigError(msg)
    fu, fy = force or "u", response or "y"
    u, y = _variable(arrays, fu, path), _variable(arrays, fy, path)
    if fs_hz is None:
        if "fs" not in arrays:
            msg = f"{path}: no sample rate variable 'fs'; give --fs"
            raise ConfigError(msg)
        fs_hz = float(np.asarray(arrays["fs"], dtype=float).ravel()[0])
    return SDOFRecord(u, y, float(fs_hz), quantity or "displacement",
                      f"{source}: force {fu}, response {fy}")


def displacement_from_acceleration(a: FloatArray, fs_hz: float, f_min_hz: float,
                                   *, periodic: bool) -> FloatArray:
    """Integrate an acceleration twice in the frequency domain, ``Y = -A / w^2``.

    Lines below ``f_min_hz`` (where ``1 / w^2`` amplifies drift and noise) are set to zero;
    the force must pass the same high-pass (:func:`high_pass`) for the record to stay one
    input-output pair. A record that is not whole periods is mirrored first (as
    :func:`modal_twin.diagnosis.restoring_force.state_derivatives`).

    Parameters
    ----------
    a : FloatArray
        Acceleration, shape (nt,), m/s^2.
    fs_hz, f_min_hz : float
        Sample rate and lowest line kept, Hz.
    periodic : bool
        True when the record holds whole periods of a steady state.

    Returns
    -------
    FloatArray
        Displacement, shape (nt,), m.
    """
    return _band(a, fs_hz, f_min_hz, periodic, integrate=True)


def force_band_edge(u: FloatArray, fs_hz: float, *, periodic: bool,
                    level: float = 0.01) -> float:
    """Lowest frequency (> 0) at which the force spectrum reaches ``level`` of its peak, Hz.

    Below it an input-output record holds no response to the force, only drift and noise,
    which a double integration would amplify by ``1 / w^2``.
    """
    xe = u if periodic else np.concatenate([u, u[::-1]])
    amp = np.abs(np.fft.rfft(xe - np.mean(xe)))
    f = np.fft.rfftfreq(xe.size, 1.0 / fs_hz)
    amp[0] = 0.0
    peak = float(amp.max())
    return float(f[np.flatnonzero(amp >= level * peak)[0]]) if peak > 0 else float(f[1])


def high_pass(x: FloatArray, fs_hz: float, f_min_hz: float, *, periodic: bool) -> FloatArray:
    """Zero the lines of ``x`` below ``f_min_hz``.

    The filter of :func:`displacement_from_acceleration`, for the force of the same record.
    """
    return _band(x, fs_hz, f_min_hz, periodic, integrate=False)


def _band(x: FloatArray, fs_hz: float, f_min_hz: float, periodic: bool, integrate: bool
          ) -> FloatArray:
    n = x.size
    xe = x if periodic else np.concatenate([x, x[::-1]])
    X = np.fft.rfft(xe)
    f = np.fft.rfftfreq(xe.size, 1.0 / fs_hz)
    keep = f >= f_min_hz
    X[~keep] = 0.0
    if integrate:
        X[keep] /= -((2 * np.pi * f[keep]) ** 2)
    return np.fft.irfft(X, xe.size)[:n]
