"""The report of a launched vehicle run: the car's modes, the twin's error, ride and floor PSD.

A folder ``modal-twin launch`` wrote (``bag/``, ``params/<node>.yaml``) whose twin (or, without
a twin, rig) ran a vehicle file -- the 3D car (``kind: vehicle3d``) or the vertical-plane car
-- gives (:func:`load_vehicle_run`):

- the car's modes: the 3D car's carbody-dominated modes named by type (as ``model info``),
  or the vertical car's modes with the part they move;
- where the twin fails: the last ``/twin/metrics`` of the bag (Eq. (8) of [004] per channel);
- ride, when the bag holds ``/measurement/frames`` with floor accelerations: per floor
  channel the Sperling index (Wz vertical, Wy lateral; :func:`modal_twin.models.ride.
  sperling_index`) of the record and of the model run offline on the record's inputs (as
  ``residual``), the floor-PSD power error in 4-15 Hz and the record's PSD peak, and a
  figure of the floor PSDs, record beside model (Welch; Sec. 5.2 of [002]).

A run whose model file is not there is one line naming it (the caller exits 2).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from modal_twin.errors import ModalTwinError
from modal_twin.progress import step

__all__ = ["PSD_BAND_HZ", "load_vehicle_run", "vehicle_of_run"]

PSD_BAND_HZ = (4.0, 15.0)
"""Band of the floor-PSD error (the carbody's first flexible modes; as ``residual --ride``)."""


def _param(folder: Path, node: str, key: str) -> str | None:
    """Return a string parameter of ``node`` in ``params/<node>.yaml`` (None if absent)."""
    from modal_twin.yaml_files import read_yaml

    p = folder / "params" / f"{node}.yaml"
    if not p.is_file() or p.is_symlink():
        return None
    try:
        doc = read_yaml(p, "node parameters")
    except ModalTwinError:
        return None
    params = (doc.get(node) or {}).get("ros__parameters") if isinstance(doc, dict) else None
    value = params.get(key) if isinstance(params, dict) else None
    return value if isinstance(value, str) and value else None


def vehicle_of_run(folder: Path) -> tuple[str, Path] | None:
    """Return (what named it, path) of the vehicle file a launched run ran, else None.

    The twin's ``model_file``, else the structure of the rig's ``rig_file``. None when the
    folder is no launched run (``bag/`` and ``params/``) or the file is no vehicle file
    (a structure of another kind keeps its own report); a named file that is not there is
    returned (its absence is what the report says).
    """
    from modal_twin.models.rig_file import load_rig
    from modal_twin.models.vehicle3d_spec import is_vehicle3d_file
    from modal_twin.models.vehicle_spec import is_vehicle_file
    from modal_twin.paths import resolve_config

    if not ((folder / "bag").is_dir() and (folder / "params").is_dir()):
        return None
    model = _param(folder, "twin", "model_file")
    if model is not None:
        found = ("params/twin.yaml model_file", resolve_config(model))
    else:
        rig = _param(folder, "rig", "rig_file")
        if rig is None:
            return None
        try:
            found = ("params/rig.yaml rig_file", load_rig(resolve_config(rig)).structure)
        except ModalTwinError:
            return None
    path = found[1]
    if not path.is_file():
        return found
    try:
        return found if is_vehicle3d_file(path) or is_vehicle_file(path) else None
    except ModalTwinError:
        return None


def _car_modes(path: Path) -> tuple[str, list[str], list[float], list[float]]:
    """Heading, labels, frequencies and damping ratios of the car's modes."""
    from modal_twin.models.vehicle3d_spec import is_vehicle3d_file

    if is_vehicle3d_file(path):
        from modal_twin.models.vehicle3d import build_vehicle3d
        from modal_twin.models.vehicle3d_ride import carbody_modes
        from modal_twin.models.vehicle3d_spec import load_vehicle3d

        spec = load_vehicle3d(path)
        veh = build_vehicle3d(spec)
        modes = carbody_modes(veh, spec.speed)
        return (f"{spec.name}: 3D car, {veh.carbody.name} carbody, {veh.n_dof} DOFs; its "
                f"carbody modes at {spec.speed_kmh:g} km/h (as model info)",
                [f"carbody {m.label}" for m in modes], [m.f_hz for m in modes],
                [m.zeta for m in modes])
    from modal_twin.models.vehicle import assemble_vehicle, load_vehicle, vehicle_info

    info = vehicle_info(assemble_vehicle(load_vehicle(path)))
    return (f"{info['name']}: vertical-plane car, {info['n_dof']} DOFs; its modes (as model "
            "info)", [str(m["part"]) for m in info["modes"]],
            [float(m["f_hz"]) for m in info["modes"]], [float(m["zeta"]) for m in info["modes"]])


def _ride(path: Path, bag: Path, notes: list[str]) -> tuple[str, Any] | None:
    """Return the ride table's HTML and the floor-PSD figure (record and model)."""
    from modal_twin.diagnosis.fitting import simulate_record
    from modal_twin.io.records import records_from_bag
    from modal_twin.models.loading import load_model
    from modal_twin.models.ride import floor_psd, psd_band_error, sperling_index
    from modal_twin.viz.ride import RideRow, plot_floor_psd, ride_table_html

    plant = load_model(path).plant()
    spec = {c.name: c for c in plant.channels}
    recs, frames = records_from_bag(bag, plant=plant)
    if not recs:
        notes.append(f"ride: no record of frames long enough in the bag ({frames.note()})")
        return None
    rec = max(recs, key=lambda r: r.n_samples - r.skip)
    floor = [c for c in rec.channel_names if c in spec and spec[c].quantity == "acceleration"
             and spec[c].direction in ("z", "y")]
    if not floor:
        notes.append("ride: the record has no floor acceleration of the car")
        return None
    rec = rec.with_channels(floor)
    meas = rec.scored
    pred = simulate_record(plant, rec)[:, rec.skip:]
    fs = rec.fs_hz
    seg = 5.0 if meas.shape[1] >= 5.0 * fs else None
    band = psd_band_error(meas, pred, fs, band=PSD_BAND_HZ)
    psd_m, psd_p = floor_psd(meas, fs), floor_psd(pred, fs)
    rows = []
    for i, name in enumerate(floor):
        d = "vertical" if spec[name].direction == "z" else "lateral"
        peaks = psd_m.peaks_hz[i]
        rows.append(RideRow(name, d, sperling_index(meas[i], fs, segment_s=seg, direction=d).W,
                            sperling_index(pred[i], fs, segment_s=seg, direction=d).W,
                            float(band.rel_power_error[i]),
                            float(peaks[0]) if peaks.size else float("nan")))
    notes.append(f"ride: {len(floor)} floor channels of {bag.name}, {meas.shape[1]} samples "
                 f"at {fs:g} Hz; the model run offline on the record's inputs")
    fig = plot_floor_psd(psd_m.f_hz, psd_m.psd, floor, psd_p.psd,
                         f_max_hz=min(40.0, fs / 2.0))
    return ride_table_html(rows, PSD_BAND_HZ), fig


def load_vehicle_run(folder: Path) -> tuple[Any, str]:
    """Return the report data of a launched vehicle run, or ``(None, what is missing)``.

    (A :class:`~modal_twin.viz.report.RunData`; module docstring.)
    """
    from modal_twin.commands.report import twin_metrics
    from modal_twin.viz.report import RecordData, RunData, figure_html
    from modal_twin.viz.ride import car_modes_html

    found = vehicle_of_run(folder)
    if found is None:
        return None, f"{folder}: not a launched vehicle run (bag/, params naming a vehicle)"
    source, path = found
    if not path.is_file():
        return None, (f"{folder}: the run's model file {path} ({source}) is not there: no "
                      "modes, ride or twin error to report against it")
    notes = [f"run folder: {folder.resolve()}", f"vehicle: {path} ({source})"]
    with step(f"report: modes of {path.name}"):
        heading, labels, f_hz, zeta = _car_modes(path)
    sections = [("car", "the car's modes",
                 f"<p>{heading}</p>" + car_modes_html(labels, f_hz, zeta))]
    bag = folder / "bag"
    m, meta = twin_metrics(bag)
    records = []
    if m is not None:
        records.append(RecordData(folder.name, tuple(m.channel_names),
                                  np.asarray(m.rms_error, dtype=float), str(m.model_version),
                                  meta))
    else:
        notes.append("where the twin fails: the bag holds no /twin/metrics")
    try:
        with step("report: ride and floor PSD"):
            ride = _ride(path, bag, notes)
    except ModalTwinError as err:
        notes.append(f"ride: not computed ({err})")
        ride = None
    if ride is not None:
        table, fig = ride
        sections.append(("ride", "ride: Sperling index and floor PSD", table + figure_html(
            fig, "floor acceleration PSD (Welch): the record, and the model run on its "
                 "inputs (dashed)")))
    return RunData(f"modal_twin vehicle run {folder.name}", records, notes=notes,
                   sections=sections), ""
