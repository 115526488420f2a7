"""A drive signal cut into blocks as a clock makes them due (real time or a multiple)."""

from __future__ import annotations

from modal_twin._types import FloatArray
from modal_twin.excitation.drive import ExcitationConfig
from modal_twin.signal_block import SignalBlock

__all__ = ["WAIT_READERS_S", "DrivePlayer"]

WAIT_READERS_S = 15.0  # start anyway (and say so) when the readers have not matched by then


class DrivePlayer:
    """Blocks of one drive, paced against a clock started by :meth:`start`.

    Parameters
    ----------
    drive : (n_channels, n_samples) float array
        The whole drive (:func:`~modal_twin.excitation.drive.make_drive`).
    cfg : ExcitationConfig
        Channels, sample rate, block size and pace (``rate``: 1 = real time, 0 = all at once).
    first_index : int
        Stream index of the drive's first sample (streams continue across drives).
    """

    def __init__(self, drive: FloatArray, cfg: ExcitationConfig, first_index: int = 0,
                 *, created_s: float = 0.0) -> None:
        self.drive, self.cfg, self.first_index = drive, cfg, first_index
        self.next_sample = 0
        self.t0_s: float | None = None
        self.t0_ns = 0
        self.created_s = created_s  # monotonic time the drive was made (for the reader wait)

    def start_when_read(self, now_s: float, now_ns: int, readers: int) -> str | None:
        """Start the clock once ``cfg.wait_subscribers`` readers matched.

        Or after :data:`WAIT_READERS_S` without them; return a warning then, else None.
        """
        if self.started:
            return None
        waited = now_s - self.created_s
        if readers < self.cfg.wait_subscribers:
            if waited < WAIT_READERS_S:
                return None
            self.start(now_s, now_ns)
            return (f"starting without {self.cfg.wait_subscribers} matched readers after "
                    f"{waited:.0f} s")
        self.start(now_s, now_ns)
        return None

    @property
    def n_samples(self) -> int:
        """Samples in the drive."""
        return int(self.drive.shape[1])

    @property
    def started(self) -> bool:
        """True once :meth:`start` fixed the clock."""
        return self.t0_s is not None

    @property
    def finished(self) -> bool:
        """True when every sample has been handed out."""
        return self.next_sample >= self.n_samples

    def start(self, now_s: float, now_ns: int) -> None:
        """Fix the clock: sample 0 is due at ``now_s`` (monotonic) stamped ``now_ns``."""
        self.t0_s, self.t0_ns = now_s, now_ns

    def due(self, now_s: float) -> list[SignalBlock]:
        """Return the blocks due by ``now_s`` that were not handed out yet.

        (last one may be short).
        """
        if self.t0_s is None:
            return []
        cfg, n_total = self.cfg, self.n_samples
        pace = cfg.rate
        due = n_total if pace <= 0 else min(
            n_total, int((now_s - self.t0_s) * cfg.fs_hz * pace) + cfg.block_size)
        out = []
        while self.next_sample + cfg.block_size <= due or (
                due == n_total and self.next_sample < n_total):
            i0 = self.next_sample
            i1 = min(i0 + cfg.block_size, n_total)
            out.append(SignalBlock(tuple(cfg.channels), cfg.fs_hz, self.first_index + i0,
                                   self.drive[:, i0:i1],
                                   stamp_ns=self.t0_ns + round(i0 / cfg.fs_hz * 1e9),
                                   source="excitation"))
            self.next_sample = i1
        return out
