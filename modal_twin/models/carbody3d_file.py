"""A 3D shell carbody from a YAML file, and its ``model info`` summary (named modes).

The file has one top-level section ``carbody3d`` (so it is told apart from a vehicle
file's ``carbody``)::

    carbody3d:
      name: trailer car shell, in service
      in_service: true          # false: the empty shell
      mesh: {n_length: 30, n_width: 4, n_height: 4}
      zones:                    # overrides of the tuned defaults, any subset
        underframe: {E: 70.0e9, rho: 2700.0}
      modes: 30                 # modes computed (rigid ones included)

Every other parameter keeps the default of :class:`~.carbody3d.CarbodyParams`.

A **zone-factor file** holds the carbody updating's result (:mod:`modal_twin.updating.
carbody`): factors on the zone moduli and densities of a carbody, which
``modal-twin ride --carbody-params FILE`` applies to the vehicle's shell carbody::

    carbody_zone_factors:       # E_<zone> / rho_<zone> (CarbodyParams.with_zone_factors)
      E_side_wall: 0.893
      E_underframe: 1.081
"""

from __future__ import annotations

import contextlib
import math
import os
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import yaml

from modal_twin.errors import ConfigError
from modal_twin.models.carbody3d import ZONE_FACTOR_NAMES, ZONES, CarbodyFE, CarbodyParams
from modal_twin.models.carbody_modes import name_modes
from modal_twin.models.fe import solve_modes
from modal_twin.yaml_files import read_yaml

__all__ = ["carbody3d_info", "carbody3d_params", "config_section", "format_carbody3d_info",
           "is_carbody3d_file", "load_carbody3d", "load_zone_factors", "save_zone_factors"]

ZONE_FACTORS_KEY = "carbody_zone_factors"

_ZONE_KEYS = ("E", "nu", "rho", "t", "t_b", "nsm", "E_service")
_MESH_KEYS = ("n_length", "n_width", "n_height")
_TOP_KEYS = ("name", "in_service", "mesh", "zones", "modes")


def is_carbody3d_file(path: str | Path) -> bool:
    """Tell whether ``path`` is a 3D carbody file (it has a ``carbody3d`` section)."""
    doc = read_yaml(path, "model file")
    return isinstance(doc, Mapping) and "carbody3d" in doc


def config_section(v: object, where: str, src: str, allowed: tuple[str, ...]
                   ) -> Mapping[str, Any]:
    """Return ``v`` if it is a mapping of ``allowed`` keys; else one-line :class:`ConfigError`."""
    if not isinstance(v, Mapping):
        msg = f"{src}: {where}: expected a mapping, got {type(v).__name__}"
        raise ConfigError(msg)
    bad = sorted(str(k) for k in v if k not in allowed)
    if bad:
        msg = f"{src}: {where}: unknown keys {bad} (expected some of {list(allowed)})"
        raise ConfigError(msg)
    return v


def _number(v: object, where: str, src: str) -> float:
    if isinstance(v, str):  # PyYAML (YAML 1.1) reads 7.0e10 without a dot as a string
        with contextlib.suppress(ValueError):
            v = float(v)
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        msg = f"{src}: {where}: expected a finite number, got {v!r}"
        raise ConfigError(msg)
    return float(v)


def _int(v: object, where: str, src: str, low: int, high: int) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or not low <= v <= high:
        msg = f"{src}: {where}: expected an int in [{low}, {high}], got {v!r}"
        raise ConfigError(msg)
    return v


def load_carbody3d(path: str | Path) -> tuple[str, CarbodyParams, int]:
    """Return ``(name, params, n_modes)`` of a 3D carbody file (module docstring).

    Raises
    ------
    ConfigError
        Unreadable file, unknown keys, bad values (one line naming file and key).
    """
    src = str(path)
    doc = read_yaml(path, "model file")
    sec = config_section(doc.get("carbody3d") if isinstance(doc, Mapping) else None, "carbody3d",
                   src, _TOP_KEYS)
    p = carbody3d_params(sec, "carbody3d", src)
    n_modes = _int(sec.get("modes", 30), "carbody3d.modes", src, 7, 200)
    name = sec.get("name", Path(path).stem)
    return str(name), p, n_modes


