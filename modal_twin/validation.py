"""Argument checks shared by the stages, and the limits every request is held to.

Signal checks (:func:`as_channels`, :func:`check_positive`, :func:`check_rank`) serve the
acquisition and identification stages. The limits (:data:`LIMITS`) bound what a message
or a service request may ask of a node before any work starts: an order, a duration, a
window, a sample rate, an array size against :data:`MEMORY_BUDGET_BYTES`. A request that
breaks one is refused with an :class:`~modal_twin.errors.OptionError` that names the field,
the limit and the value.
"""

from __future__ import annotations

import re
import stat
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.errors import OptionError, ShapeError, SignalError

__all__ = [
    "FILE_UNPACKED_MAX_BYTES",
    "LIMITS",
    "MEMORY_BUDGET_BYTES",
    "REQUEST_FILE_MAX_BYTES",
    "TEXT_FILE_MAX_BYTES",
    "YAML_MAX_ALIASES",
    "YAML_MAX_DEPTH",
    "YAML_MAX_NODES",
    "Limit",
    "as_channels",
    "check_array_budget",
    "check_field",
    "check_name",
    "check_positive",
    "check_rank",
    "check_request_path",
]

MEMORY_BUDGET_BYTES = 1 << 28
"""Largest float64 array a single request may make a node allocate (256 MiB)."""

FILE_UNPACKED_MAX_BYTES = 1 << 29
"""Most a data file (NPZ, .mat, CSV, UFF, strong-motion zip) may unpack to (512 MiB),
judged on its declared shapes before anything is allocated
(:mod:`modal_twin.models.array_files`)."""

TEXT_FILE_MAX_BYTES = 64 * 2**20
"""Largest JSON or YAML file read (64 MiB: a modes JSON of 4,096 channels and 200 modes
takes about 35 MB), checked with ``fstat`` on the open file before it is read
(:func:`modal_twin.yaml_files.read_text`)."""

YAML_MAX_NODES = 500_000
"""Most nodes a YAML document may hold, aliases expanded (a 4,096-channel map takes 98,307;
each parsed node takes about 650 bytes): a "billion laughs" document of a few
hundred bytes that expands to 10^9 nodes is refused before it is constructed."""

YAML_MAX_ALIASES = 10_000
"""Most aliases (``*name``) a YAML document may use."""

YAML_MAX_DEPTH = 100
"""Deepest nesting of a YAML document, aliases expanded (the configurations nest about 6)."""


@dataclass(frozen=True, slots=True)
class Limit:
    """Closed range ``[lo, hi]`` of a request field; ``integer``: whole numbers only."""

    lo: float
    hi: float
    integer: bool = False
    unit: str = ""


LIMITS: dict[str, Limit] = {
    "sample_rate_hz": Limit(1e-3, 1e6, unit="Hz"),
    "duration_s": Limit(0.0, 86_400.0, unit="s"),
    "window_s": Limit(0.0, 86_400.0, unit="s"),
    "frequency_hz": Limit(0.0, 5e5, unit="Hz"),
    "amplitude": Limit(0.0, 1e9),
    "record_scale": Limit(-1e9, 1e9),
    "max_order": Limit(0, 400, integer=True),
    "block_rows": Limit(0, 2000, integer=True),
    "n_channels": Limit(0, 4096, integer=True),
    "n_samples": Limit(0, 1 << 27, integer=True),
    "seed": Limit(0, 2**32 - 1, integer=True),
    "parameter": Limit(-1e300, 1e300),
    "n_parameters": Limit(0, 10_000, integer=True),
    "n_dof": Limit(1, 1 << 20, integer=True),
}
"""Limits of the request fields, by kind (the same kind is named the same in every node).

``n_dof`` bounds the DOFs of a matrix model (1,048,576): a sparse matrix may declare any
shape in a few bytes, and the modes of ``n`` DOFs take ``n`` x 61 floats of Lanczos basis
(488 MiB at the limit); the file limit lets a solid model's stiffness (about 80 entries a
row) reach about 400,000 DOFs."""


def check_field(value: object, name: str, kind: str) -> float:
    """Return ``value`` as a float (an int for integer kinds) inside ``LIMITS[kind]``.

    Raises
    ------
    OptionError
        Not a number, NaN / Inf, a fraction for an integer kind, or outside the limit;
        the message names the field, the range and the value.
    """
    lim = LIMITS[kind]
    try:
        v = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError, OverflowError):
        v = float("nan")
    ok = np.isfinite(v) and lim.lo <= v <= lim.hi and (not lim.integer or v == int(v))
    if not ok:
        what = "an integer" if lim.integer else "a finite number"
        msg = f"{name}: expected {what} in [{lim.lo:g}, {lim.hi:g}] {lim.unit}".rstrip()
        msg += f", got {value!r}"
        raise OptionError(msg)
    return int(v) if lim.integer else v


def check_array_budget(shape: tuple[int, ...], name: str,
                       budget_bytes: int = MEMORY_BUDGET_BYTES) -> None:
    """Refuse a float64 array of ``shape`` larger than ``budget_bytes`` before allocating it.

    Raises
    ------
    OptionError
        Naming the field, the shape, the bytes it would take and the budget.
    """
    n = 1
    for s in shape:
        n *= max(int(s), 0)
    if 8 * n > budget_bytes:
        msg = (f"{name}: expected at most {budget_bytes / 2**20:.0f} MiB, got shape {shape} "
               f"({8 * n / 2**20:.0f} MiB)")
        raise OptionError(msg)


