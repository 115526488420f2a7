"""3D vehicle file (``config/vehicles/trailer_car_3d.yaml``) -> :class:`Vehicle3DSpec`.

The file has ``kind: vehicle3d`` and the sections below (SI units; every suspension value
is per element, e.g. per axle box or per air spring):

``carbody``  ``{model, mass, Ixx, Iyy, Izz, length, cg_height, floor_height, pivot_spacing}``
  ``model``: ``rigid`` (default; six DOFs of the mass and inertia given) or ``shell`` (the
  Craig-Bampton shell carbody of the ``carbody_shell`` section,
  :mod:`modal_twin.models.carbody_shell`; its own mass and inertia, the numbers here
  serve the static axle load). The vertical-plane vehicle's beam carbody is the other
  vehicle file (``config/vehicles/trailer_car.yaml``, :mod:`modal_twin.models.vehicle`).
``carbody_shell`` (optional)  ``{in_service, mesh, zones}`` as a ``carbody3d`` file
  (:mod:`modal_twin.models.carbody3d_file`) and ``{f_cut_hz, f_keep_hz, zeta}``: the CB
  cut-off, the flexible free-free modes kept in the vehicle (plus residual vectors) and
  their modal damping; the seats take ``secondary.half_spacing``.
``bogie``  ``{mass, Ixx, Iyy, Izz, cg_height, wheelbase}``
``wheelset``  ``{mass, Izz}`` (lateral and yaw; vertical and roll follow the track)
``contact``  ``{conicity, r0, b, f11, f22}`` (:mod:`modal_twin.models.wheel_rail`)
``primary``  ``{kx, ky, kz, cz, half_spacing}`` per axle box
``secondary``  ``{kx, ky, kz, half_spacing, seat_height}`` per air spring
``vertical_damper``, ``lateral_damper``, ``yaw_damper``  ``{c, k_series[, half_spacing]}``
  Maxwell elements (two vertical and two yaw dampers per bogie at ``+-half_spacing``, one
  lateral damper per bogie on the centre line)
``anti_roll_bar``  ``{k_roll}`` per bogie, N m/rad
``traction_rod``  ``{kx}`` per bogie
``floor_points``  ``[{label, x, y}]`` floor accelerometers (vertical and lateral)
``equipment`` (optional)  ``[{name, x, mass, inertia: [Jxx, Jyy, Jzz], mount, hanger,
  half_length, half_width, depth, f_mount_hz, lateral_ratio, zeta}]``: underframe or roof
  boxes, rigid bodies on four hangers (:class:`~modal_twin.models.carbody3d.Equipment`,
  same meaning and defaults). ``hanger: rigid``: the box is part of the carbody (its mass
  and inertia are inside the ``carbody`` values, the shell's own equipment stands for it):
  the car is the car without the entry. ``hanger: elastic``: the box has its own six DOFs
  on four hangers, each a spring-damper in x, y, z (vertical ``k = m (2 pi f_mount)^2 /
  4``, lateral and longitudinal ``lateral_ratio k``, ``c = 2 zeta sqrt(k m / 4)`` times the
  same ratio, as the shell's mounts); the rigid carbody's values (the car in service) lose
  the box's mass and inertia, the shell leaves out its own item of that name (:mod:`modal_
  twin.models.vehicle3d`).
``speed_kmh``
``extends`` (optional)  another vehicle file of the same folder this one changes: its
  sections are updated key by key (``config/vehicles/trailer_car_3d_shell.yaml``)

Missing keys and wrong types raise :class:`ConfigError`, non-positive physical values
:class:`ModelError`; both name the file and the entry.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from modal_twin.errors import ConfigError
from modal_twin.models.carbody3d import CarbodyParams, Equipment
from modal_twin.models.carbody3d_file import carbody3d_params, config_section
from modal_twin.models.vehicle_spec import _num as read_number
from modal_twin.yaml_files import read_yaml

__all__ = [
    "CARBODY_MODELS",
    "DEFAULT_VEHICLE3D_YAML",
    "FloorPoint",
    "ShellSpec",
    "Vehicle3DSpec",
    "is_vehicle3d_file",
    "load_vehicle3d",
]

DEFAULT_VEHICLE3D_YAML = (Path(__file__).resolve().parents[2] / "config" / "vehicles"
                          / "trailer_car_3d.yaml")
"""The 3D trailer car of [002] shipped with the package."""

G_ACC = 9.81
"""Gravity, m/s^2."""

# section -> key -> may be zero (dampers may be switched off)
_SCHEMA: dict[str, dict[str, bool]] = {
    "carbody": {"mass": False, "Ixx": False, "Iyy": False, "Izz": False, "length": False,
                "cg_height": False, "floor_height": False, "pivot_spacing": False},
    "bogie": {"mass": False, "Ixx": False, "Iyy": False, "Izz": False,
              "cg_height": False, "wheelbase": False},
    "wheelset": {"mass": False, "Izz": False},
    "contact": {"conicity": False, "r0": False, "b": False, "f11": False, "f22": False},
    "primary": {"kx": False, "ky": False, "kz": False, "cz": True, "half_spacing": False},
    "secondary": {"kx": False, "ky": False, "kz": False, "half_spacing": False,
                  "seat_height": False},
    "vertical_damper": {"c": True, "k_series": False, "half_spacing": False},
    "lateral_damper": {"c": True, "k_series": False},
    "yaw_damper": {"c": True, "k_series": False, "half_spacing": False},
    "anti_roll_bar": {"k_roll": True},
    "traction_rod": {"kx": True},
}


CARBODY_MODELS: tuple[str, ...] = ("rigid", "shell")
"""Carbody models of the 3D vehicle (``carbody.model``)."""


@dataclass(frozen=True, slots=True)
class ShellSpec:
    """The shell carbody of a 3D vehicle (``carbody_shell``; module docstring).

    Attributes
    ----------
    params : CarbodyParams
        Mesh, zones, service state (seat spacing set from the vehicle when built).
    f_cut_hz : float
        Craig-Bampton cut-off, Hz.
    f_keep_hz : float or None
        Flexible free-free modes kept in the vehicle, Hz (None: all CB coordinates).
    zeta : float
        Modal damping of the flexible modes.
    """

    params: CarbodyParams = field(default_factory=CarbodyParams)
    f_cut_hz: float = 60.0
    f_keep_hz: float | None = 40.0
    zeta: float = 0.02


@dataclass(frozen=True, slots=True)
class FloorPoint:
    """A floor accelerometer: ``label``, ``x`` (m from the centre, + front), ``y`` (+ left)."""

    label: str
    x: float
    y: float = 0.0


@dataclass(frozen=True, slots=True)
class Vehicle3DSpec:
    """A 3D trailer car (module docstring).

    Attributes
    ----------
    name : str
    values : mapping section -> mapping key -> float
        The numbers of the file's sections (``values["primary"]["kx"]`` ...).
    floor_points : tuple of FloorPoint
    speed_kmh : float
    source : str
    carbody_model : {"rigid", "shell"}
    shell : ShellSpec
        Used when ``carbody_model`` is ``"shell"``.
    equipment : tuple of Equipment
        The file's equipment boxes (module docstring); :attr:`hung_equipment` those on
        elastic hangers.
    """

    name: str
    values: Mapping[str, Mapping[str, float]]
    floor_points: tuple[FloorPoint, ...]
    speed_kmh: float = 300.0
    source: str = "<spec>"
    carbody_model: str = "rigid"
    shell: ShellSpec = field(default_factory=ShellSpec)
    equipment: tuple[Equipment, ...] = ()

    @property
    def hung_equipment(self) -> tuple[Equipment, ...]:
        """The boxes on elastic hangers, with six DOFs of their own (module docstring)."""
        return tuple(e for e in self.equipment if e.hanger == "elastic")

    def with_equipment(self, name: str, **changes: Any) -> Vehicle3DSpec:
        """Copy with one box's fields changed: ``spec.with_equipment("EQ1", hanger="elastic")``.

        Raises
        ------
        ConfigError
            Unknown box or field, or a value the file would refuse.
        """
        names = [e.name for e in self.equipment]
        if name not in names:
            msg = f"equipment: expected one of {names}, got {name!r}"
            raise ConfigError(msg)
        old = self.equipment[names.index(name)]
        bad = sorted(set(changes) - set(_EQUIPMENT_KEYS))
        if bad:
            msg = f"equipment {name}: unknown fields {bad}; expected {list(_EQUIPMENT_KEYS)}"
            raise ConfigError(msg)
        new = replace(old, **changes)
        _check_equipment(new, f"equipment {name}", self.source,
                         0.5 * self.v("carbody", "length"))
        boxes = list(self.equipment)
        boxes[names.index(name)] = new
        return replace(self, equipment=tuple(boxes))

    def with_carbody(self, model: str) -> Vehicle3DSpec:
        """Copy with another carbody model (:data:`CARBODY_MODELS`).

        Raises
        ------
        ConfigError
            Unknown model.
        """
        if model not in CARBODY_MODELS:
            msg = f"carbody.model: expected one of {list(CARBODY_MODELS)}, got {model!r}"
            raise ConfigError(msg)
        return replace(self, carbody_model=model)

    def with_zone_factors(self, factors: Mapping[str, float]) -> Vehicle3DSpec:
        """Copy whose shell carbody has its zone moduli / densities times ``factors``.

        ``factors``: the carbody updating's result (``E_<zone>``, ``rho_<zone>``;
        :meth:`~modal_twin.models.carbody3d.CarbodyParams.with_zone_factors`, which raises
        :class:`~modal_twin.errors.OptionError` on an unknown name or a bad factor).
        """
        shell = replace(self.shell, params=self.shell.params.with_zone_factors(factors))
        return replace(self, shell=shell)

    def v(self, section: str, key: str) -> float:
        """One value, e.g. ``spec.v("yaw_damper", "c")``."""
        return float(self.values[section][key])

    def with_values(self, **changes: Mapping[str, float]) -> Vehicle3DSpec:
        """Copy with some values replaced: ``spec.with_values(contact={"conicity": 0.3})``.

        Raises
        ------
        ConfigError
            Unknown section or key.
        """
        vals = {s: dict(d) for s, d in self.values.items()}
        for sec, upd in changes.items():
            for k, val in upd.items():
                if sec not in vals or k not in vals[sec]:
                    msg = f"{sec}.{k}: unknown vehicle value"
                    raise ConfigError(msg)
                vals[sec][k] = float(val)
        return replace(self, values=vals)

    @property
    def speed(self) -> float:
        """Running speed, m/s."""
        return self.speed_kmh / 3.6

    @property
    def pivot_x(self) -> tuple[float, float]:
        """Bogie centres (bogie 1 leading, bogie 2), m."""
        h = 0.5 * self.v("carbody", "pivot_spacing")
        return h, -h

    @property
    def axle_x(self) -> tuple[float, float, float, float]:
        """Wheelsets 1 (leading) .. 4, m from the carbody centre."""
        a = 0.5 * self.v("bogie", "wheelbase")
        f, r = self.pivot_x
        return f + a, f - a, r + a, r - a

    @property
    def axle_load(self) -> float:
        """Static vertical load on one wheelset, N (a quarter of car and bogies, plus it)."""
        m = (self.v("carbody", "mass") + 2.0 * self.v("bogie", "mass")) / 4.0
        return G_ACC * (m + self.v("wheelset", "mass"))


def _number(d: Any, key: str, where: str, src: str, zero_ok: bool) -> float:
    if not isinstance(d, Mapping):
        msg = f"{src}: {where}.{key}: missing"
        raise ConfigError(msg)
    return read_number(d, key, where, src, positive=not zero_ok)


def is_vehicle3d_file(path: str | Path) -> bool:
    """Tell whether ``path`` is a 3D vehicle file (``kind: vehicle3d``)."""
    doc = read_yaml(path, "model file")
    return isinstance(doc, Mapping) and doc.get("kind") == "vehicle3d"


def _read_extended(p: Path, depth: int = 0) -> dict[str, Any]:
    """Read a vehicle file over the one it ``extends`` (a file of the same folder).

    A section (a mapping) updates the base's section key by key; any other value replaces
    the base's; the name is the file's own (or its stem). E.g. ``extends:
    trailer_car_3d.yaml`` with ``carbody: {model: shell}``.
    """
    doc = dict(read_yaml(p, "vehicle file"))
    base = doc.pop("extends", None)
    if base is None:
        return doc
    bp = (p.parent / str(base)).resolve()
    if not isinstance(base, str) or bp.parent != p.parent.resolve() or depth >= 4:
        msg = (f"{p}: extends: expected the name of a vehicle file in the same folder "
               f"(at most 4 deep), got {base!r}")
        raise ConfigError(msg)
    merged = _read_extended(bp, depth + 1)
    merged.pop("name", None)  # the file's own name, else its stem
    for key, value in doc.items():
        old = merged.get(key)
        merged[key] = ({**old, **value} if isinstance(old, Mapping)
                       and isinstance(value, Mapping) else value)
    return merged


def load_vehicle3d(path: str | Path | None = None) -> Vehicle3DSpec:
    """Read a 3D vehicle file (default :data:`DEFAULT_VEHICLE3D_YAML`).

    Raises
    ------
    ConfigError
        Not a ``kind: vehicle3d`` file, a missing key, a wrong type, a floor point off the car.
    ModelError
        A mass, stiffness or length that is not positive (a damping may be 0).
    """
    p = Path(DEFAULT_VEHICLE3D_YAML if path is None else path)
    doc = _read_extended(p)
    src = str(p)
    if doc.get("kind") != "vehicle3d":
        msg = f"{src}: kind: expected 'vehicle3d', got {doc.get('kind')!r}"
        raise ConfigError(msg)
    values = {sec: {k: _number(doc.get(sec), k, sec, src, z) for k, z in keys.items()}
              for sec, keys in _SCHEMA.items()}
    model = doc["carbody"].get("model", "rigid")
    if model not in CARBODY_MODELS:
        hint = (" (the beam carbody is the vertical-plane vehicle, "
                "config/vehicles/trailer_car.yaml)" if model == "beam" else "")
        msg = (f"{src}: carbody.model: expected one of {list(CARBODY_MODELS)}, got "
               f"{model!r}{hint}")
        raise ConfigError(msg)
    shell = _shell_spec(doc.get("carbody_shell", {}), src)
    pts = doc.get("floor_points")
    if not isinstance(pts, list) or not pts:
        msg = f"{src}: floor_points: expected a non-empty list, got {pts!r}"
        raise ConfigError(msg)
    half = 0.5 * values["carbody"]["length"]
    floor = []
    for i, item in enumerate(pts):
        where = f"floor_points[{i}]"
        if not isinstance(item, Mapping) or "label" not in item:
            msg = f"{src}: {where}: expected a mapping with a label, got {item!r}"
            raise ConfigError(msg)
        xy = [item.get("x"), item.get("y", 0.0)]
        if any(isinstance(c, bool) or not isinstance(c, int | float) or not math.isfinite(c)
               for c in xy) or abs(float(xy[0])) > half or abs(float(xy[1])) > 1.6:
            msg = f"{src}: {where}: expected finite x within +-{half} m, |y| <= 1.6 m, got {xy}"
            raise ConfigError(msg)
        floor.append(FloorPoint(str(item["label"]), float(xy[0]), float(xy[1])))
    speed = _number(doc, "speed_kmh", "<top>", src, False) if "speed_kmh" in doc else 300.0
    return Vehicle3DSpec(name=str(doc.get("name", p.stem)), values=values,
                         floor_points=tuple(floor), speed_kmh=speed, source=src,
                         carbody_model=str(model), shell=shell,
                         equipment=_equipment(doc.get("equipment", []), src, half))


_EQUIPMENT_KEYS = ("name", "x", "mass", "inertia", "mount", "hanger", "half_length",
                   "half_width", "depth", "f_mount_hz", "lateral_ratio", "zeta")
_CHOICES = {"mount": ("underframe", "roof"), "hanger": ("elastic", "rigid")}


def _check_equipment(e: Equipment, where: str, src: str, half: float) -> None:
    """Refuse a box off the car, a choice not known or a value out of range."""
    for key, options in _CHOICES.items():
        if getattr(e, key) not in options:
            msg = f"{src}: {where}.{key}: expected one of {list(options)}, got {getattr(e, key)!r}"
            raise ConfigError(msg)
    nums = {"mass": e.mass, "half_length": e.half_length, "half_width": e.half_width,
            "f_mount_hz": e.f_mount_hz, "lateral_ratio": e.lateral_ratio,
            **{f"inertia[{i}]": v for i, v in enumerate(e.inertia)}}
    for key, val in nums.items():
        if isinstance(val, bool) or not isinstance(val, int | float) or not (
                math.isfinite(val) and val > 0.0):
            msg = f"{src}: {where}.{key}: expected a finite value > 0, got {val!r}"
            raise ConfigError(msg)
    for key, val, lo, hi in (("x", e.x, -half, half), ("depth", e.depth, 0.0, 2.0),
                             ("zeta", e.zeta, 0.0, 0.999)):
        if isinstance(val, bool) or not isinstance(val, int | float) or not lo <= val <= hi:
            msg = f"{src}: {where}.{key}: expected a value in [{lo}, {hi}], got {val!r}"
            raise ConfigError(msg)
    if abs(e.x) + e.half_length > half:
        msg = f"{src}: {where}: hangers at x = {e.x} +- {e.half_length} are off the car"
        raise ConfigError(msg)


def _equipment(items: object, src: str, half: float) -> tuple[Equipment, ...]:
    """Read the ``equipment`` list (module docstring)."""
    if not isinstance(items, list):
        msg = f"{src}: equipment: expected a list, got {items!r}"
        raise ConfigError(msg)
    out: list[Equipment] = []
    for i, item in enumerate(items):
        where = f"equipment[{i}]"
        if not isinstance(item, Mapping) or not isinstance(item.get("name"), str):
            msg = f"{src}: {where}: expected a mapping with a name, got {item!r}"
            raise ConfigError(msg)
        bad = sorted(set(item) - set(_EQUIPMENT_KEYS))
        missing = [k for k in ("x", "mass", "inertia") if k not in item]
        if bad or missing:
            msg = (f"{src}: {where}: unknown keys {bad}, missing {missing}; expected "
                   f"{list(_EQUIPMENT_KEYS)}")
            raise ConfigError(msg)
        inertia = item["inertia"]
        if not isinstance(inertia, list) or len(inertia) != 3:
            msg = f"{src}: {where}.inertia: expected [Jxx, Jyy, Jzz], got {inertia!r}"
            raise ConfigError(msg)
        e = Equipment(**{**item, "inertia": tuple(inertia)})
        if e.name in [o.name for o in out]:
            msg = f"{src}: {where}: the name {e.name!r} is used twice"
            raise ConfigError(msg)
        _check_equipment(e, where, src, half)
        out.append(e)
    return tuple(out)


_SHELL_KEYS = ("in_service", "mesh", "zones", "f_cut_hz", "f_keep_hz", "zeta")


def _shell_spec(sec: object, src: str) -> ShellSpec:
    """Read the ``carbody_shell`` section (module docstring)."""
    where = "carbody_shell"
    sec = config_section(sec, where, src, _SHELL_KEYS)
    d = ShellSpec()
    f_cut = read_number(sec, "f_cut_hz", where, src, default=d.f_cut_hz)
    f_keep = (None if "f_keep_hz" in sec and sec["f_keep_hz"] is None
              else read_number(sec, "f_keep_hz", where, src, default=d.f_keep_hz))
    zeta = read_number(sec, "zeta", where, src, positive=False, default=d.zeta)
    if not zeta < 1.0:
        msg = f"{src}: {where}.zeta: expected a damping ratio in [0, 1), got {zeta!r}"
        raise ConfigError(msg)
    return ShellSpec(params=carbody3d_params(sec, where, src), f_cut_hz=f_cut,
                     f_keep_hz=f_keep, zeta=zeta)
