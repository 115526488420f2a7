"""Find configuration files wherever a scenario is run from; the folders requests may name.

Paths are given relative to the working folder, the source tree or the installed
package share (``share/modal_twin``). A message or a service request may name a file only
inside :func:`request_roots`: the run folders (``runs/`` of the working folder) and the
model folders of the configuration (``config/structures``, ``config/vehicles``,
``config/channel_maps``), never the rest of the source tree.
"""

from __future__ import annotations

import os
import shutil
import stat
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import BinaryIO

from modal_twin.errors import BagError, ConfigError

__all__ = ["MODEL_FOLDERS", "RUNS", "TEMP_PREFIX", "UMASK", "atomic_dir", "atomic_file",
           "check_new", "check_new_in", "check_regular", "clean_stale", "config_roots",
           "open_regular", "private_files", "request_roots", "resolve_config"]

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


def open_regular(path: str | Path, what: str = "file", *, follow: bool = True) -> BinaryIO:
    """Open ``path`` for reading if it is a regular file (after symbolic links), else refuse.

    Opened with ``O_NONBLOCK`` and checked with ``fstat`` before anything is read, so a FIFO
    or a device named in a file or a message never blocks the reader. ``follow=False``
    refuses a symbolic link itself (``O_NOFOLLOW``).

    Raises
    ------
    ConfigError
        Missing, unreadable, or not a regular file (FIFO, device, folder).
    """
    p = Path(path)
    try:
        flags = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0)
        fd = os.open(p, flags if follow else flags | os.O_NOFOLLOW)
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


UMASK = 0o077
"""The one file-mode policy: what the project writes is private to its user (files 0600,
folders 0700), set by :func:`private_files` in every entry point (the command line, the
launcher's nodes, a node started on its own)."""


def private_files() -> None:
    """Set the process's umask to :data:`UMASK` (inherited by the processes it starts)."""
    os.umask(UMASK)


TEMP_PREFIX = ".modal_twin-tmp-"
"""Prefix of the temporary file or folder an output is written to before its rename:
``.modal_twin-tmp-<pid>-<name>.<random>`` beside the target."""


def clean_stale(folder: str | Path) -> list[Path]:
    """Remove the temporaries in ``folder`` left by a killed process; return them.

    Only those of processes no longer alive (the PID in the name), so a concurrent writer's
    temporary stays.
    """
    out: list[Path] = []
    try:
        entries = list(Path(folder).iterdir())
    except OSError:
        return out
    for e in entries:
        if not e.name.startswith(TEMP_PREFIX):
            continue
        pid = e.name[len(TEMP_PREFIX):].partition("-")[0]
        if not pid.isdigit() or _alive(int(pid)):
            continue
        if e.is_dir() and not e.is_symlink():
            shutil.rmtree(e, ignore_errors=True)
        else:
            e.unlink(missing_ok=True)
        out.append(e)
    return out


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def check_new(target: str | Path, force: bool) -> Path:
    """Return ``target`` unless it exists and ``force`` is not given.

    Raises
    ------
    ConfigError
        ``target`` exists (outputs never overwrite silently: ``--force``).
    """
    t = Path(target)
    if not force and (t.exists() or t.is_symlink()):
        msg = f"{t} exists; give --force to overwrite it"
        raise ConfigError(msg)
    return t


def check_new_in(folder: str | Path, names: tuple[str, ...], force: bool) -> list[Path]:
    """Return the outputs ``folder/name`` of a command writing into a folder, each checked.

    The folder may exist (several commands write into one); the files it would hold may
    not, unless ``force`` (:func:`check_new`).

    Raises
    ------
    ConfigError
        ``folder`` is a file, or one of the outputs exists and ``force`` is not given.
    """
    f = Path(folder)
    if f.exists() and not f.is_dir():
        msg = f"{f}: expected a folder for the outputs, got a file"
        raise ConfigError(msg)
    _check_creatable(f)
    return [check_new(f / n, force) for n in names]


def _check_creatable(folder: Path) -> None:
    """Refuse, before any work, a folder whose nearest existing parent takes no new entry.

    A probe (a temporary folder made and removed in that parent) rather than a permission
    test: as root every permission test passes, yet ``/proc`` or a read-only mount refuse.
    """
    base = folder.absolute()
    while not base.exists():
        base = base.parent
    if not base.is_dir():
        msg = f"{folder}: {base} is a file, not a folder"
        raise ConfigError(msg)
    try:
        Path(tempfile.mkdtemp(prefix=".modal_twin_probe_", dir=base)).rmdir()
    except OSError as err:
        msg = f"{folder}: cannot write in {base} ({err.strerror or err})"
        raise ConfigError(msg) from err


@contextmanager
def atomic_dir(target: str | Path) -> Iterator[Path]:
    """Return a temporary folder renamed to ``target`` on success, removed on failure.

    The temporary sits beside ``target`` (:data:`TEMP_PREFIX`); one left by a killed
    process is removed the next time anything is written there (:func:`clean_stale`).
    """
    t = Path(target)
    if t.exists():
        msg = f"{t} exists already; choose a new path"
        raise BagError(msg)
    t.parent.mkdir(parents=True, exist_ok=True)
    clean_stale(t.parent)
    tmp = Path(tempfile.mkdtemp(prefix=f"{TEMP_PREFIX}{os.getpid()}-{t.name}.", dir=t.parent))
    work = tmp / t.name
    try:
        yield work
        os.replace(work, t)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@contextmanager
def atomic_file(target: str | Path, *, force: bool = True) -> Iterator[Path]:
    """Return a temporary file path renamed to ``target`` on success, removed on failure.

    Without ``force`` an existing ``target`` is refused (:func:`check_new`) before anything
    is written. The temporary is created with the umask's mode (:data:`UMASK`).
    """
    t = check_new(target, force)
    t.parent.mkdir(parents=True, exist_ok=True)
    clean_stale(t.parent)
    fd, name = tempfile.mkstemp(prefix=f"{TEMP_PREFIX}{os.getpid()}-{t.name}.",
                                suffix=t.suffix, dir=t.parent)
    mask = os.umask(UMASK)
    os.umask(mask)
    os.fchmod(fd, 0o666 & ~mask)
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        os.replace(tmp, t)
    finally:
        tmp.unlink(missing_ok=True)
