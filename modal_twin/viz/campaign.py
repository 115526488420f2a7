"""Plot a monitoring campaign: modal frequency and damping of every track against time."""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from modal_twin.identification.campaign import CampaignResult
from modal_twin.viz._png import save_png

__all__ = ["REAL_TIME_S", "plot_campaign"]

REAL_TIME_S = 315_532_800.0
"""Start times from this on (1980-01-01 UTC, in s since 1970) are real dates, not clocks."""


def plot_campaign(result: CampaignResult, out_png: str | Path, *, force: bool = True) -> Path:
    """Write a PNG: frequency (top) and damping (bottom) of each mode track against time.

    Windows with real start times (UTC, from the records' headers: after
    :data:`REAL_TIME_S`) are placed at their dates; otherwise time is in hours from the
    first window's start. Each track is one colour, with a marker per window that holds
    it. An existing ``out_png`` is refused unless ``force``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t0 = min((w.t_start_s for w in result.windows), default=0.0)
    real = t0 >= REAL_TIME_S
    fig, (af, az) = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    for k in range(result.n_tracks):
        t, f, z = result.track_series(k)
        h = ([datetime.fromtimestamp(v, tz=UTC) for v in t] if real
             else (t - t0) / 3600.0)
        af.plot(h, f, marker="o", ms=3, lw=0.8, label=f"track {k}: {np.median(f):.3g} Hz")
        az.plot(h, 100 * z, marker="o", ms=3, lw=0.8)
    af.set_ylabel("frequency, Hz")
    az.set_ylabel("damping, %")
    az.set_xlabel("start of the window (UTC)" if real else "time from the first window, h")
    if real:
        fig.autofmt_xdate()
    af.set_title(f"{len(result.windows)} windows, {result.n_tracks} mode tracks")
    for ax in (af, az):
        ax.grid(True, alpha=0.3)
    if result.n_tracks:
        af.legend(fontsize=7, ncol=3)
    return save_png(fig, out_png, force=force)
