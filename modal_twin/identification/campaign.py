"""Monitoring campaigns: identify every window of long records and track the modes in time.

A structure in service is watched for months; its records arrive as many bags (or rotated
parts of one). Each record is cut into windows of ``window_s`` seconds; every window is
identified on its own by :func:`~modal_twin.identification.record.identify_record`
(output-only SSI-cov, or N4SID when inputs are measured), its modes picked from the
stabilization diagram (sec. 3 of [004]); the windows are independent
tasks and run on any executor (:mod:`modal_twin.executors`: serial, a process pool, a Dask
cluster). The modes of successive windows are then joined into *tracks*: a window's mode
continues the track whose last frequency and shape it is closest to, within a relative
frequency tolerance and above a MAC threshold (Eq. (6) of [002]), by an optimal
one-to-one assignment (``scipy.optimize.linear_sum_assignment``); a mode that continues no
track opens a new one. A track's frequency and damping against time is what a monitoring
campaign looks at (a stiffness loss shows as a step down of its frequency).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment

from modal_twin._types import ComplexArray, FloatArray, IntArray
from modal_twin.channels import ChannelSpec
from modal_twin.errors import OptionError, ShapeError, SignalError
from modal_twin.executors import ExecutorSpec, make_executor, map_ordered
from modal_twin.identification.metrics import mac
from modal_twin.identification.record import OUTPUT_ONLY, IdentifyOptions, identify_record
from modal_twin.signal_block import SignalBlock

__all__ = [
    "CampaignResult",
    "CampaignWindow",
    "WindowIdentifier",
    "WindowModes",
    "run_campaign",
    "split_windows",
    "track_modes",
]

_log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class CampaignWindow:
    """One window of a record: the task of one identification.

    Attributes
    ----------
    source : str
        Record it came from (e.g. the bag path).
    index : int
        Window number within its record.
    t_start_s : float
        Time of its first sample (s, the record's clock).
    fs_hz : float
    y : (n_out, n) float array
        Outputs.
    u : (n_in, n) float array, optional
        Measured inputs (N4SID); None for output-only identification.
    """

    source: str
    index: int
    t_start_s: float
    fs_hz: float
    y: FloatArray
    u: FloatArray | None = None


@dataclass(frozen=True, slots=True)
class WindowModes:
    """Modes identified in one window (``f_hz`` ascending; ``shapes`` (n_out, n_modes))."""

    source: str
    index: int
    t_start_s: float
    duration_s: float
    f_hz: FloatArray
    zeta: FloatArray
    shapes: ComplexArray
    error: str = ""


def split_windows(block: SignalBlock, window_s: float, *, outputs: Sequence[str],
                  inputs: Sequence[str] = (), source: str | None = None,
                  ) -> list[CampaignWindow]:
    """Cut a record into consecutive windows of ``window_s`` seconds (a short tail is dropped).

    Raises
    ------
    OptionError
        ``window_s`` not positive or longer than the record.
    SignalError
        Unknown channel names.
    """
    n = round(window_s * block.fs_hz)
    if not np.isfinite(window_s) or n < 2:
        msg = f"window_s: expected a positive duration of >= 2 samples, got {window_s!r}"
        raise OptionError(msg)
    if n > block.n_samples:
        msg = (f"window_s: expected at most the record's {block.n_samples / block.fs_hz:.6g} s "
               f"({source or block.source}), got {window_s!r}")
        raise OptionError(msg)
    y = block.select(tuple(outputs)).data
    u = block.select(tuple(inputs)).data if inputs else None
    t0 = block.stamp_ns / 1e9
    return [CampaignWindow(source if source is not None else block.source, k,
                           t0 + k * n / block.fs_hz, block.fs_hz, y[:, k * n:(k + 1) * n],
                           None if u is None else u[:, k * n:(k + 1) * n])
            for k in range(block.n_samples // n)]


@dataclass(frozen=True, slots=True)
class WindowIdentifier:
    """Picklable ``CampaignWindow -> WindowModes``: one identification per window.

    Each window goes through :func:`~modal_twin.identification.record.identify_record`
    (as ``modal-twin identify`` and the node), its outputs of role ``output`` and its
    inputs of role ``input``.

    Attributes
    ----------
    method : {"ssi-cov", "n4sid", "polymax"}
    orders : tuple of int, optional
        Model orders of the stabilization diagram (None: from the window).
    f_range_hz : (float, float), optional
        Band of the analysis and of the modes kept (None: from the window).
    zeta_max : float
        Damping above this is not a physical mode.
    """

    method: str = "ssi-cov"
    orders: tuple[int, ...] | None = tuple(range(8, 41, 2))
    f_range_hz: tuple[float, float] | None = None
    zeta_max: float = 0.2

    def __post_init__(self) -> None:
        self.options()  # a bad method or band fails here, before any window

    def options(self) -> IdentifyOptions:
        """Return the options of every window's :func:`identify_record`."""
        lo, hi = self.f_range_hz if self.f_range_hz is not None else (None, None)
        return IdentifyOptions(method=self.method, orders=self.orders,
                               f_min_hz=lo if lo else None,
                               f_max_hz=hi if hi is not None and np.isfinite(hi) else None,
                               zeta_max=self.zeta_max, n_blocks_std=0)

    def __call__(self, w: CampaignWindow) -> WindowModes:
        """Identify ``w``; a window that cannot be identified gives no modes and its error."""
        try:
            if self.method == "n4sid" and w.u is None:
                msg = f"window {w.index} of {w.source}: {self.method} needs inputs, got none"
                raise OptionError(msg)
            u = w.u if w.u is not None and self.method not in OUTPUT_ONLY else None
            n_in = 0 if u is None else u.shape[0]
            names = tuple(f"u{k}" for k in range(n_in)) + tuple(
                f"y{k}" for k in range(w.y.shape[0]))
            chans = [ChannelSpec(n, "acceleration", role="input" if n[0] == "u" else "output")
                     for n in names]
            data = w.y if u is None else np.vstack([u, w.y])
            blk = SignalBlock(names, w.fs_hz, 0, data, source=w.source)
            mm = identify_record(blk, chans, self.options()).modes
        except (SignalError, OptionError, ShapeError, np.linalg.LinAlgError) as err:
            _log.warning("window %d of %s: %s", w.index, w.source, err)
            e = np.zeros(0)
            return WindowModes(w.source, w.index, w.t_start_s, w.y.shape[1] / w.fs_hz, e, e,
                               np.zeros((w.y.shape[0], 0), complex), str(err))
        return WindowModes(w.source, w.index, w.t_start_s, w.y.shape[1] / w.fs_hz,
                           mm.f_hz, mm.zeta, mm.shapes)


@dataclass(frozen=True, slots=True)
class CampaignResult:
    """Modes of every window and their tracks.

    Attributes
    ----------
    channel_names : tuple of str
        Outputs the shapes refer to.
    windows : tuple of WindowModes
        In time order.
    track : tuple of (n_modes_w,) int arrays
        Track number of each mode of each window.
    mac_to_track : tuple of (n_modes_w,) float arrays
        MAC of each mode with its track's previous shape (1 where it opens the track).
    """

    channel_names: tuple[str, ...]
    windows: tuple[WindowModes, ...]
    track: tuple[IntArray, ...]
    mac_to_track: tuple[FloatArray, ...] = field(default=())

    @property
    def n_tracks(self) -> int:
        """Number of tracks."""
        return 1 + max((int(t.max()) for t in self.track if t.size), default=-1)

    def rows(self) -> list[dict[str, object]]:
        """One row per (window, mode): the campaign table."""
        out: list[dict[str, object]] = []
        for w, tr, mc in zip(self.windows, self.track, self.mac_to_track, strict=True):
            for j in range(w.f_hz.size):
                out.append({"source": w.source, "window": w.index, "t_start_s": w.t_start_s,
                            "duration_s": w.duration_s, "track": int(tr[j]),
                            "f_hz": float(w.f_hz[j]), "zeta": float(w.zeta[j]),
                            "mac_to_track": float(mc[j])})
        return out

    def track_series(self, k: int) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``(t_start_s, f_hz, zeta)`` of track ``k`` over the windows that hold it."""
        t, f, z = [], [], []
        for w, tr in zip(self.windows, self.track, strict=True):
            for j in np.flatnonzero(tr == k):
                t.append(w.t_start_s)
                f.append(w.f_hz[j])
                z.append(w.zeta[j])
        return np.array(t), np.array(f), np.array(z)


def track_modes(windows: Sequence[WindowModes], *, rel_tol_f: float = 0.10,
                mac_min: float = 0.8) -> tuple[tuple[IntArray, ...], tuple[FloatArray, ...]]:
    """Join the modes of successive windows into tracks (module docstring).

    The cost of continuing a track is ``|f - f_track| / f_track / rel_tol_f +
    (1 - MAC) / (1 - mac_min)``, admissible only within both limits; the assignment
    minimises the summed cost one-to-one.

    Returns
    -------
    track : tuple of int arrays
        Track number of each mode, per window.
    mac_to_track : tuple of float arrays
    """
    if not (rel_tol_f > 0 and 0 <= mac_min < 1):
        msg = (f"rel_tol_f, mac_min: expected > 0 and in [0, 1), got {rel_tol_f!r}, "
               f"{mac_min!r}")
        raise OptionError(msg)
    ref_f: list[float] = []
    ref_s: list[ComplexArray] = []
    tracks, macs = [], []
    for w in windows:
        lab = np.full(w.f_hz.size, -1, dtype=np.int64)
        mv = np.ones(w.f_hz.size)
        if ref_f and w.f_hz.size:
            mac_w = mac(w.shapes, np.stack(ref_s, axis=1))  # Eq. (6) of [002]
            df = np.abs(w.f_hz[:, None] - np.array(ref_f)[None, :]) / np.array(ref_f)[None, :]
            ok = (df <= rel_tol_f) & (mac_w >= mac_min)
            cost = np.where(ok, df / rel_tol_f + (1 - mac_w) / (1 - mac_min), 1e6)
            for i, k in zip(*linear_sum_assignment(cost), strict=True):
                if ok[i, k]:
                    lab[i], mv[i] = k, mac_w[i, k]
        for i in range(w.f_hz.size):
            if lab[i] < 0:
                lab[i] = len(ref_f)
                ref_f.append(0.0)
                ref_s.append(w.shapes[:, i])
            ref_f[lab[i]], ref_s[lab[i]] = float(w.f_hz[i]), w.shapes[:, i]
        tracks.append(lab)
        macs.append(mv)
    return tuple(tracks), tuple(macs)


def run_campaign(
    windows: Sequence[CampaignWindow], channel_names: Sequence[str], *,
    identifier: WindowIdentifier | None = None, executor: ExecutorSpec = None,
    rel_tol_f: float = 0.10, mac_min: float = 0.8,
    progress: Callable[[str], None] | None = None,
) -> CampaignResult:
    """Identify every window on ``executor`` and track the modes (module docstring).

    Parameters
    ----------
    windows : sequence of CampaignWindow
        From :func:`split_windows`, any number of records; sorted by start time here.
    channel_names : sequence of str
        The outputs (rows of every window's ``y``).
    identifier : WindowIdentifier, optional
        Method and options (default SSI-cov, orders 8-40).
    executor : ExecutorSpec
        :func:`~modal_twin.executors.make_executor` spec or an executor; the result does
        not depend on it.
    rel_tol_f, mac_min
        :func:`track_modes` limits.

    Raises
    ------
    OptionError
        No windows.
    ShapeError
        Windows with different numbers of outputs.
    """
    if not windows:
        msg = "windows: expected at least one window, got none (records shorter than --window?)"
        raise OptionError(msg)
    n_out = {w.y.shape[0] for w in windows}
    if n_out != {len(channel_names)}:
        msg = f"windows: expected {len(channel_names)} outputs each, got {sorted(n_out)}"
        raise ShapeError(msg)
    ws = sorted(windows, key=lambda w: (w.t_start_s, w.source, w.index))
    ident = identifier or WindowIdentifier()
    with make_executor(executor) as ex:
        if progress:
            progress(f"identifying {len(ws)} windows on {type(ex).__name__}")
        out = map_ordered(ex, ident, ws)
    track, macs = track_modes(out, rel_tol_f=rel_tol_f, mac_min=mac_min)
    return CampaignResult(tuple(channel_names), tuple(out), track, macs)
