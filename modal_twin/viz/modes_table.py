"""Modes table, identified vs model, as an HTML table (for the report and ``identify``)."""

from __future__ import annotations

import html
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from modal_twin.errors import ShapeError

__all__ = ["modes_table_html"]


def _cell(v: float, fmt: str) -> str:
    return "&ndash;" if not np.isfinite(v) else format(v, fmt)


def modes_table_html(f_id_hz: ArrayLike, zeta_id: ArrayLike, *,
                     f_model_hz: ArrayLike | None = None, zeta_model: ArrayLike | None = None,
                     mac: ArrayLike | None = None, labels: Sequence[str] | None = None,
                     mac_warn: float = 0.8) -> str:
    """One row per identified mode, with its paired model mode where given.

    Parameters
    ----------
    f_id_hz, zeta_id : (n,) array_like
        Identified frequencies (Hz) and damping ratios (fraction).
    f_model_hz, zeta_model : (n,) array_like, optional
        Paired model values (NaN where unpaired).
    mac : (n,) array_like, optional
        MAC of each pair.
    labels : sequence of str, optional
        Mode labels (default ``1 .. n``).
    mac_warn : float
        Pairs with a MAC below it are marked (class ``bad``).

    Returns
    -------
    str
        ``<table class="modes">`` ... ``</table>``; frequency error in percent.

    Raises
    ------
    ShapeError
        Columns of different lengths.
    """
    f = np.atleast_1d(np.asarray(f_id_hz, dtype=float))
    cols = {"zeta_id": zeta_id, "f_model_hz": f_model_hz, "zeta_model": zeta_model, "mac": mac}
    arr = {k: np.full(f.size, np.nan) if v is None else np.atleast_1d(np.asarray(v, float))
           for k, v in cols.items()}
    for k, v in arr.items():
        if v.shape != f.shape:
            msg = f"{k}: expected {f.size} values like f_id_hz, got {v.size}"
            raise ShapeError(msg)
    names = list(labels) if labels is not None else [str(i + 1) for i in range(f.size)]
    head = ("<tr><th>mode</th><th>f id [Hz]</th><th>&zeta; id [%]</th><th>f model [Hz]</th>"
            "<th>&Delta;f [%]</th><th>&zeta; model [%]</th><th>MAC</th></tr>")
    rows = []
    for i in range(f.size):
        fm, m = arr["f_model_hz"][i], arr["mac"][i]
        df = 100.0 * (f[i] - fm) / fm if np.isfinite(fm) and fm else np.nan
        bad = ' class="bad"' if np.isfinite(m) and m < mac_warn else ""
        rows.append(
            f"<tr{bad}><td>{html.escape(names[i])}</td><td>{_cell(f[i], '.4f')}</td>"
            f"<td>{_cell(100 * arr['zeta_id'][i], '.2f')}</td><td>{_cell(fm, '.4f')}</td>"
            f"<td>{_cell(df, '+.2f')}</td><td>{_cell(100 * arr['zeta_model'][i], '.2f')}</td>"
            f"<td>{_cell(m, '.3f')}</td></tr>")
    return f'<table class="modes">{head}{"".join(rows)}</table>'
