"""The report of an imported record, an ``identify`` folder or a launched structure run.

What the folder holds decides the sections (:func:`load_record_folder`):

- modes: ``modes.json`` (``identify --out``) or ``modes_<file>.json`` (a UFF 55 that
  ``modal-twin import`` read) -> the modes table and their auto-MAC; the PNGs ``identify``
  wrote beside them (``stabilization.png``, ``mac.png``) are embedded;
- an imported bag (``channel_map.json`` and a record) without modes -> identified here, as
  ``modal-twin identify`` does (:func:`~modal_twin.identification.record.identify_record`):
  stabilization diagram, modes, auto-MAC; with input channels also the H1 FRFs;
- a hammer test's FRF matrix (``frf.uff``, as ``impact`` / ``hammer`` write it) -> the FRF
  magnitudes, each response over each reference;
- a test geometry (``geometry_*.json`` of the import, or the one in the modes file) -> the
  3D view, the modes drawn on it where their channels sit.

A folder with none of these gives one line naming what is missing (the caller exits 2).
A launched run that is no vehicle run (``bag/`` and ``params/``, what ``modal-twin launch
--run-dir`` writes) gives its result folders' sections and its record's
(:func:`load_launched_run`).
"""

from __future__ import annotations

import html
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin.errors import ModalTwinError
from modal_twin.paths import open_regular
from modal_twin.progress import step

__all__ = ["RECORD_FIGURES", "is_launched_run", "load_launched_run", "load_record_folder"]

RECORD_FIGURES = ("stabilization.png", "mac.png")
"""The figures ``identify --out`` writes, embedded as they are."""
_PNG = b"\x89PNG\r\n\x1a\n"
_FIGURE_MAX_BYTES = 32 * 2**20


def _modes_files(folder: Path) -> list[Path]:
    return [p for p in [folder / "modes.json", *sorted(folder.glob("modes_*.json"))]
            if p.is_file() and not p.is_symlink()]


def _figures(folder: Path, notes: list[str]) -> list[tuple[str, bytes]]:
    out = []
    for name in RECORD_FIGURES:
        p = folder / name
        if not p.exists():
            continue
        try:
            with open_regular(p, "figure", follow=False) as fh:
                data = fh.read(_FIGURE_MAX_BYTES + 1)
        except (ModalTwinError, OSError) as err:
            notes.append(f"left out {name}: {err}")
            continue
        if data.startswith(_PNG) and len(data) <= _FIGURE_MAX_BYTES:
            out.append((f"{p.stem} (identify)", data))
        else:
            notes.append(f"left out {name}: not a PNG figure")
    return out


def _modes_sections(mf: Any, source: str) -> dict[str, Any]:
    from modal_twin.identification.metrics import mac_measured

    labels = [f"{k + 1}: {f:.3f} Hz" for k, f in enumerate(mf.f_hz)]
    return {"modes": {"f_id_hz": mf.f_hz, "zeta_id": mf.zeta, "labels": labels},
            "mac": (mac_measured(mf.shapes, mf.shapes), labels, labels),  # NaN: unmeasured
            "selected_f_hz": mf.f_hz,
            "source": source}


def _identified(bag: Path, notes: list[str]) -> tuple[dict[str, Any], Any]:
    """Identify the bag's modes as ``identify`` does; the sections and a ModesFile-like."""
    from modal_twin.acquisition.frf import frf
    from modal_twin.identification.record import IdentifyOptions, identify_record
    from modal_twin.io.imported import read_imported
    from modal_twin.io.modes_file import ModesFile, modes_document

    with step(f"report: reading {bag.name}"):
        block, chans = read_imported(bag)
    with step(f"report: identifying {bag.name} ({block.n_samples / block.fs_hz:.0f} s of "
              f"{len(chans)} channels)"):
        rec = identify_record(block, chans, IdentifyOptions())
    mm = rec.modes
    notes.append(f"identification: {rec.method} on {len(rec.inputs)} inputs, "
                 f"{len(rec.outputs)} outputs, {rec.settings.describe()}; "
                 f"{mm.f_hz.size} modes" + "".join(f"; {n}" for n in rec.notes))
    notes += [f"not reported: {d.describe()}" for d in rec.dropped]
    doc = modes_document(rec)
    mf = ModesFile(mm.f_hz, mm.zeta, mm.std_f_hz, mm.shapes, np.full(mm.shapes.shape, np.nan),
                   None, tuple(doc["dofs"]))
    out: dict[str, Any] = {"stabilization": rec.diagram}
    if mm.f_hz.size:
        out.update(_modes_sections(mf, bag.name))
    # the record's inputs, also where the identification ran output-only (said above)
    ins = list(rec.inputs) or [c for c in chans if c.role == "input" and c.name in
                               block.channel_names and np.std(block.select((c.name,)).data) > 0]
    if ins and rec.outputs:
        with step("report: FRFs (H1)"):
            x = block.select([ins[0].name]).data
            y = block.select([c.name for c in rec.outputs]).data
            est = frf(x, y, block.fs_hz)
        lo, hi = rec.settings.band_hz
        band = (est.f_hz >= lo) & (est.f_hz <= hi)
        out["frf"] = (est.f_hz[band], np.nan_to_num(est.H1[:, 0, band]),
                      [c.name for c in rec.outputs], None)
        notes.append(f"FRF: H1 of every output to the input {ins[0].name}"
                     + ("" if rec.inputs else " (a measured input the output-only "
                                              "identification left out)"))
    return out, (mf if mm.f_hz.size else None)


