"""Error history of a model line.

One point per version, channels grouped so that many channels stay readable ("add the effect and
watch the error fall").

One small panel per direction / quantity group (acceleration x, y, z, drift, force ...);
in each, the median over the channels of the group as a line with the 10-90 % band, and
the worst place of the group named. Legend outside the panels, labels never cut
(constrained layout).

"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from modal_twin.models.versions import history
from modal_twin.paths import atomic_file, check_new
from modal_twin.viz._figure import channel_parts, new_figure

__all__ = ["error_history_figure", "plot_error_history"]


def _group_key(name: str) -> str:
    _place, direction, quantity = channel_parts(name)
    return f"{quantity} {direction}"


def error_history_figure(labels: Sequence[str], errors: Sequence[Mapping[str, float]], *,
                         metric: str = "held-out NMSE, %") -> Figure:
    r"""Small multiples of the per-channel error against model version.

    Parameters
    ----------
    labels : sequence of str
        One label per version (x ticks), e.g. ``"v1\\nstick_slip at ESB1"``.
    errors : sequence of mapping channel -> error
        Per-channel errors of each version (same order as ``labels``).
    metric : str
        Y axis label.

    Returns
    -------
    matplotlib.figure.Figure
        One axes per group (titled ``"<quantity> <direction> (<n> channels)"``), log y.
    """
    groups: dict[str, set[str]] = defaultdict(set)
    for e in errors:
        for ch in e:
            groups[_group_key(ch)].add(ch)
    keys = sorted(groups)
    ncols = min(3, max(1, len(keys)))
    nrows = int(np.ceil(len(keys) / ncols)) or 1
    fig = new_figure(3.6 * ncols + 1.6, 2.8 * nrows + 0.9)
    axes = fig.subplots(nrows, ncols, squeeze=False, sharex=True)
    x = np.arange(len(labels))
    for k, ax in enumerate(axes.flat):
        if k >= len(keys):
            ax.set_visible(False)
            continue
        chans = sorted(groups[keys[k]])
        Y = np.array([[e.get(c, np.nan) for c in chans] for e in errors], dtype=float)
        Y = np.where(Y > 0, Y, np.nan)
        ok = np.any(np.isfinite(Y), axis=1)
        lo = np.full(len(x), np.nan)
        med, hi = lo.copy(), lo.copy()
        lo[ok], med[ok], hi[ok] = np.nanpercentile(Y[ok], [10, 50, 90], axis=1)
        ax.fill_between(x, lo, hi, color="tab:blue", alpha=0.25, label="10-90 % of channels")
        ax.plot(x, med, "o-", color="tab:blue", label="median")
        ax.plot(x, np.nanmax(np.where(np.isfinite(Y), Y, -np.inf), axis=1,
                             initial=-np.inf), "v:", color="tab:red", ms=4, label="worst")
        ax.set_yscale("log")
        ax.set_title(f"{keys[k]} ({len(chans)} channels)", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.tick_params(labelsize=7)
    for ax in axes.flat:  # every panel labels its versions (hidden panels leave gaps)
        ax.set_xticks(x, labels, fontsize=7)
        ax.tick_params(labelbottom=True)
        ax.set_xlim(-0.5, len(labels) - 0.5)
    for row in axes:
        row[0].set_ylabel(metric, fontsize=8)
    handles, leg = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, leg, loc="outside right upper", fontsize=8, frameon=False)
    fig.suptitle("error history per channel group", fontsize=10)
    return fig


def version_labels(notes: Sequence[tuple[str, str]], width: int = 18) -> list[str]:
    r"""``"v1\\n<note cut to width>"`` for each (label, note)."""
    return [f"{lab}\n{note[:width]}" for lab, note in notes]


def plot_error_history(folder: str | Path, out_png: str | Path, *, force: bool = True
                       ) -> Path:
    """Write the error history of the model versions in ``folder`` as a PNG.

    Written to a temporary name and renamed (:func:`modal_twin.paths.atomic_file`); an
    existing ``out_png`` is refused unless ``force``, before the figure is drawn.
    """
    out = check_new(out_png, force)
    versions = history(folder)
    fig = error_history_figure(version_labels([(v.label, v.note) for v in versions]),
                               [v.errors for v in versions])
    with atomic_file(out, force=force) as tmp:
        fig.savefig(tmp, dpi=110)
    return out
