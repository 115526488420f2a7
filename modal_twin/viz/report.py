"""The run report.

One self-contained HTML file (figures as base64 PNG, CSS inline, the 3D scene as an inline
``srcdoc``; nothing is fetched from a network).

:class:`RunData` holds plain data (arrays, result objects, model versions) gathered by the
command line (:mod:`modal_twin.commands.report` reads a run folder); :func:`render_report`
turns it into HTML with one section per kind of data present, in the order of the loop of
the design card: the 3D scene, identification (stabilization diagram, modes table, MAC),
FRF overlay, where the model fails, evidence, hysteresis loops, error history.

"""

from __future__ import annotations

import base64
import html
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.paths import atomic_file
from modal_twin.viz._figure import png_data_uri

__all__ = ["RecordData", "RunData", "figure_html", "render_report", "write_report"]


@dataclass(frozen=True, slots=True)
class RecordData:
    """What the report shows of one recorded run.

    Attributes
    ----------
    name : str
        Sub-run folder name (``2_train_random``).
    metrics_names : tuple of str
        Channels of the last twin metrics (empty: none recorded).
    rms_error_pct : (n,) float array
        Eq. (8) of [004] per channel, percent.
    model_version : str
        Model the twin ran.
    meta : mapping channel -> (place, direction, quantity)
        From the channel map.
    loops : mapping name -> (drift m, force N)
        Measured device loops (``"ESB1 x"``).
    force_state : mapping name -> (drift m, velocity m/s, force N)
        Samples for force-state maps.
    model_loops : mapping name -> (drift m, force N)
        The model's device force for the same measured drift (the last model version).
    """

    name: str
    metrics_names: tuple[str, ...] = ()
    rms_error_pct: FloatArray = field(default_factory=lambda: np.zeros(0))
    model_version: str = ""
    meta: Mapping[str, tuple[str, str, str]] = field(default_factory=dict)
    loops: Mapping[str, tuple[FloatArray, FloatArray]] = field(default_factory=dict)
    force_state: Mapping[str, tuple[FloatArray, FloatArray, FloatArray]] = field(
        default_factory=dict)
    model_loops: Mapping[str, tuple[FloatArray, FloatArray]] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class RunData:
    """Everything a report may show; every field is optional."""

    title: str
    records: Sequence[RecordData] = ()
    versions: Sequence[Any] = ()  # ModelVersion, oldest first
    scene_html: str | None = None
    record_scene_html: str | None = None  # a record's motion, measured beside the twins
    stabilization: Any = None  # StabilizationDiagram
    selected_f_hz: FloatArray | None = None
    modes: Mapping[str, Any] | None = None  # keyword arguments of modes_table_html
    mac: tuple[FloatArray, Sequence[str], Sequence[str]] | None = None
    frf: tuple[FloatArray, Any, Sequence[str], Any] | None = None  # f, H_meas, names, H_model
    images: Sequence[tuple[str, bytes]] = ()  # (caption, PNG bytes) found in the run folder
    figures: Sequence[tuple[str, bytes]] = ()  # identify's PNGs (caption, bytes)
    notes: Sequence[str] = ()
    sections: Sequence[tuple[str, str, str]] = ()  # (anchor, title, HTML) after the scenes


_CSS = """
body {font: 14px/1.45 system-ui, sans-serif; margin: 0 auto; max-width: 1200px;
      padding: 0 18px 40px; color: #222;}
h1 {font-size: 22px; border-bottom: 2px solid #444;} h2 {font-size: 18px; margin-top: 34px;
border-bottom: 1px solid #bbb;} h3 {font-size: 15px;}
figure {margin: 12px 0;} figure img {max-width: 100%; height: auto; border: 1px solid #ddd;}
figcaption {color: #555; font-size: 12px;}
table {border-collapse: collapse; margin: 8px 0; font-size: 13px;}
th, td {border: 1px solid #ccc; padding: 3px 8px; text-align: right;}
th {background: #f0f0f0;} td:first-child {text-align: left;} tr.bad td {background: #fde2e2;}
nav a {margin-right: 12px;} iframe {width: 100%; height: 520px; border: 1px solid #ccc;}
.note {color: #555;}
"""


def figure_html(fig: Any, caption: str) -> str:
    """Return a matplotlib figure as an inline PNG ``<figure>`` with its caption."""
    return (f'<figure><img alt="{html.escape(caption)}" src="{png_data_uri(fig)}">'
            f"<figcaption>{html.escape(caption)}</figcaption></figure>")


_img = figure_html


def _png(data: bytes, caption: str) -> str:
    uri = "data:image/png;base64," + base64.b64encode(data).decode()
    return (f'<figure><img alt="{html.escape(caption)}" src="{uri}">'
            f"<figcaption>{html.escape(caption)}</figcaption></figure>")


def _identification(d: RunData) -> str:
    from modal_twin.viz.mac import plot_mac
    from modal_twin.viz.modes_table import modes_table_html
    from modal_twin.viz.stabilization import plot_stabilization

    parts = []
    if d.stabilization is not None:
        parts.append(_img(plot_stabilization(d.stabilization, selected_f_hz=d.selected_f_hz),
                          "stabilization diagram"))
    if d.modes is not None:
        parts.append("<h3>modes, identified vs model</h3>" + modes_table_html(**d.modes))
    if d.mac is not None:
        parts.append(_img(plot_mac(*d.mac), "MAC, identified vs model" if d.versions or
                          d.records else "auto-MAC of the identified modes"))
    parts += [_png(data, caption) for caption, data in d.figures]
    return "".join(parts)