def as_channels(
    x: object, name: str, *, min_samples: int = 2, allow_constant: bool = True
) -> FloatArray:
    """Return ``x`` as a finite float array of shape (n_channels, n_samples).

    A 1-D input is one channel. Raises :class:`ShapeError` for other ranks or too few
    samples and :class:`SignalError` for NaN / Inf or (if not allowed) constant channels.
    """
    a = np.asarray(x, dtype=np.float64)
    if a.ndim == 1:
        a = a[np.newaxis, :]
    if a.ndim != 2:
        msg = f"{name}: expected (n_channels, n_samples) or (n_samples,), got shape {a.shape}"
        raise ShapeError(msg)
    if a.shape[1] < min_samples:
        msg = f"{name}: expected at least {min_samples} samples, got {a.shape[1]}"
        raise ShapeError(msg)
    if a.shape[0] < 1:
        msg = f"{name}: expected at least 1 channel, got shape {a.shape}"
        raise ShapeError(msg)
    bad = ~np.isfinite(a)
    if bad.any():
        ch = np.unique(np.nonzero(bad)[0]).tolist()
        msg = f"{name}: expected finite samples, got NaN/Inf in channel(s) {ch}"
        raise SignalError(msg)
    if not allow_constant:
        spread = np.ptp(a, axis=1)
        scale = np.max(np.abs(a), axis=1)
        const = spread <= 1e-12 * np.maximum(scale, np.finfo(float).tiny)
        if const.any():
            ch = np.nonzero(const)[0].tolist()
            msg = f"{name}: expected varying channels, got constant channel(s) {ch}"
            raise SignalError(msg)
    return a


def check_positive(value: float, name: str) -> float:
    """Return ``value`` as float if finite and > 0, else raise :class:`OptionError`."""
    v = float(value)
    if not np.isfinite(v) or v <= 0.0:
        msg = f"{name}: expected a finite value > 0, got {value!r}"
        raise OptionError(msg)
    return v


def check_rank(x: FloatArray, name: str, *, rtol: float = 1e-10) -> None:
    """Raise :class:`SignalError` if the channels of ``x`` are linearly dependent.

    The test is on the singular values of the channel matrix relative to the largest.
    """
    s = np.linalg.svd(x - x.mean(axis=1, keepdims=True), compute_uv=False)
    if s.size == 0 or s[0] == 0.0:
        msg = f"{name}: expected non-zero signals, got all channels constant"
        raise SignalError(msg)
    rank = int(np.sum(s > rtol * s[0]))
    if rank < x.shape[0]:
        msg = (
            f"{name}: expected {x.shape[0]} linearly independent channels, got rank {rank} "
            f"(singular value ratio {s[-1] / s[0]:.2e})"
        )
        raise SignalError(msg)


NAME_PATTERN = re.compile(r"[A-Za-z0-9_-][A-Za-z0-9._-]{0,63}")
"""A name that becomes part of a file or folder name: letters, digits, ``. _ -``, at most
64 characters, not starting with a dot (no ``..``, no separator, no newline)."""


def check_name(value: object, name: str) -> str:
    """Return ``value`` if it is a safe name (:data:`NAME_PATTERN`), else refuse it.

    Every name that becomes part of a path (a run's name, a label, a component in a file
    name) passes here, where it becomes a path.

    Raises
    ------
    OptionError
        Naming the field and the value.
    """
    if not isinstance(value, str) or not NAME_PATTERN.fullmatch(value):
        msg = (f"{name}: expected letters, digits, '.', '_' or '-' (not starting with '.', "
               f"at most 64), got {value!r}")
        raise OptionError(msg)
    return value


REQUEST_FILE_MAX_BYTES = 256 * 2**20
"""Largest file a message or service request may make a node open (256 MiB)."""


def check_request_path(value: str, name: str, roots: Sequence[str | Path],
                       max_bytes: int = REQUEST_FILE_MAX_BYTES) -> Path:
    """Resolve a path received in a message inside one of ``roots``, or refuse it.

    A relative path is taken relative to the working folder and to each root in turn; the
    path, after ``..`` and symbolic links are resolved, must lie inside a root. The target
    must be a regular file (a FIFO or device would hang the node) of at most ``max_bytes``.

    Raises
    ------
    OptionError
        Naming the field, the path and the reason (outside the allowed folders, missing,
        not a regular file, too large).
    """
    text = str(value)
    if not text or "\x00" in text:
        msg = f"{name}: expected a file path, got {value!r}"
        raise OptionError(msg)
    bases = [Path(r).resolve() for r in roots]
    p = Path(text)
    candidates = [p.resolve()] if p.is_absolute() else [
        (b / p).resolve() for b in (Path.cwd(), *bases)]
    inside = [c for c in candidates if any(c.is_relative_to(b) for b in bases)]
    if not inside:
        msg = (f"{name}: expected a file inside {[str(b) for b in bases]}, got {text!r}")
        raise OptionError(msg)
    for c in inside:
        try:
            st = c.stat()
        except OSError:
            continue
        if not stat.S_ISREG(st.st_mode):
            msg = f"{name}: expected a regular file, got {text!r} (a FIFO, device or folder)"
            raise OptionError(msg)
        if st.st_size > max_bytes:
            msg = (f"{name}: expected at most {max_bytes / 2**20:.0f} MiB, got {text!r} "
                   f"({st.st_size / 2**20:.0f} MiB)")
            raise OptionError(msg)
        return c
    msg = f"{name}: no such file {text!r} in {[str(b) for b in bases]}"
    raise OptionError(msg)
