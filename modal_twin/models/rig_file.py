"""Rig files: which structure the simulated rig runs, its sensors and any hidden effects.

::

    structure: ../structures/building.yaml   # relative to this file
    noise_rms: {acceleration: 0.002, displacement: 1.0e-5, force: 200.0}   # SI
    sensitivity: {acceleration: 0.10197}     # raw units per SI unit (1 V/g)
    seed: 7
    theta: {E_Fc27: 2.4e10}                   # parameter values of the truth (optional)
    channels: ["floor_*"]                     # the structure's channels measured (optional,
                                              # fnmatch patterns; default all)
    effects:                                  # what the nominal model is not told
      - {component: ESB1, law: coulomb, params: {mu_s: 0.06, mu_k: 0.04}}
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from modal_twin.errors import ConfigError
from modal_twin.models.effects import EffectSpec
from modal_twin.yaml_files import read_yaml

__all__ = ["RigFile", "load_rig"]


@dataclass(frozen=True, slots=True)
class RigFile:
    """Contents of a rig file."""

    path: Path
    structure: Path
    noise_rms: dict[str, float]
    sensitivity: dict[str, float]
    effects: tuple[EffectSpec, ...]
    seed: int
    theta: dict[str, float] = field(default_factory=dict)  # parameter values of the truth
    channels: tuple[str, ...] = ()  # patterns of the structure's channels measured; () = all


def _num_map(path: Path, doc: dict[str, Any], key: str) -> dict[str, float]:
    value = doc.get(key) or {}
    if not isinstance(value, dict):
        msg = f"{path}: key {key!r}: expected a mapping quantity -> number"
        raise ConfigError(msg)
    out = {}
    for q, v in value.items():
        if not isinstance(v, int | float) or isinstance(v, bool) or v < 0:
            msg = f"{path}: key '{key}.{q}': expected a number >= 0, got {v!r}"
            raise ConfigError(msg)
        out[str(q)] = float(v)
    return out


def load_rig(path: str | Path) -> RigFile:
    """Read a rig file.

    Raises
    ------
    ConfigError
        Naming the file, key and problem.
    """
    p = Path(path)
    doc = read_yaml(p, "rig file")
    if not isinstance(doc.get("structure"), str):
        msg = f"{p}: key 'structure': missing (path of the structure file)"
        raise ConfigError(msg)
    structure = (p.parent / doc["structure"]).resolve()
    if not structure.is_file():
        msg = f"{p}: key 'structure': no such file {structure}"
        raise ConfigError(msg)
    effects = []
    for i, e in enumerate(doc.get("effects") or []):
        if not isinstance(e, dict) or not isinstance(e.get("component"), str) or not \
                isinstance(e.get("law"), str):
            msg = f"{p}: key 'effects[{i}]': expected {{component: NAME, law: LAW, params: {{}}}}"
            raise ConfigError(msg)
        params = e.get("params") or {}
        if not isinstance(params, dict) or not all(
                isinstance(v, int | float) and not isinstance(v, bool) for v in params.values()):
            msg = f"{p}: key 'effects[{i}].params': expected a mapping of numbers"
            raise ConfigError(msg)
        effects.append(EffectSpec(e["component"], e["law"],
                                  {str(k): float(v) for k, v in params.items()}))
    seed = doc.get("seed", 0)
    if not isinstance(seed, int):
        msg = f"{p}: key 'seed': expected an integer, got {seed!r}"
        raise ConfigError(msg)
    theta = doc.get("theta") or {}
    if not isinstance(theta, dict) or not all(
            isinstance(v, int | float) and not isinstance(v, bool) for v in theta.values()):
        msg = f"{p}: key 'theta': expected a mapping parameter -> number"
        raise ConfigError(msg)
    channels = doc.get("channels") or []
    if not isinstance(channels, list) or not all(isinstance(c, str) for c in channels):
        msg = f"{p}: key 'channels': expected a list of channel names or patterns (floor_*)"
        raise ConfigError(msg)
    return RigFile(p, structure, _num_map(p, doc, "noise_rms"),
                   _num_map(p, doc, "sensitivity"), tuple(effects), seed,
                   {str(k): float(v) for k, v in theta.items()}, tuple(channels))
