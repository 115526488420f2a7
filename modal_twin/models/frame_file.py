"""Frame files: the tracking frame of [000] as a structure file (``kind: frame``).

A frame file names the frame's dimensions and contact stiffnesses
(:class:`~modal_twin.models.tracking_frame.FrameSpec` fields), the DOFs of its
accelerometers and of the points a hammer (or a shaker) hits, and the bounds of its
contact-stiffness parameters::

    kind: frame
    spec: {}                       # FrameSpec fields (SI); {} = the shipped frame
    sensors: ["201:x", "402:z"]    # DOF labels "<node>:<direction>" of the accelerometers
    forces: ["402:z", "203:x"]     # DOF labels of the hit points (the model's inputs)
    bounds: [-0.7, 1.5]            # of every theta_j (optional)

It is read as a matrix model (:func:`frame_arrays`, the arrays
:func:`~modal_twin.models.matrix_model.matrix_model_from_arrays` takes): ``K(theta) = K0 +
sum_j theta_j K_j`` with ``K_feet`` and ``K_bearings`` the nominal contact springs, so a
rig, ``update`` and ``model`` take it like a ``.npz`` matrix model, driven by point forces
at ``forces`` (:class:`~modal_twin.models.matrix_factory.MatrixFactory`); with the nodes'
coordinates (``node_xyz``) and the frame's outline (``trace_nodes``,
:func:`~modal_twin.models.tracking_frame.frame_outline`), so a test on it has a geometry.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import fields
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin.errors import ConfigError

__all__ = ["FRAME_KIND", "frame_arrays", "is_frame_file", "spec_fields"]

FRAME_KIND = "frame"
_KEYS = {"kind", "description", "spec", "sensors", "forces", "bounds"}
_YAML = (".yaml", ".yml")


def _number(v: object) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def spec_fields(cls: type, given: Mapping[str, Any], where: str) -> dict[str, Any]:
    """Check ``given`` against the fields of dataclass ``cls`` (numbers, tuples of numbers).

    Returns the values converted to the fields' types (float, int, tuple of floats).

    Raises
    ------
    ConfigError
        An unknown key or a value unlike the field's default, naming ``where``.
    """
    names = {f.name for f in fields(cls)}
    bad = sorted(set(given) - names)
    if bad:
        msg = f"{where}: unknown keys {bad}; expected some of {sorted(names)}"
        raise ConfigError(msg)
    defaults: dict[str, Any] = {f.name: f.default for f in fields(cls)}
    out: dict[str, Any] = {}
    for k, v in given.items():
        want = defaults[k]
        if isinstance(want, tuple):
            ok = (isinstance(v, list) and len(v) == len(want)
                  and all(_number(x) for x in v))
        else:
            ok = _number(v) and (isinstance(want, float) or float(v).is_integer())
        if not ok:
            msg = f"{where}.{k}: expected a value like {want!r}, got {v!r}"
            raise ConfigError(msg)
        out[k] = (tuple(float(x) for x in v) if isinstance(want, tuple)
                  else float(v) if isinstance(want, float) else int(v))
    return out


def is_frame_file(path: str | Path) -> bool:
    """Tell whether ``path`` is a frame file (a YAML file with ``kind: frame``)."""
    from modal_twin.yaml_files import read_yaml

    p = Path(path)
    if p.suffix.lower() not in _YAML or not p.is_file():
        return False
    doc = read_yaml(p, "model file")
    return isinstance(doc, Mapping) and doc.get("kind") == FRAME_KIND


def _labels(doc: Mapping[str, Any], key: str, dofs: list[str], src: str) -> np.ndarray:
    labels = doc.get(key) or []
    if not isinstance(labels, list) or not all(isinstance(v, str) for v in labels):
        msg = f"{src}: {key}: expected a list of DOF labels like '402:z'"
        raise ConfigError(msg)
    bad = [v for v in labels if v not in dofs]
    if bad or len(set(labels)) != len(labels):
        msg = (f"{src}: {key}: {bad or 'repeated labels'} not distinct DOFs of the frame "
               f"(labels like {dofs[:3]})")
        raise ConfigError(msg)
    return np.array([dofs.index(v) for v in labels], dtype=np.int64)


def frame_arrays(path: str | Path) -> dict[str, Any]:
    """Return the named arrays of a frame file's nominal model (module docstring).

    Raises
    ------
    ConfigError
        Not a frame file, unknown keys, bad spec fields, DOF labels or bounds.
    """
    from modal_twin.models.tracking_frame import JOINTS, FrameSpec, frame_matrices, frame_outline
    from modal_twin.yaml_files import read_yaml

    src = str(path)
    doc = read_yaml(path, "frame file")
    if doc.get("kind") != FRAME_KIND:
        msg = f"{src}: expected kind: {FRAME_KIND}, got {doc.get('kind')!r}"
        raise ConfigError(msg)
    bad = sorted(set(doc) - _KEYS)
    if bad:
        msg = f"{src}: unknown keys {bad}; expected some of {sorted(_KEYS)}"
        raise ConfigError(msg)
    spec_doc = doc.get("spec") or {}
    if not isinstance(spec_doc, Mapping):
        msg = f"{src}: spec: expected a mapping of FrameSpec fields"
        raise ConfigError(msg)
    spec = FrameSpec(**spec_fields(FrameSpec, spec_doc, f"{src}: spec"))
    nom = frame_matrices(spec)
    dofs = [str(v) for v in nom["dofs"]]
    out: dict[str, Any] = {"M": nom["M"], "K0": nom["K0"], "dofs": nom["dofs"],
                           "parameter_names": np.array(JOINTS),
                           **{f"K_{j}": nom[f"K_{j}"] for j in JOINTS},
                           "measured_dofs": _labels(doc, "sensors", dofs, src),
                           "force_dofs": _labels(doc, "forces", dofs, src),
                           "node_xyz": nom["node_xyz"],
                           "trace_nodes": np.array(frame_outline(spec), dtype=np.int64)}
    if "bounds" in doc:
        b = doc["bounds"]
        if not (isinstance(b, list) and len(b) == 2 and all(_number(v) for v in b)
                and -1.0 < b[0] < b[1]):
            msg = f"{src}: bounds: expected [lower, upper] with -1 < lower < upper, got {b!r}"
            raise ConfigError(msg)
        out["lower"] = np.full(len(JOINTS), float(b[0]))
        out["upper"] = np.full(len(JOINTS), float(b[1]))
    return out
