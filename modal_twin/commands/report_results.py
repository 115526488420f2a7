"""Report sections of the result folders of ``update --out`` and ``campaign --out``.

``update`` of a matrix model writes ``model_vN.npz`` and ``update_vN.json`` (the last
version is shown: every identified mode with its model partner, df and MAC before and
after, an unmatched one at its nearest partner, and the parameters); ``campaign`` writes
``campaign.json`` and ``campaign.png`` (the modes tracked over the events' real times).
Each is read bounded, as plain JSON / PNG; a file that does not read is a note, never a
crash.
"""

from __future__ import annotations

import html
import json
import re
from pathlib import Path
from typing import Any

from modal_twin.errors import ModalTwinError
from modal_twin.paths import open_regular

__all__ = ["campaign_section", "update_section"]

_MAX_BYTES = 32 * 2**20
_PNG = b"\x89PNG\r\n\x1a\n"
_UPDATE = re.compile(r"^update_v(\d+)\.json$")


def _read(p: Path, what: str, notes: list[str]) -> bytes | None:
    try:
        with open_regular(p, what, follow=False) as fh:
            data = fh.read(_MAX_BYTES + 1)
    except (ModalTwinError, OSError) as err:
        notes.append(f"left out {p.name}: {err}")
        return None
    if len(data) > _MAX_BYTES:
        notes.append(f"left out {p.name}: larger than {_MAX_BYTES} bytes")
        return None
    return data


def _json(p: Path, notes: list[str]) -> dict[str, Any] | None:
    data = _read(p, "result file", notes)
    if data is None:
        return None
    try:
        doc = json.loads(data)
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        notes.append(f"left out {p.name}: not JSON ({err})")
        return None
    if not isinstance(doc, dict):
        notes.append(f"left out {p.name}: expected a JSON object")
        return None
    return doc


def _num(v: Any, fmt: str) -> str:
    return format(float(v), fmt) if isinstance(v, (int, float)) else "-"


def update_section(folder: Path, notes: list[str]) -> tuple[str, str, str] | None:
    """Return the section of the last ``update_vN.json`` in ``folder`` (None: none).

    Rows: each identified mode, its model partner (``*``: unmatched, the nearest) with df
    and MAC before and after; then each parameter's start, estimate and std.
    """
    files = sorted((int(m[1]), p) for p in folder.glob("update_v*.json")
                   if (m := _UPDATE.match(p.name)) and p.is_file() and not p.is_symlink())
    if not files:
        return None
    p = files[-1][1]
    doc = _json(p, notes)
    if doc is None:
        return None
    try:
        f = [float(v) for v in doc["f_id_hz"]]
        cols = {k: list(doc.get(k) or [None] * len(f))
                for k in ("model_before", "df_pct_before", "mac_before", "unmatched_before",
                          "model_after", "df_pct_after", "mac_after", "unmatched_after")}
        names, th0, th = list(doc["names"]), list(doc["theta_start"]), list(doc["theta"])
    except (KeyError, TypeError, ValueError) as err:
        notes.append(f"left out {p.name}: not an update result ({err!r})")
        return None
    std = list(doc.get("std") or [None] * len(names))

    def partner(when: str, k: int) -> str:
        j = cols[f"model_{when}"][k]
        star = "*" if cols[f"unmatched_{when}"][k] else ""
        return f"{j}{star}" if isinstance(j, int) else "-"

    rows = "".join(
        f"<tr><td>{k + 1}</td><td>{fk:.4f}</td><td>{partner('before', k)}</td>"
        f"<td>{_num(cols['df_pct_before'][k], '.3f')}</td>"
        f"<td>{_num(cols['mac_before'][k], '.3f')}</td><td>{partner('after', k)}</td>"
        f"<td>{_num(cols['df_pct_after'][k], '.3f')}</td>"
        f"<td>{_num(cols['mac_after'][k], '.3f')}</td></tr>" for k, fk in enumerate(f))
    params = "".join(
        f"<tr><td>{html.escape(str(n))}</td><td>{_num(a, '+.4f')}</td><td>{_num(b, '+.4f')}"
        f"</td><td>{_num(s, '.4f')}</td></tr>"
        for n, a, b, s in zip(names, th0, th, std, strict=False))
    body = (f"<p>{html.escape(p.name)} (model {html.escape(p.stem.replace('update', 'model'))}"
            ".npz): every identified mode before and after; <code>*</code> an unmatched "
            "mode at its nearest model mode.</p><table><tr><th>mode</th><th>f id [Hz]</th>"
            "<th>model</th><th>df before %</th><th>MAC before</th><th>model</th>"
            f"<th>df after %</th><th>MAC after</th></tr>{rows}</table>"
            "<table><tr><th>parameter</th><th>start</th><th>estimate</th><th>std</th></tr>"
            f"{params}</table>")
    notes.append(f"update: {p.name} ({len(f)} modes, {len(names)} parameters)"
                 + (f"; also {[q.name for _, q in files[:-1]]}" if files[:-1] else ""))
    return ("update", "Model update", body)


def campaign_section(folder: Path, notes: list[str]) -> tuple[str, str, str] | None:
    """Return the section of ``campaign.json`` / ``campaign.png`` in ``folder`` (None: none)."""
    import base64

    jp, pp = folder / "campaign.json", folder / "campaign.png"
    if not (jp.is_file() and not jp.is_symlink()):
        return None
    doc = _json(jp, notes)
    if doc is None:
        return None
    raw = doc.get("modes")
    modes: list[Any] = raw if isinstance(raw, list) else []
    tracks: dict[Any, list[dict[str, Any]]] = {}
    for m in modes:
        if isinstance(m, dict):
            tracks.setdefault(m.get("track"), []).append(m)
    rows = "".join(
        f"<tr><td>{html.escape(str(t))}</td><td>{len(ms)}</td>"
        f"<td>{_num(min(m.get('f_hz', 0.0) for m in ms), '.4f')}</td>"
        f"<td>{_num(max(m.get('f_hz', 0.0) for m in ms), '.4f')}</td>"
        f"<td>{html.escape(', '.join(sorted({str(m.get('t_start_utc', '')) for m in ms})))}"
        "</td></tr>" for t, ms in tracks.items())
    img = ""
    if pp.is_file() and not pp.is_symlink():
        data = _read(pp, "figure", notes)
        if data is not None and data.startswith(_PNG):
            img = (f'<figure><img src="data:image/png;base64,{base64.b64encode(data).decode()}"'
                   ' alt="campaign"><figcaption>campaign.png</figcaption></figure>')
    body = (f"<p>{doc.get('n_windows', '?')} windows, {doc.get('n_tracks', '?')} tracks, "
            f"failed windows {html.escape(str(doc.get('failed_windows', [])))}</p>{img}"
            "<table><tr><th>track</th><th>windows</th><th>f min [Hz]</th><th>f max [Hz]</th>"
            f"<th>event times (UTC)</th></tr>{rows}</table>")
    notes.append(f"campaign: {jp.name} ({len(modes)} modes in {len(tracks)} tracks)")
    return ("campaign", "Monitoring campaign", body)