def _frf_file(folder: Path, notes: list[str]) -> dict[str, Any]:
    """Return the report section of a hammer test's ``frf.uff`` (``impact``, ``hammer``, node)."""
    from modal_twin.io.impact_files import FRF_FILE, read_frf_matrix

    p = folder / FRF_FILE
    if not p.is_file() or p.is_symlink():
        return {}
    try:
        with step(f"report: FRFs ({FRF_FILE})"):
            f, H, outs, ins = read_frf_matrix(p)
    except ModalTwinError as err:
        notes.append(f"left out {FRF_FILE}: {err}")
        return {}
    keep = f > 0
    names = [f"{''.join(o)}/{''.join(i)}" for i in ins for o in outs]
    rows = np.concatenate([H[:, k, keep] for k in range(len(ins))])
    notes.append(f"FRF: {FRF_FILE}, {len(outs)} responses x {len(ins)} references "
                 f"(response/reference node and direction)")
    return {"frf": (f[keep], rows, names, None)}


def _scene(folder: Path, mf: Any, notes: list[str]) -> str | None:
    """3D view of the folder's test geometry (or the modes file's), the modes on it."""
    from modal_twin.commands.view import load_measured_geometry
    from modal_twin.viz.measured_geometry import (
        MeasuredGeometry,
        geometry_from_uff,
        modes_on_nodes,
    )
    from modal_twin.viz.scene import caption_html, overlay_html, scene_commands, static_html

    if any(folder.glob("geometry_*.json")):
        mg = load_measured_geometry(folder)
    elif mf is not None and mf.geometry:
        geom, ids = geometry_from_uff(mf.geometry, folder.name,
                                      [str(d["node"]) for d in mf.dofs])
        chans = {str(d["channel"]): (str(d["node"]), str(d["direction"])) for d in mf.dofs}
        mg = MeasuredGeometry(geom, ids, chans)
    else:
        return None
    if mf is None or not mf.dofs:
        g = mg.geom
        return static_html(scene_commands(g), caption=caption_html([
            f"<b>{html.escape(folder.name)}</b>: test geometry, {len(mg.ids)} nodes"]))
    try:
        modes = modes_on_nodes(mg, mf.f_hz, mf.zeta, mf.shapes, mf.dofs)
    except ModalTwinError as err:
        notes.append(f"3D view without modes: {err}")
        return static_html(scene_commands(mg.geom), caption=caption_html(
            [f"<b>{html.escape(folder.name)}</b>: test geometry"]))
    return static_html(scene_commands(mg.geom, modes), caption=overlay_html(mg.geom, modes))


def _sections(folder: Path, notes: list[str], *, identify: bool = True
              ) -> tuple[dict[str, Any], Any, list[tuple[str, bytes]], str | None]:
    """Return the report sections of one folder: data, its modes, its figures, its 3D view."""
    from modal_twin.commands.report_results import campaign_section, update_section
    from modal_twin.io.impact_files import hit_summary_lines
    from modal_twin.io.modes_file import read_modes

    data: dict[str, Any] = {}
    mf = None
    files = _modes_files(folder)
    if files:
        mf = read_modes(files[0])
        data.update(_modes_sections(mf, files[0].name))
        notes.append(f"modes: {files[0].name} ({mf.f_hz.size} modes at {len(mf.dofs)} "
                     "channels)" + (f"; also {[p.name for p in files[1:]]}" if files[1:]
                                    else ""))
    elif identify and (folder / "channel_map.json").is_file() and \
            (folder / "metadata.yaml").is_file():
        ident, mf = _identified(folder, notes)
        data.update(ident)
    if "frf" not in data:
        data.update(_frf_file(folder, notes))
    results = [sec for sec in (update_section(folder, notes), campaign_section(folder, notes))
               if sec is not None]  # update --out, campaign --out
    if results:
        data["sections"] = results
    notes += hit_summary_lines(folder)
    images = _figures(folder, notes)
    with step("report: 3D view"):
        scene = _scene(folder, mf, notes)
    return data, mf, images, scene


