"""Where the model fails: per-channel errors grouped by place, direction and quantity.

Errors are Eq. (8) of [004] (RMS error per channel, percent) or any per-channel metric.
The bar chart has one panel per grouping (mean and largest error of each group); the table
lists the worst channels with their group.
"""

from __future__ import annotations

import html
from collections import defaultdict
from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import ArrayLike

from modal_twin.errors import ShapeError
from modal_twin.viz._figure import channel_parts, new_figure

__all__ = ["channel_groups", "plot_where", "where_table_html"]

Groups = Mapping[str, tuple[str, str, str]]


def channel_groups(names: Sequence[str], meta: Groups | None = None
                   ) -> list[tuple[str, str, str]]:
    """(place, direction, quantity) of each channel.

    From ``meta`` (the channel map's location / direction / quantity) where given, else from
    the name (:func:`~modal_twin.viz._figure.channel_parts`).
    """
    meta = meta or {}
    return [meta[n] if n in meta else channel_parts(n) for n in names]


def _check(names: Sequence[str], errors: ArrayLike) -> np.ndarray:
    e = np.atleast_1d(np.asarray(errors, dtype=float))
    if e.shape != (len(names),):
        msg = f"errors: expected {len(names)} values (one per channel name), got {e.shape}"
        raise ShapeError(msg)
    return e


def plot_where(names: Sequence[str], errors: ArrayLike, *, meta: Groups | None = None,
               metric: str = "RMS error, %", title: str = "where the model fails") -> Figure:
    """Bar charts of the mean (bar) and largest (dot) error per place, direction, quantity.

    Returns
    -------
    matplotlib.figure.Figure
        Three axes (place, direction, quantity); their tick labels are the group names.
    """
    e = _check(names, errors)
    parts = channel_groups(names, meta)
    fig = new_figure(11.0, 3.8)
    axes = fig.subplots(1, 3, width_ratios=[3, 1.2, 1.2])
    for a, (ax, what) in enumerate(zip(axes, ("place", "direction", "quantity"), strict=True)):
        by: dict[str, list[float]] = defaultdict(list)
        for p, v in zip(parts, e, strict=True):
            if np.isfinite(v):
                by[p[a]].append(v)
        keys = sorted(by)
        x = np.arange(len(keys))
        ax.bar(x, [np.mean(by[k]) for k in keys], color="tab:orange", label="mean")
        ax.plot(x, [np.max(by[k]) for k in keys], "kv", ms=5, label="largest")
        tilt = len(keys) > 6 or max((len(k) for k in keys), default=0) > 6
        ax.set_xticks(x, keys, rotation=40 if tilt else 0, ha="right" if tilt else "center",
                      fontsize=8)
        ax.set_title(f"by {what}", fontsize=9)
        ax.grid(True, axis="y", alpha=0.3)
    axes[0].set_ylabel(metric)
    axes[-1].legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8, frameon=False)
    fig.suptitle(title, fontsize=10)
    return fig


def where_table_html(names: Sequence[str], errors: ArrayLike, *, meta: Groups | None = None,
                     top: int = 15, metric: str = "RMS error [%]") -> str:
    """HTML table of the ``top`` worst channels with place, direction and quantity."""
    e = _check(names, errors)
    parts = channel_groups(names, meta)
    order = np.argsort(-np.nan_to_num(e, nan=-np.inf))[:top]
    rows = "".join(
        f"<tr><td>{html.escape(names[i])}</td><td>{html.escape(parts[i][0])}</td>"
        f"<td>{html.escape(parts[i][1])}</td><td>{html.escape(parts[i][2])}</td>"
        f"<td>{e[i]:.3g}</td></tr>" for i in order)
    return ('<table class="where"><tr><th>channel</th><th>place</th><th>direction</th>'
            f"<th>quantity</th><th>{html.escape(metric)}</th></tr>{rows}</table>")
