"""A vehicle run in the report: the car's modes, ride indices and floor PSDs.

Plain data in, HTML tables and a matplotlib figure out (:mod:`modal_twin.viz.report`
embeds them). The figures themselves are computed by :mod:`modal_twin.models.ride`
(Sperling index, Welch floor PSD; Sec. 5.2 of [002]).
"""

from __future__ import annotations

import html
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from matplotlib.figure import Figure

from modal_twin._types import FloatArray
from modal_twin.errors import ShapeError
from modal_twin.viz._figure import new_figure

__all__ = ["RideRow", "car_modes_html", "plot_floor_psd", "ride_table_html"]


@dataclass(frozen=True, slots=True)
class RideRow:
    """Ride figures of one floor channel, record beside model.

    Attributes
    ----------
    channel : str
        Floor acceleration channel (``floor_mid_z``).
    direction : str
        ``vertical`` (Wz) or ``lateral`` (Wy).
    w_record, w_model : float
        Sperling index of the record and of the model run on its inputs.
    psd_error : float
        Relative floor-PSD power error of the model in the band, fraction.
    peak_hz : float
        Frequency of the record's largest floor-PSD peak, Hz.
    """

    channel: str
    direction: str
    w_record: float
    w_model: float
    psd_error: float
    peak_hz: float


def car_modes_html(labels: Sequence[str], f_hz: Sequence[float], zeta: Sequence[float]) -> str:
    """One row per carbody mode: number, type, frequency (Hz), damping ratio (%)."""
    rows = "".join(f"<tr><td>{k}</td><td>{html.escape(lab)}</td><td>{f:.3f}</td>"
                   f"<td>{100 * z:.2f}</td></tr>"
                   for k, (lab, f, z) in enumerate(zip(labels, f_hz, zeta, strict=True), 1))
    return ("<table><tr><th>mode</th><th>type</th><th>f [Hz]</th><th>&zeta; [%]</th></tr>"
            + rows + "</table>")


def ride_table_html(rows: Sequence[RideRow], band_hz: tuple[float, float]) -> str:
    """Return the ride table: Sperling W of record and model, PSD band error, peak."""
    lo, hi = band_hz
    body = "".join(
        f"<tr><td>{html.escape(r.channel)}</td><td>{html.escape(r.direction)}</td>"
        f"<td>{r.w_record:.3f}</td><td>{r.w_model:.3f}</td><td>{100 * r.psd_error:.2f}</td>"
        f"<td>{r.peak_hz:.2f}</td></tr>" for r in rows)
    return ("<table><tr><th>channel</th><th>direction</th><th>W record</th><th>W model</th>"
            f"<th>PSD {lo:g}-{hi:g} Hz error [%]</th><th>PSD peak [Hz]</th></tr>{body}"
            "</table>")


def plot_floor_psd(f_hz: FloatArray, psd_record: FloatArray, names: Sequence[str],
                   psd_model: FloatArray | None = None, *, f_max_hz: float = 40.0,
                   title: str = "floor acceleration PSD") -> Figure:
    """Floor PSDs on a log scale, one panel per channel: record (and model, dashed).

    Parameters
    ----------
    f_hz : (n_f,) float array
    psd_record : (n_ch, n_f) float array
        One-sided PSD, (m/s^2)^2/Hz.
    names : sequence of str
        One per row.
    psd_model : (n_ch, n_f) float array, optional
    f_max_hz : float
        Upper end of the axis.
    title : str

    Raises
    ------
    ShapeError
        Shapes that do not agree.
    """
    f = np.asarray(f_hz, dtype=float)
    P = np.atleast_2d(np.asarray(psd_record, dtype=float))
    if P.shape != (len(names), f.size) or (psd_model is not None
                                          and np.shape(psd_model) != P.shape):
        msg = f"psd: expected ({len(names)}, {f.size}) for record and model, got {P.shape}"
        raise ShapeError(msg)
    ncols = min(3, max(1, len(names)))
    nrows = -(-len(names) // ncols)
    fig = new_figure(4.0 * ncols, 2.6 * nrows + 0.4)
    sel = (f > 0) & (f <= f_max_hz)
    for i, name in enumerate(names):
        ax = fig.add_subplot(nrows, ncols, i + 1)
        ax.semilogy(f[sel], P[i, sel], lw=1.0, label="record")
        if psd_model is not None:
            ax.semilogy(f[sel], np.asarray(psd_model)[i, sel], "--", lw=1.0, color="tab:red",
                        label="model")
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("f [Hz]", fontsize=8)
        ax.set_ylabel("(m/s$^2$)$^2$/Hz", fontsize=8)
        ax.tick_params(labelsize=7)
        if i == 0:
            ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    return fig