def carbody3d_params(sec: Mapping[str, Any], where: str, src: str) -> CarbodyParams:
    """Return the :class:`CarbodyParams` of a section's ``in_service``, ``mesh``, ``zones``.

    Used for a ``carbody3d`` file and a 3D vehicle file's ``carbody_shell`` section.

    Raises
    ------
    ConfigError
        Bad values (one line naming ``src`` and ``where.key``).
    """
    p = CarbodyParams()
    in_service = sec.get("in_service", True)
    if not isinstance(in_service, bool):
        msg = f"{src}: {where}.in_service: expected true or false, got {in_service!r}"
        raise ConfigError(msg)
    mesh = config_section(sec.get("mesh", {}), f"{where}.mesh", src, _MESH_KEYS)
    sizes = {k: _int(v, f"{where}.mesh.{k}", src, 2, 400) for k, v in mesh.items()}
    zones = dict(p.zones)
    for zname, over in config_section(sec.get("zones", {}), f"{where}.zones", src, ZONES).items():
        vals = config_section(over, f"{where}.zones.{zname}", src, _ZONE_KEYS)
        zones[zname] = replace(zones[zname], **{
            k: _number(v, f"{where}.zones.{zname}.{k}", src) for k, v in vals.items()})
    return replace(p, in_service=in_service, zones=zones,
                   n_length=sizes.get("n_length", p.n_length),
                   n_width=sizes.get("n_width", p.n_width),
                   n_height=sizes.get("n_height", p.n_height))


def load_zone_factors(path: str | Path) -> dict[str, float]:
    """Return the factors of a zone-factor file (module docstring).

    Raises
    ------
    ConfigError
        Unreadable file, no ``carbody_zone_factors`` mapping, an unknown name or a factor
        that is not a finite number > 0 (one line naming the file and the key).
    """
    src = str(path)
    doc = read_yaml(path, "zone-factor file")
    where = ZONE_FACTORS_KEY
    sec = config_section(doc.get(where) if isinstance(doc, Mapping) else None, where, src,
                         ZONE_FACTOR_NAMES)
    out = {}
    for name, v in sec.items():
        f = _number(v, f"{where}.{name}", src)
        if not f > 0.0:
            msg = f"{src}: {where}.{name}: expected a factor > 0, got {v!r}"
            raise ConfigError(msg)
        out[str(name)] = f
    return out


def save_zone_factors(path: str | Path, factors: Mapping[str, float]) -> None:
    """Write ``factors`` as a zone-factor file that :func:`load_zone_factors` reads.

    Names from :data:`~.carbody3d.ZONE_FACTOR_NAMES`; written to a temporary file beside
    ``path``, then renamed (a reader never sees half a file).
    """
    bad = sorted(str(k) for k in factors if k not in ZONE_FACTOR_NAMES)
    if bad:
        msg = f"factors: unknown names {bad} (expected some of {list(ZONE_FACTOR_NAMES)})"
        raise ConfigError(msg)
    p = Path(path)
    tmp = p.with_name(p.name + ".tmp")
    tmp.write_text(yaml.safe_dump({ZONE_FACTORS_KEY: {str(k): float(v) for k, v in
                                                      factors.items()}}, sort_keys=False))
    os.replace(tmp, p)


def carbody3d_info(car: CarbodyFE, n_modes: int = 30, *, name: str = "carbody",
                   n_show: int | None = None) -> dict[str, Any]:
    """Return a JSON-ready summary: DOFs, mass, and the named free-free modes.

    Rigid modes are left out of ``modes`` and counted in ``n_rigid``.
    """
    sol = solve_modes(car.asm.K, car.asm.M, min(n_modes, car.asm.n_dof - 2))
    named = name_modes(car, sol.f_hz, sol.Phi)
    flex = [m for m in named if m.kind != "rigid"]
    if n_show is not None:
        flex = flex[:n_show]
    return {
        "name": name, "n_dof": car.asm.n_dof, "n_nodes": len(car.asm.nodes),
        "total_mass_kg": car.asm.total_mass(), "in_service": car.params.in_service,
        "n_rigid": len(named) - len([m for m in named if m.kind != "rigid"]),
        "modes": [{"number": m.number, "f_hz": m.f_hz, "kind": m.kind, "order": m.order,
                   "label": m.label, "equipment_share": m.equipment_share,
                   "section_shares": dict(zip(
                       ("lateral", "vertical", "rotation", "diamond", "breathing", "local"),
                       (round(float(v), 4) for v in m.fractions), strict=True))}
                  for m in flex],
    }


def format_carbody3d_info(info: Mapping[str, Any]) -> str:
    """Return the summary of :func:`carbody3d_info` as a text table."""
    state = "in service" if info["in_service"] else "empty shell"
    head = info["name"] if state in str(info["name"]) else f"{info['name']} ({state})"
    lines = [f"{head}: {info['n_nodes']} nodes, {info['n_dof']} DOFs, "
             f"total mass {info['total_mass_kg'] / 1e3:.2f} t, {info['n_rigid']} rigid modes",
             f"{'mode':>4} {'f [Hz]':>8}  type"]
    for m in info["modes"]:
        lines.append(f"{m['number']:>4d} {m['f_hz']:8.3f}  {m['label']}")
    return "\n".join(lines)
