"""Bags to the diagnosis's :class:`~modal_twin.diagnosis.record.Record`.

A damaged bag gives its good part: frames that do not decode are skipped and a missing
stretch of samples splits the record into runs (:func:`~modal_twin.io.bag.read_frames`);
what was skipped and where is logged as one warning.
"""

from __future__ import annotations

import logging
from dataclasses import replace
from pathlib import Path

import numpy as np

from modal_twin.diagnosis.record import Record, record_from_blocks
from modal_twin.errors import SignalError
from modal_twin.io.bag import FrameRead, read_frames
from modal_twin.io.channel_map import MAP_FILE, read_channel_map
from modal_twin.models.plant import Plant
from modal_twin.signal_block import SignalBlock

__all__ = ["record_from_bag", "records_from_bag", "run_skips", "settling_samples"]

log = logging.getLogger(__name__)


def record_from_bag(bag: str | Path, topic: str = "/measurement/frames", *,
                    plant: Plant | None = None) -> Record:
    """Read the measurement frames of a bag as one :class:`Record`.

    A bag written by ``modal-twin import`` carries its channel map (``BAG/channel_map.json``):
    then the channels' roles say what is an input and what a response, and ``plant`` (the
    model the record is compared with) names them (:func:`record_from_blocks`). Without a
    map, the naming rule of the shipped scenarios applies (``table_*`` are the inputs). A
    damaged bag gives its best contiguous run (module docstring): with ``plant``, the one
    with the most samples scored (:func:`records_from_bag`), else the longest; what was
    skipped and where is logged.
    """
    pairs, frames = _run_records(bag, topic, plant)
    if len(frames.runs) == 1 and not frames.skipped:
        return pairs[0][1]
    if not pairs:
        msg = (f"bag {bag}: no run of frames long enough to use (every run after a gap "
               f"shorter than the model's settling time; {frames.note()})")
        raise SignalError(msg)
    used, rec = max(pairs, key=lambda br: br[1].n_samples - br[1].skip)
    log.warning("bag %s, %s: %s", bag, topic, frames.note(used))
    return rec


def records_from_bag(bag: str | Path, topic: str = "/measurement/frames", *,
                     plant: Plant | None = None) -> tuple[list[Record], FrameRead]:
    """Read every usable contiguous run of a bag's frames as a :class:`Record`.

    Gaps stay gaps. With ``plant``, a run that starts after a gap (or after a lost first
    message) starts from an unknown state: its first :func:`settling_samples` are simulated
    but not scored (``Record.skip``), and a run shorter than that is left out; the first
    run starts where the record starts (from rest, as any record). Runs of fewer than 2
    samples are left out. The channel map applies as in :func:`record_from_bag`.
    """
    pairs, frames = _run_records(bag, topic, plant)
    return [rec for _, rec in pairs], frames


def _run_records(bag: str | Path, topic: str, plant: Plant | None
                 ) -> tuple[list[tuple[SignalBlock, Record]], FrameRead]:
    """Return the usable runs of :func:`records_from_bag`, each with its frames."""
    p = Path(bag)
    channels = read_channel_map(p / MAP_FILE) if (p / MAP_FILE).is_file() else None
    frames = read_frames(bag, topic)
    skips = run_skips(plant, frames) if plant is not None else [0] * len(frames.runs)
    out = []
    for b, skip in zip(frames.runs, skips, strict=True):
        if b.n_samples >= 2 and skip < b.n_samples - 1:
            rec = record_from_blocks([b], source=str(bag), channels=channels, plant=plant)
            out.append((b, replace(rec, skip=skip) if skip else rec))
    return out, frames


def settling_samples(plant: Plant, fs_hz: float, fraction: float = 0.01) -> int:
    """Return the samples until the model's slowest free decay falls to ``fraction``.

    From the slowest pole of the linear part, ``exp(-sigma t) = fraction``, with the poles
    the eigenvalues of ``[[0, I], [-M^-1 K, -M^-1 C]]`` (devices left out).
    """
    sysm = plant.system
    n = sysm.M.shape[0]
    try:
        Minv = np.linalg.inv(sysm.M)
        A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ sysm.K, -Minv @ sysm.C]])
        sigma = float(np.min(-np.linalg.eigvals(A).real))
    except (np.linalg.LinAlgError, ValueError):
        sigma = 0.0
    if not sigma > 0:  # no decay to wait for: a run after a gap is never scored
        return 2**62
    return int(np.ceil(np.log(1.0 / fraction) / sigma * fs_hz))


def run_skips(plant: Plant, frames: FrameRead) -> list[int]:
    """Return the samples of each run to simulate but not score (:func:`records_from_bag`).

    0 for the first run when nothing before it was lost; :func:`settling_samples` for
    every other.
    """
    if len(frames.runs) == 1 and not frames.skipped:
        return [0]
    warm = settling_samples(plant, frames.runs[0].fs_hz)
    t0 = frames.runs[0].stamp_ns
    clean_start = not any(t < t0 for _, t, _ in frames.skipped)
    return [0 if k == 0 and clean_start else warm for k in range(len(frames.runs))]
