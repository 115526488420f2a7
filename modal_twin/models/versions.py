"""Versioned models: a structure file plus parameter values and added effects.

A model version is a small YAML file beside its siblings::

    structure: /abs/path/config/structures/building.yaml
    version: 2
    parent: 1
    created: 2026-11-22T03:10:00
    note: added stick_slip at ESB1 (held-out NMSE 3.46 % -> 0.22 %)
    theta: {E_Fc27: 2.95e10}
    effects:
      - {component: ESB1, law: stick_slip, params: {Fk: 80100.0, Fs: 80100.0}}
    errors: {F0_C1_x: 3.1, ...}        # held-out NMSE per channel, percent

``write_version`` never overwrites: version n stays when n + 1 is written. The error
history of a model line is the sequence of their ``errors`` maps.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any

import yaml

from modal_twin.errors import ConfigError
from modal_twin.models.effects import EffectSpec
from modal_twin.paths import check_regular
from modal_twin.yaml_files import read_yaml

__all__ = ["ModelVersion", "history", "latest_version", "read_version", "write_version"]


@dataclass(frozen=True, slots=True)
class ModelVersion:
    """One version of a model line."""

    structure: Path
    version: int = 0
    parent: int | None = None
    theta: dict[str, float] = field(default_factory=dict)
    effects: tuple[EffectSpec, ...] = ()
    note: str = ""
    errors: dict[str, float] = field(default_factory=dict)
    created: str = ""
    path: Path | None = None

    @property
    def label(self) -> str:
        """Short name, e.g. ``v2``."""
        return f"v{self.version}"


def _file(folder: Path, version: int) -> Path:
    return folder / f"v{version:04d}.yaml"


def write_version(folder: str | Path, mv: ModelVersion) -> ModelVersion:
    """Write ``mv`` as the next version in ``folder`` (never overwriting) and return it.

    The returned version has its version number, parent and path set.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    last = latest_version(folder)
    version = 0 if last is None else last.version + 1
    parent = None if last is None else last.version
    path = _file(folder, version)
    doc: dict[str, Any] = {
        "structure": str(Path(mv.structure).resolve()),
        "version": version,
        "parent": parent,
        "created": datetime.now().isoformat(timespec="seconds"),
        "note": mv.note,
        "theta": {k: float(v) for k, v in mv.theta.items()},
        "effects": [{"component": e.component, "law": e.law,
                     "params": {k: float(v) for k, v in e.params.items()}} for e in mv.effects],
        "errors": {k: float(v) for k, v in mv.errors.items()},
    }
    with path.open("x") as fh:  # "x": version n is never overwritten
        yaml.safe_dump(doc, fh, sort_keys=False)
    return read_version(path)


def read_version(path: str | Path) -> ModelVersion:
    """Read a version file, or wrap a plain structure (or matrix) file as version 0.

    Raises
    ------
    ConfigError
        Naming the file and the key.
    """
    from modal_twin.models.matrix_model import MATRIX_SUFFIXES

    p = Path(path)
    if p.suffix.lower() in MATRIX_SUFFIXES:  # a matrix model of the user's FE tool
        return ModelVersion(structure=check_regular(p.resolve(), "matrix model",
                                                    missing_ok=True), path=p)
    doc = read_yaml(p, "model file")
    if "structure" not in doc:  # a structure file itself
        return ModelVersion(structure=p.resolve(), path=p)
    structure = check_regular((p.parent / str(doc["structure"])).resolve(),
                              f"structure named by {p}", missing_ok=True)
    try:
        effects = tuple(EffectSpec(str(e["component"]), str(e["law"]),
                                   {str(k): float(v) for k, v in (e.get("params") or {}).items()})
                        for e in doc.get("effects") or [])
        return ModelVersion(
            structure=structure,
            version=int(doc.get("version", 0)),
            parent=None if doc.get("parent") is None else int(doc["parent"]),
            theta={str(k): float(v) for k, v in (doc.get("theta") or {}).items()},
            effects=effects,
            note=str(doc.get("note", "")),
            errors={str(k): float(v) for k, v in (doc.get("errors") or {}).items()},
            created=str(doc.get("created", "")),
            path=p,
        )
    except (KeyError, TypeError, ValueError) as err:
        msg = f"{p}: bad model version entry: {err!r}"
        raise ConfigError(msg) from err


def latest_version(folder: str | Path) -> ModelVersion | None:
    """Highest version in ``folder`` (None if empty)."""
    files = sorted(Path(folder).glob("v[0-9][0-9][0-9][0-9].yaml"))
    return read_version(files[-1]) if files else None


def history(folder: str | Path) -> list[ModelVersion]:
    """All versions in order.

    Raises
    ------
    ConfigError
        ``folder`` is not a folder.
    """
    if not Path(folder).is_dir():
        msg = f"{folder}: no such model folder"
        raise ConfigError(msg)
    return [read_version(f) for f in sorted(Path(folder).glob("v[0-9][0-9][0-9][0-9].yaml"))]
