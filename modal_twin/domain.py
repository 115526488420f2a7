"""Reserve a ROS domain id on this host for as long as one graph lives in it.

Two graphs on one host in one domain see each other's nodes: a launcher could start
another run's excitation (seen: a demo's training record got a second drive from a test's
launcher that drew the same id). A domain is taken here when

- any UDP port of its RTPS range is bound (a participant's discovery or data locators,
  read from ``/proc/net/udp``): a graph of any program on this host, or
- another process holds its lock: an exclusive ``flock`` on ``<folder>/<id>.lock``, taken
  without waiting and kept until :meth:`DomainReservation.release` (or the holder's exit:
  a lock dies with its process, so a crashed run never keeps a domain). The lock covers the
  time between the draw and the graph's first bound port, in which two processes that only
  looked at the ports could draw the same id (parallel test workers, two launches).

The lock folder is ``$XDG_RUNTIME_DIR/modal_twin-domains`` or
``<tempdir>/modal_twin-domains-<uid>``, private to the user (0700); one that is not (owned
by another user, a link, open to others) is not used, and the ports alone decide (logged).
No rclpy here: the launcher and the test fixtures both use it.
"""

from __future__ import annotations

import fcntl
import logging
import os
import random
import stat
import tempfile
from collections.abc import Iterable
from pathlib import Path

from modal_twin.errors import LaunchError

__all__ = ["DomainReservation", "domain_lock_folder", "reserve_domain"]

log = logging.getLogger(__name__)

# RTPS port mapping (Fast DDS defaults): every port of domain d lies in
# [PB + DG d, PB + DG (d + 1)); d <= 232 keeps them below 65536
_PORT_BASE, _DOMAIN_GAIN, _MAX_DOMAIN = 7400, 250, 232


def _udp_ports_in_use() -> set[int]:
    """Local UDP ports bound on this host (``/proc/net/udp``, ``udp6``; empty elsewhere)."""
    ports: set[int] = set()
    for table in ("/proc/net/udp", "/proc/net/udp6"):
        try:
            lines = Path(table).read_text().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            fields = line.split()
            if len(fields) > 1 and ":" in fields[1]:
                ports.add(int(fields[1].rsplit(":", 1)[1], 16))
    return ports


def domains_bound(ports: Iterable[int]) -> set[int]:
    """Return the domain ids whose RTPS port range holds one of ``ports``."""
    return {(p - _PORT_BASE) // _DOMAIN_GAIN for p in ports if p >= _PORT_BASE}


def domain_lock_folder() -> Path:
    """Return the per-user folder of the domain locks (not created here)."""
    runtime = os.environ.get("XDG_RUNTIME_DIR")
    if runtime and Path(runtime).is_dir():
        return Path(runtime) / "modal_twin-domains"
    return Path(tempfile.gettempdir()) / f"modal_twin-domains-{os.getuid()}"


def _private_folder(folder: Path) -> bool:
    """Create ``folder`` 0700 if missing; True when it is this user's own and closed to others."""
    try:
        folder.mkdir(mode=0o700, exist_ok=True)
        st = os.lstat(folder)
    except OSError as e:
        log.warning("domain locks: cannot use %s (%s); the bound ports alone decide", folder, e)
        return False
    if not stat.S_ISDIR(st.st_mode) or st.st_uid != os.getuid() or st.st_mode & 0o077:
        log.warning("domain locks: %s is not a folder private to this user; the bound ports "
                    "alone decide", folder)
        return False
    return True


def _try_lock(folder: Path, domain_id: int) -> int | None:
    """Open and lock ``<folder>/<domain_id>.lock`` without waiting: its descriptor, or None."""
    flags = os.O_RDWR | os.O_CREAT | os.O_CLOEXEC | os.O_NOFOLLOW
    try:
        fd = os.open(folder / f"{domain_id}.lock", flags, 0o600)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:  # held by another process (or another reservation of this one)
        os.close(fd)
        return None
    return fd


class DomainReservation:
    """A ROS domain id held for this process until :meth:`release` (or its exit).

    A context manager: ``with reserve_domain() as r: ... r.domain_id ...``.
    """

    def __init__(self, domain_id: int, fd: int | None) -> None:
        self.domain_id = domain_id
        self._fd = fd

    @property
    def held(self) -> bool:
        """True while the lock is held (False after release, or with no lock folder)."""
        return self._fd is not None

    def release(self) -> None:
        """Give the domain back (closing the lock file releases its lock); idempotent."""
        fd, self._fd = self._fd, None
        if fd is not None:
            os.close(fd)

    def __del__(self) -> None:  # a reservation dropped unreleased: its descriptor too
        self.release()

    def __enter__(self) -> DomainReservation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()

    def __repr__(self) -> str:
        return f"DomainReservation({self.domain_id}, held={self.held})"


def reserve_domain(rng: random.Random | None = None, *,
                   folder: Path | None = None) -> DomainReservation:
    """Reserve a ROS domain id, drawn at random from 1..232, that no process here uses.

    Parameters
    ----------
    rng
        The draw's generator (system randomness by default).
    folder
        The lock folder (default :func:`domain_lock_folder`).

    Returns
    -------
    DomainReservation
        The id and its lock, held until released or this process exits.

    Raises
    ------
    LaunchError
        Every domain is bound or locked (name one with ``ROS_DOMAIN_ID``).
    """
    pick = rng or random.SystemRandom()
    busy = domains_bound(_udp_ports_in_use())
    free = [d for d in range(1, _MAX_DOMAIN + 1) if d not in busy]
    pick.shuffle(free)
    folder = folder or domain_lock_folder()
    if not _private_folder(folder):
        if free:
            return DomainReservation(free[0], None)
    else:
        for d in free:
            fd = _try_lock(folder, d)
            if fd is not None:
                return DomainReservation(d, fd)
    msg = (f"no free ROS domain: all of 1..{_MAX_DOMAIN} have bound ports or are reserved "
           f"(locks in {folder}); set ROS_DOMAIN_ID")
    raise LaunchError(msg)