def load_record_folder(folder: Path) -> tuple[Any, str]:
    """Return the report data of an imported / identify folder, or ``(None, what is missing)``.

    (A :class:`~modal_twin.viz.report.RunData`; module docstring.)
    """
    from modal_twin.viz.report import RunData

    notes = [f"folder: {folder.resolve()}"]
    data, _, images, scene = _sections(folder, notes)
    source = data.pop("source", folder.name)
    if not (data or images or scene):
        return None, (f"{folder}: nothing to report: no run (*/bag, models/, or a launched "
                      "run's bag/ with params/), no imported "
                      "record (channel_map.json with a bag), no modes (modes.json, "
                      "modes_*.json), no FRF matrix (frf.uff), no test geometry "
                      "(geometry_*.json), no update result (update_v*.json) and no campaign "
                      "(campaign.json)")
    return RunData(f"modal_twin record {folder.name} ({source})", scene_html=scene,
                   figures=images, notes=notes, **data), ""


def is_launched_run(folder: Path) -> bool:
    """Return whether ``folder`` is what ``modal-twin launch --run-dir`` wrote (bag/, params/)."""
    return (folder / "bag").is_dir() and (folder / "params").is_dir()


def _own_bag(folder: Path, notes: list[str]) -> Path | None:
    """``folder/bag`` unless it, or a file in it, is a link, FIFO or device (then a note)."""
    from modal_twin.commands.report import unsafe_entry

    bag = folder / "bag"
    bad = unsafe_entry(bag, folder)
    if bad is not None:
        notes.append(f"left out bag: {bad.name} is a link, FIFO or device")
        return None
    return bag


def load_launched_run(folder: Path) -> tuple[Any, str]:
    """Return the report data of a launched run that is no vehicle run, or ``(None, why)``.

    The results written into the run folder come first: each sub-folder (``impact/`` of a
    hammer test: its FRF matrix and hit verdicts; an ``identify --out`` folder: its modes
    and figures) gives the sections :func:`load_record_folder` gives it, the first folder
    with a kind of section keeping it. Where none gave modes, the run's record (``bag/``,
    read with the channel map it recorded) is identified as an imported record is
    (stabilization, modes, auto-MAC; its H1 FRFs where no FRF matrix was found); the twin's
    metrics in it, where a twin ran, give the per-channel errors.
    """
    from modal_twin.commands.report import twin_metrics
    from modal_twin.viz.report import RecordData, RunData

    notes = [f"launched run folder: {folder.resolve()}"]
    data: dict[str, Any] = {}
    images: list[tuple[str, bytes]] = []
    scene = None
    subs = [p for p in sorted(folder.iterdir()) if p.is_dir() and not p.is_symlink()
            and p.name not in ("bag", "params", "logs")]
    for sub in subs:
        sub_notes: list[str] = []
        part, _, figs, sub_scene = _sections(sub, sub_notes, identify=False)
        part.pop("source", None)
        if not (part or figs or sub_scene):
            continue
        notes += [f"{sub.name}/: {n}" for n in sub_notes]
        for k, v in part.items():
            data.setdefault(k, v)
        images += [(f"{sub.name}/: {c}", b) for c, b in figs]
        scene = scene or sub_scene
    records = []
    bag = _own_bag(folder, notes)
    if bag is not None:
        try:
            m, meta = twin_metrics(bag)
            if "modes" in data:
                notes.append("the record bag/ not identified: the modes are a result "
                             "folder's")
            else:
                ident, _ = _identified(bag, notes)
                if "frf" in data:
                    ident.pop("frf", None)
                    notes[:] = [n for n in notes if not n.startswith("FRF: H1")]
                data.update(ident)
        except ModalTwinError as err:
            notes.append(f"the record bag/ does not read: {err}")
            m, meta = None, {}
        if m is not None:
            records.append(RecordData(folder.name, tuple(m.channel_names),
                                      np.asarray(m.rms_error, dtype=float),
                                      str(m.model_version), meta, {}, {}, {}))
    data.pop("source", None)
    if not (data or images or scene or records):
        return None, (f"{folder}: nothing to report: a launched run whose record bag/ gives "
                      "no modes and with no result folder (impact/frf.uff, modes.json)")
    return RunData(f"modal_twin run {folder.name}", records, scene_html=scene, figures=images,
                   notes=notes, **data), ""
