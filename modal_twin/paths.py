"""Find configuration files wherever a scenario is run from; the folders requests may name.

Paths are given relative to the working folder, the source tree or the installed
package share (``share/modal_twin``). A message or a service request may name a file only
inside :func:`request_roots`: the run folders (``runs/`` of the working folder) and the
model folders of the configuration (``config/structures``, ``config/vehicles``,
``config/channel_maps``), never the rest of the source tree.
"""

from __future__ import annotations

import os
import stat
import sys
from pathlib import Path
from typing import BinaryIO

from modal_twin.errors import ConfigError

__all__ = ["MODEL_FOLDERS", "RUNS", "check_regular", "config_roots", "open_regular",
           "request_roots", "resolve_config"]

MODEL_FOLDERS = ("config/structures", "config/vehicles", "config/channel_maps")
"""The model folders of a configuration root a request may name a file in (README)."""
RUNS = "runs"
"""The run folder of the working folder: launches, imports, model versions, the demo."""

_ROOTS = (Path(__file__).resolve().parents[1], Path(sys.prefix) / "share" / "modal_twin")


def resolve_config(path: str | Path) -> Path:
    """Return ``path`` itself if it exists, else the first of source tree / share that holds it.

    Unchanged when none does (the caller's error then names it).
    """
    p = Path(path)
    if p.is_absolute() or p.exists():
        return p
    for root in _ROOTS:
        if (root / p).exists():
            return root / p
    return p


def config_roots() -> tuple[Path, ...]:
    """Return the folders configuration files are looked up in (source tree, package share)."""
    return tuple(r for r in _ROOTS if r.is_dir())


def request_roots(*more: str | Path) -> tuple[Path, ...]:
    """Folders a message or request may name a file in, resolved.

    ``runs/`` of the working folder, the folders ``more`` (a node's own run or model folder)
    and :data:`MODEL_FOLDERS` of the source tree and the package share.
    """
    out = [Path.cwd() / RUNS, *(Path(m) for m in more)]
    out += [r / f for r in _ROOTS for f in MODEL_FOLDERS]
    return tuple(dict.fromkeys(p.resolve() for p in out))


def open_regular(path: str | Path, what: str = "file") -> BinaryIO:
    """Open ``path`` for reading if it is a regular file (after symbolic links), else refuse.

    Opened with ``O_NONBLOCK`` and checked with ``fstat`` before anything is read, so a FIFO
    or a device named in a file or a message never blocks the reader.

    Raises
    ------
    ConfigError
        Missing, unreadable, or not a regular file (FIFO, device, folder).
    """
    p = Path(path)
    try:
        fd = os.open(p, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except FileNotFoundError as err:
        msg = f"{p}: no such {what}"
        raise ConfigError(msg) from err
    except OSError as err:
        msg = f"{p}: cannot read {what} ({err.strerror})"
        raise ConfigError(msg) from err
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        msg = f"{p}: expected a regular {what}, got a FIFO, device or folder"
        raise ConfigError(msg)
    os.set_blocking(fd, True)
    return os.fdopen(fd, "rb")


def check_regular(path: str | Path, what: str = "file", *, missing_ok: bool = False) -> Path:
    """Return ``path`` if it is a regular file (after symbolic links); never opens it.

    Raises
    ------
    ConfigError
        Missing (unless ``missing_ok``), or not a regular file (a FIFO would block its reader).
    """
    p = Path(path)
    try:
        mode = p.stat().st_mode
    except FileNotFoundError:
        if missing_ok:
            return p
        msg = f"{p}: no such {what}"
        raise ConfigError(msg) from None
    except OSError as err:
        msg = f"{p}: cannot read {what} ({err.strerror})"
        raise ConfigError(msg) from err
    if not stat.S_ISREG(mode):
        msg = f"{p}: expected a regular {what}, got a FIFO, device or folder"
        raise ConfigError(msg)
    return p