def _frf(d: RunData) -> str:
    from modal_twin.viz.frf import plot_frf_overlay

    if d.frf is None:
        return ""
    f, Hm, names, Hp = d.frf
    return _img(plot_frf_overlay(f, Hm, names, Hp),
                "FRF magnitude, measured" + (" vs model" if Hp is not None else ""))


def _where(d: RunData) -> str:
    from modal_twin.viz.where import plot_where, where_table_html

    parts = []
    for r in d.records:
        if not r.metrics_names:
            continue
        parts.append(f"<h3>{html.escape(r.name)} (model {html.escape(r.model_version)})</h3>")
        parts.append(_img(plot_where(r.metrics_names, r.rms_error_pct, meta=r.meta,
                                     title=f"where the model fails: {r.name}"),
                          f"Eq. (8) RMS error per place, direction, quantity: {r.name}"))
        parts.append(where_table_html(r.metrics_names, r.rms_error_pct, meta=r.meta, top=10))
    return "".join(parts)


def _evidence(d: RunData) -> str:
    from modal_twin.viz.evidence import plot_force_state_surface

    parts = []
    for r in d.records:
        for name, (u, v, f) in r.force_state.items():
            parts.append(_img(plot_force_state_surface(u, v, f, title=f"{name}: {r.name}"),
                              f"force-state map, {name}, {r.name}"))
    parts += [_png(data, caption) for caption, data in d.images]
    return "".join(parts)


def _hysteresis(d: RunData) -> str:
    from modal_twin.viz.hysteresis import plot_hysteresis

    return "".join(_img(plot_hysteresis(r.loops, r.model_loops or None,
                                        title=f"device loops: {r.name}"),
                        f"device hysteresis loops, {r.name}: measured (solid) and the last "
                        "model version's device on the same drift (dashed red)")
                   for r in d.records if r.loops)


def _versions(d: RunData) -> str:
    from modal_twin.viz.error_history import error_history_figure, version_labels

    if not d.versions:
        return ""
    rows = []
    for v in d.versions:
        err = np.array(list(v.errors.values()), dtype=float)
        eff = ", ".join(f"{e.law} at {e.component}" for e in v.effects) or "&ndash;"
        rows.append(f"<tr><td>{html.escape(v.label)}</td><td>{html.escape(v.note)}</td>"
                    f"<td>{eff}</td><td>{np.median(err) if err.size else np.nan:.4g}</td>"
                    f"<td>{np.max(err) if err.size else np.nan:.4g}</td></tr>")
    table = ('<table><tr><th>version</th><th>note</th><th>effects</th>'
             "<th>median held-out NMSE [%]</th><th>worst [%]</th></tr>" + "".join(rows)
             + "</table>")
    fig = error_history_figure(version_labels([(v.label, v.note) for v in d.versions]),
                               [v.errors for v in d.versions])
    return table + _img(fig, "error history per channel group")


def _scene(d: RunData) -> str:
    if not d.scene_html:
        return ""
    return (f'<iframe title="3D scene" srcdoc="{html.escape(d.scene_html, quote=True)}">'
            "</iframe><p class=note>drag to turn, scroll to zoom; the modes are animated</p>")


def _record_scene(d: RunData) -> str:
    if not d.record_scene_html:
        return ""
    return (f'<iframe title="the record on the structure" srcdoc="'
            f'{html.escape(d.record_scene_html, quote=True)}"></iframe><p class=note>the '
            "held-out record's strongest stretch in real time: measured, the nominal model's "
            "twin and the last version's twin, each sensor coloured by the last twin's "
            "error there</p>")


def render_report(d: RunData) -> str:
    """Return the HTML of the report (sections without data are left out)."""
    sections = [("scene", "3D scene", _scene(d)),
                ("record", "the record on the structure", _record_scene(d)),
                *d.sections,
                ("identification", "identification", _identification(d)),
                ("frf", "FRF overlay", _frf(d)),
                ("where", "where the model fails", _where(d)),
                ("evidence", "evidence of the missing effect", _evidence(d)),
                ("hysteresis", "device hysteresis loops", _hysteresis(d)),
                ("history", "model versions and error history", _versions(d))]
    shown = [(k, t, b) for k, t, b in sections if b]
    nav = " ".join(f'<a href="#{k}">{html.escape(t)}</a>' for k, t, _ in shown)
    body = "".join(f'<section id="{k}"><h2>{html.escape(t)}</h2>{b}</section>'
                   for k, t, b in shown)
    notes = "".join(f"<p class=note>{html.escape(n)}</p>" for n in d.notes)
    stamp = datetime.now().isoformat(timespec="seconds")
    return (f'<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">'
            f"<title>{html.escape(d.title)}</title><style>{_CSS}</style></head><body>"
            f"<h1>{html.escape(d.title)}</h1><p class=note>written {stamp}</p>{notes}"
            f"<nav>{nav}</nav>{body}</body></html>")


def write_report(d: RunData, out: str | Path) -> Path:
    """Write :func:`render_report` to ``out``.

    Renamed into place: a link there is replaced, never written through.
    """
    with atomic_file(out) as tmp:
        tmp.write_text(render_report(d), encoding="utf-8")
    return Path(out)
