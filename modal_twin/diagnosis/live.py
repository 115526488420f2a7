"""Live where-it-fails from the twin's residual, without simulation.

It can run on a schedule beside the twin (the full diagnosis, with candidate fits, runs
on request).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from modal_twin.channels import ChannelSpec
from modal_twin.diagnosis.pipeline import Diagnosis
from modal_twin.diagnosis.where import where_it_fails
from modal_twin.errors import SignalError
from modal_twin.signal_block import SignalBlock, concatenate_blocks

__all__ = ["live_diagnosis"]


def _span(blocks: Sequence[SignalBlock]) -> SignalBlock:
    """Return the last contiguous run of blocks as one block."""
    run = [blocks[-1]]
    for b in reversed(blocks[:-1]):
        if b.next_index != run[0].first_index or b.channel_names != run[0].channel_names:
            break
        run.insert(0, b)
    return concatenate_blocks(run)


def live_diagnosis(frames: Sequence[SignalBlock], residuals: Sequence[SignalBlock],
                   channels: Mapping[str, ChannelSpec], *,
                   nmse_threshold_pct: float = 2.0) -> Diagnosis:
    """Find where the twin fails over the samples both streams cover.

    Predicted = measured + residual; the breakdown is the full diagnosis' but without
    candidates.

    Raises
    ------
    SignalError
        No frames or residuals, or no overlap between them.
    """
    if not frames or not residuals:
        msg = "live diagnosis: no frames or no twin residual received yet"
        raise SignalError(msg)
    meas, res = _span(frames), _span(residuals)
    i0 = max(meas.first_index, res.first_index)
    i1 = min(meas.next_index, res.next_index)
    names = [c for c in res.channel_names if c in meas.channel_names and c in channels]
    if i1 - i0 < 2 or not names:
        msg = (f"live diagnosis: frames [{meas.first_index}, {meas.next_index}) and residual "
               f"[{res.first_index}, {res.next_index}) do not overlap on known channels")
        raise SignalError(msg)
    y = meas.select(names).data[:, i0 - meas.first_index:i1 - meas.first_index]
    e = res.select(names).data[:, i0 - res.first_index:i1 - res.first_index]
    where = where_it_fails(y, y + e, tuple(channels[c] for c in names), meas.fs_hz,
                           n_windows=max(2, min(10, (i1 - i0) // 640)))
    worst = where.worst("location", 1)[0]
    significant = worst.nmse_pct > nmse_threshold_pct
    summary = (f"live (twin residual, {(i1 - i0) / meas.fs_hz:.1f} s): worst place {worst.key} "
               f"{worst.nmse_pct:.2f} % NMSE; "
               + ("significant: run the diagnosis for candidates" if significant
                  else "nothing significant"))
    return Diagnosis(significant, summary, where, (), ())
