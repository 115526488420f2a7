"""Vehicle file (``config/vehicles/*.yaml``) -> :class:`VehicleSpec` of a trailer car.

A vehicle file lists, in SI units (see ``config/vehicles/trailer_car.yaml``):

``carbody``
    ``{length, pivot_spacing, shell_line_mass, fittings_line_mass, EI, zeta, n_elements,
    cutoff_hz}``: a free-free Euler-Bernoulli beam (Sec. 5.1 of [002] uses a Craig-Bampton
    flexible carbody) with a uniform line mass ``shell + fittings`` (kg/m).
``bogie``
    ``{mass, pitch_inertia, wheelbase}`` of each bogie frame.
``primary``, ``secondary``
    ``{k, c}``: vertical stiffness (N/m) and damping (N s/m) per wheelset and per bogie.
``equipment``
    ``[{name, mass, x, mount: rigid | elastic, f_mount_hz, zeta_mount}]``: underframe items
    at ``x`` (m from the carbody centre), bolted (rigid) or hung on elastic mounts (Fig. 3b
    of [002]).
``sensors``
    ``[{label, x}]``: floor vertical accelerometers, channel ``floor_<label>_z``.
``speed_kmh``
    Running speed.

Schema problems (missing key, wrong type, unknown mount) raise :class:`ConfigError`;
physical ones (a mass or stiffness that is not positive) :class:`ModelError`; both name
the file and the entry.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal

from modal_twin.errors import ConfigError, ModelError, OptionError
from modal_twin.yaml_files import read_yaml

__all__ = [
    "DEFAULT_VEHICLE_YAML",
    "MOUNTS",
    "EquipmentSpec",
    "SensorSpec",
    "VehicleSpec",
    "apply_theta",
    "equipment_mounted",
    "is_vehicle_file",
    "load_vehicle",
    "parameter_value",
    "theta_names",
]

DEFAULT_VEHICLE_YAML = (Path(__file__).resolve().parents[2] / "config" / "vehicles"
                        / "trailer_car.yaml")
"""The trailer car of [002] shipped with the package."""

MOUNTS: tuple[str, ...] = ("rigid", "elastic")
"""Equipment mount types (Fig. 3b of [002]: bolted or elastic hanging)."""

Mount = Literal["rigid", "elastic"]


@dataclass(frozen=True, slots=True)
class EquipmentSpec:
    """An underframe equipment item.

    Attributes
    ----------
    name : str
    mass : float
        kg.
    x : float
        Attachment position from the carbody centre, m (+ = front).
    mount : {"rigid", "elastic"}
    f_mount_hz : float
        Vertical mount frequency ``sqrt(k / m) / 2 pi`` when elastic, Hz.
    zeta_mount : float
        Mount damping ratio when elastic (``c = 2 zeta m 2 pi f``).
    u_h_mount : float
        Hardening of the mount: its spring force is ``k d (1 + (|d| / u_h)^(m - 1))`` for a
        drift ``d`` (the stiffening of rubber hangers); 0: linear (default), m.
    m_mount : float
        Exponent ``m`` of that hardening, in [2, 9].
    u_s_mount : float
        Softening of the mount: its spring force is ``k d`` for ``|d| <= u_s`` and
        ``r k d + (1 - r) k u_s sign(d)`` beyond (Eq. (9) of [004], a bilinear elastic
        spring with ``kb = r k``: rubber that softens, a hanger that slips into a softer
        stage); 0: no softening (default), m.
    r_mount : float
        Tangent stiffness beyond ``u_s`` over ``k``, in (0, 1].
    n_mount : float
        Sharpness of that softening's knee: 0 (default) the sharp bilinear spring above;
        else the Richard-Abbott curve ``r k d + (1 - r) k d / (1 + |d / u_s|^n)^(1/n)``
        with the same asymptotes (Eq. (1) of Richard & Abbott (1975), rubber that softens
        gradually; n in [0.5, 100], large n the bilinear one).
    """

    name: str
    mass: float
    x: float
    mount: Mount = "rigid"
    f_mount_hz: float = 10.0
    zeta_mount: float = 0.05
    u_h_mount: float = 0.0
    m_mount: float = 3.0
    u_s_mount: float = 0.0
    r_mount: float = 1.0
    n_mount: float = 0.0

    @property
    def k_mount(self) -> float:
        """Mount stiffness ``m (2 pi f)^2``, N/m."""
        return self.mass * (2.0 * math.pi * self.f_mount_hz) ** 2

    @property
    def c_mount(self) -> float:
        """Mount damping ``2 zeta m 2 pi f``, N s/m."""
        return 2.0 * self.zeta_mount * self.mass * 2.0 * math.pi * self.f_mount_hz


@dataclass(frozen=True, slots=True)
class SensorSpec:
    """A floor vertical accelerometer: ``label`` and position ``x`` (m from the centre)."""

    label: str
    x: float


@dataclass(frozen=True, slots=True)
class VehicleSpec:
    """Trailer car in the vertical plane (module docstring; SI units).

    Attributes
    ----------
    name : str
    length, pivot_spacing : float
        Carbody length and bogie pivot spacing, m.
    shell_line_mass, fittings_line_mass : float
        Distributed masses, kg/m.
    EI : float
        Vertical bending stiffness, N m^2.
    zeta_carbody : float
        Modal damping of the flexible carbody modes.
    n_elements : int
        Beam elements over the length (before nodes are inserted at special points).
    cutoff_hz : float
        Craig-Bampton cutoff.
    bogie_mass, bogie_pitch_inertia, wheelbase : float
        kg, kg m^2, m.
    k_primary, c_primary : float
        Per wheelset, N/m and N s/m.
    k_secondary, c_secondary : float
        Per bogie, N/m and N s/m.
    equipment : tuple of EquipmentSpec
    sensors : tuple of SensorSpec
    speed_kmh : float
    source : str
        File the spec came from (for messages).
    """

    name: str
    length: float
    pivot_spacing: float
    shell_line_mass: float
    fittings_line_mass: float
    EI: float
    zeta_carbody: float
    n_elements: int
    cutoff_hz: float
    bogie_mass: float
    bogie_pitch_inertia: float
    wheelbase: float
    k_primary: float
    c_primary: float
    k_secondary: float
    c_secondary: float
    equipment: tuple[EquipmentSpec, ...]
    sensors: tuple[SensorSpec, ...]
    speed_kmh: float = 300.0
    source: str = "<spec>"
    # per-bogie factors (front, rear) on the suspensions' k and c: one worn damper or a
    # sagging spring is a change at one bogie, not at the car
    bogie_factors: tuple[tuple[str, float, float], ...] = ()
    # (k, zeta_k): the damping ratio of the k-th flexible free-free carbody mode (1 = first
    # bending) where it is not ``zeta_carbody`` (theta ``zeta_cb_<k>``)
    zeta_modes: tuple[tuple[int, float], ...] = ()

    def zeta_mode(self, k: int) -> float:
        """Damping ratio of the ``k``-th flexible carbody mode (1-based)."""
        return next((z for j, z in self.zeta_modes if j == k), self.zeta_carbody)

    def suspension(self, name: str, bogie: int) -> float:
        """Value of ``k_primary`` / ``c_primary`` / ``k_secondary`` / ``c_secondary`` at a bogie.

        ``bogie`` 0 is the front one, 1 the rear one.
        """
        factor = next(((f[1] if bogie == 0 else f[2]) for f in self.bogie_factors
                       if f[0] == name), 1.0)
        return float(getattr(self, name)) * factor

    @property
    def carbody_mass(self) -> float:
        """Carbody in service: shell, fittings and every equipment item, kg."""
        return ((self.shell_line_mass + self.fittings_line_mass) * self.length
                + sum(e.mass for e in self.equipment))

    @property
    def total_mass(self) -> float:
        """Sprung and bogie mass: carbody in service plus two bogie frames, kg."""
        return self.carbody_mass + 2.0 * self.bogie_mass

    @property
    def speed(self) -> float:
        """Running speed, m/s."""
        return self.speed_kmh / 3.6

    @property
    def pivot_x(self) -> tuple[float, float]:
        """Bogie pivot positions (front, rear), m."""
        return 0.5 * self.pivot_spacing, -0.5 * self.pivot_spacing

    @property
    def axle_x(self) -> tuple[float, float, float, float]:
        """Wheelset positions 1 (leading) .. 4 (trailing), m from the carbody centre."""
        a = 0.5 * self.wheelbase
        f, r = self.pivot_x
        return f + a, f - a, r + a, r - a

    def equipment_named(self, name: str) -> EquipmentSpec:
        """Return the equipment item ``name``.

        Raises
        ------
        OptionError
            Unknown name (the message lists the known ones).
        """
        for e in self.equipment:
            if e.name == name:
                return e
        msg = f"equipment: expected one of {[e.name for e in self.equipment]}, got {name!r}"
        raise OptionError(msg)


def equipment_mounted(spec: VehicleSpec, name: str, f_hz: float, zeta: float, *,
                      u_h: float = 0.0, m: float = 3.0, u_s: float = 0.0,
                      r: float = 1.0, n: float = 0.0) -> VehicleSpec:
    """Return a copy of ``spec`` with equipment ``name`` on elastic mounts (f_hz, zeta).

    ``u_h > 0`` makes the mount harden, ``u_s > 0`` with ``r < 1`` soften, with a sharp
    knee (``n = 0``) or a rounded one of sharpness ``n`` (:class:`EquipmentSpec`); not
    both.

    The "elastic attachment" candidate of the diagnosis (Fig. 3b of [002]).

    Raises
    ------
    OptionError
        Unknown equipment name.
    ModelError
        ``f_hz`` not positive or ``zeta`` negative.
    """
    spec.equipment_named(name)
    if not (math.isfinite(f_hz) and f_hz > 0.0):
        msg = f"f_hz: expected a finite value > 0, got {f_hz!r}"
        raise ModelError(msg)
    if not (math.isfinite(zeta) and zeta >= 0.0):
        msg = f"zeta: expected a finite value >= 0, got {zeta!r}"
        raise ModelError(msg)
    if not (math.isfinite(u_h) and u_h >= 0.0 and 2.0 <= m <= 9.0):
        msg = f"u_h, m: expected u_h >= 0 m and m in [2, 9], got {u_h!r}, {m!r}"
        raise ModelError(msg)
    if not (math.isfinite(u_s) and u_s >= 0.0 and 0.0 < r <= 1.0) or (u_s > 0 and u_h > 0):
        msg = (f"u_s, r: expected u_s >= 0 m, r in (0, 1] and not both u_s and u_h, got "
               f"{u_s!r}, {r!r} (u_h {u_h!r})")
        raise ModelError(msg)
    if not (n == 0.0 or 0.5 <= n <= 100.0):
        msg = f"n: expected 0 (a sharp knee) or a sharpness in [0.5, 100], got {n!r}"
        raise ModelError(msg)
    eq = tuple(replace(e, mount="elastic", f_mount_hz=float(f_hz), zeta_mount=float(zeta),
                       u_h_mount=float(u_h), m_mount=float(m), u_s_mount=float(u_s),
                       r_mount=float(r), n_mount=float(n))
               if e.name == name else e for e in spec.equipment)
    return replace(spec, equipment=eq)


_SCALAR_THETA = {"EI_carbody": "EI", "zeta_carbody": "zeta_carbody",
                 "k_primary": "k_primary", "c_primary": "c_primary",
                 "k_secondary": "k_secondary", "c_secondary": "c_secondary"}
_SUSPENSIONS = ("k_primary", "c_primary", "k_secondary", "c_secondary")
BOGIES = ("front", "rear")
# the suspension of one bogie (N/m or N s/m): k_primary_front ... c_secondary_rear
_BOGIE_THETA = {f"{n}_{b}": (n, i) for n in _SUSPENSIONS for i, b in enumerate(BOGIES)}
N_CARBODY_MODES = 3
"""Flexible carbody modes with a damping ratio of their own (``zeta_cb_1`` .. ``_3``)."""
CARBODY_MODE_PREFIX = "zeta_cb_"
_MODE_THETA = {f"{CARBODY_MODE_PREFIX}{k}": k for k in range(1, N_CARBODY_MODES + 1)}


def theta_names(spec: VehicleSpec) -> tuple[str, ...]:
    """Parameter names :func:`apply_theta` accepts for ``spec``.

    ``EI_carbody``, ``zeta_carbody``, ``k_/c_primary``, ``k_/c_secondary``, the same per
    bogie (``c_secondary_front``, ``k_primary_rear`` ...), the damping ratio of each of the
    first :data:`N_CARBODY_MODES` flexible carbody modes (``zeta_cb_1`` = first vertical
    bending; default ``zeta_carbody``), and per equipment item
    ``m_<name>``; per elastic item also ``f_<name>`` (mount frequency, Hz)
    and ``zeta_<name>``.
    """
    names = [*_SCALAR_THETA, *_BOGIE_THETA, *_MODE_THETA]
    for e in spec.equipment:
        names.append(f"m_{e.name}")
        if e.mount == "elastic":
            names += [f"f_{e.name}", f"zeta_{e.name}"]
    return tuple(names)


def apply_theta(spec: VehicleSpec, theta: Mapping[str, float] | None) -> VehicleSpec:
    """Return ``spec`` with the parameter values ``theta`` (see :func:`theta_names`).

    Raises
    ------
    OptionError
        Unknown parameter name (the message lists the valid ones).
    ModelError
        A value that is not finite, or not positive (``zeta_*``: negative).
    """
    if not theta:
        return spec
    valid = theta_names(spec)
    bad = [k for k in theta if k not in valid]
    if bad:
        msg = f"theta: expected names from {list(valid)}, got {bad}"
        raise OptionError(msg)
    for key, val in theta.items():
        ok = math.isfinite(val) and (val >= 0.0 if key.startswith("zeta_") else val > 0.0)
        if not ok:
            msg = f"theta[{key!r}]: expected a finite value {'>=' if 'zeta' in key else '>'} 0, "
            msg += f"got {val!r}"
            raise ModelError(msg)
    changes: dict[str, Any] = {_SCALAR_THETA[k]: float(v) for k, v in theta.items()
                               if k in _SCALAR_THETA}
    eq = []
    for e in spec.equipment:
        upd: dict[str, Any] = {f: float(theta[f"{p}_{e.name}"]) for p, f in
               (("m", "mass"), ("f", "f_mount_hz"), ("zeta", "zeta_mount"))
               if f"{p}_{e.name}" in theta}
        eq.append(replace(e, **upd) if upd else e)
    out = replace(spec, equipment=tuple(eq), **changes)
    modes = {**dict(spec.zeta_modes),
             **{_MODE_THETA[k]: float(v) for k, v in theta.items() if k in _MODE_THETA}}
    if modes:
        out = replace(out, zeta_modes=tuple(sorted(modes.items())))
    return _with_bogie_values(out, {k: float(v) for k, v in theta.items() if k in _BOGIE_THETA})


def _with_bogie_values(spec: VehicleSpec, values: Mapping[str, float]) -> VehicleSpec:
    """Set per-bogie suspension values as factors on the car's value (after the car's)."""
    if not values:
        return spec
    factors = {f[0]: [f[1], f[2]] for f in spec.bogie_factors}
    for key, val in values.items():
        name, bogie = _BOGIE_THETA[key]
        factors.setdefault(name, [1.0, 1.0])[bogie] = val / float(getattr(spec, name))
    return replace(spec, bogie_factors=tuple((n, f[0], f[1]) for n, f in factors.items()))


# ---------------------------------------------------------------------------- loading
def _get(d: Mapping[str, Any], key: str, where: str, src: str) -> Any:
    if not isinstance(d, Mapping) or key not in d:
        msg = f"{src}: {where}.{key}: missing"
        raise ConfigError(msg)
    return d[key]


def _num(d: Mapping[str, Any], key: str, where: str, src: str, *, positive: bool = True,
         default: float | None = None) -> float:
    if default is not None and isinstance(d, Mapping) and key not in d:
        return float(default)
    v = _get(d, key, where, src)
    if isinstance(v, str):  # PyYAML (YAML 1.1) reads 2.0e6 without a sign as a string
        with contextlib.suppress(ValueError):
            v = float(v)
    if isinstance(v, bool) or not isinstance(v, int | float):
        msg = f"{src}: {where}.{key}: expected a number, got {v!r}"
        raise ConfigError(msg)
    if not math.isfinite(v) or (v <= 0.0 if positive else v < 0.0):
        msg = f"{src}: {where}.{key}: expected a finite value {'>' if positive else '>='} 0, "
        msg += f"got {v!r}"
        raise ModelError(msg)
    return float(v)


def _equipment(item: Any, i: int, src: str) -> EquipmentSpec:
    where = f"equipment[{i}]"
    if not isinstance(item, Mapping):
        msg = f"{src}: {where}: expected a mapping, got {item!r}"
        raise ConfigError(msg)
    name = str(_get(item, "name", where, src))
    where = f"equipment[{i}] ({name})"
    mount = item.get("mount", "rigid")
    if mount not in MOUNTS:
        msg = f"{src}: {where}.mount: expected one of {list(MOUNTS)}, got {mount!r}"
        raise ConfigError(msg)
    return EquipmentSpec(
        name=name, mass=_num(item, "mass", where, src),
        x=_position(_get(item, "x", where, src), where, src),
        mount=mount, f_mount_hz=_num(item, "f_mount_hz", where, src, default=10.0),
        zeta_mount=_num(item, "zeta_mount", where, src, positive=False, default=0.05))


def _position(v: Any, where: str, src: str) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        msg = f"{src}: {where}.x: expected a finite number, got {v!r}"
        raise ConfigError(msg)
    return float(v)


def is_vehicle_file(path: str | Path) -> bool:
    """Tell whether ``path`` is a vehicle file (it has a ``carbody`` section)."""
    doc = read_yaml(path, "model file")
    return isinstance(doc, Mapping) and "carbody" in doc


def parameter_value(spec: VehicleSpec, name: str) -> float:
    """Return the current value of the parameter ``name`` of :func:`theta_names`.

    Raises
    ------
    OptionError
        Unknown name.
    """
    if name in _SCALAR_THETA:
        return float(getattr(spec, _SCALAR_THETA[name]))
    if name in _BOGIE_THETA:
        return spec.suspension(*_BOGIE_THETA[name])
    if name in _MODE_THETA:
        return spec.zeta_mode(_MODE_THETA[name])
    prefix, _, item = name.partition("_")
    field_of = {"m": "mass", "f": "f_mount_hz", "zeta": "zeta_mount"}
    if prefix in field_of and name in theta_names(spec):
        return float(getattr(spec.equipment_named(item), field_of[prefix]))
    msg = f"parameter: expected one of {list(theta_names(spec))}, got {name!r}"
    raise OptionError(msg)


def load_vehicle(path: str | Path | None = None) -> VehicleSpec:
    """Read a vehicle file (default :data:`DEFAULT_VEHICLE_YAML`).

    Raises
    ------
    ConfigError
        Missing file or key, wrong type, unknown mount type, a position off the carbody.
    ModelError
        A mass, stiffness, damping or length that is not positive.
    """
    p = Path(DEFAULT_VEHICLE_YAML if path is None else path)
    doc = read_yaml(p, "vehicle file")
    src = str(p)
    cb = _get(doc, "carbody", "<top>", src)
    bg = _get(doc, "bogie", "<top>", src)
    pr = _get(doc, "primary", "<top>", src)
    se = _get(doc, "secondary", "<top>", src)
    n_el = _get(cb, "n_elements", "carbody", src)
    if isinstance(n_el, bool) or not isinstance(n_el, int) or n_el < 2:
        msg = f"{src}: carbody.n_elements: expected an int >= 2, got {n_el!r}"
        raise ConfigError(msg)
    eq_doc = doc.get("equipment", []) or []
    sn_doc = _get(doc, "sensors", "<top>", src)
    if not isinstance(eq_doc, list) or not isinstance(sn_doc, list) or not sn_doc:
        msg = f"{src}: equipment, sensors: expected lists (sensors non-empty), got "
        msg += f"{type(eq_doc).__name__}, {type(sn_doc).__name__}"
        raise ConfigError(msg)
    equipment = tuple(_equipment(e, i, src) for i, e in enumerate(eq_doc))
    names = [e.name for e in equipment]
    if len(set(names)) != len(names):
        msg = f"{src}: equipment: expected unique names, got {names}"
        raise ConfigError(msg)
    sensors = []
    for i, s in enumerate(sn_doc):
        where = f"sensors[{i}]"
        label = str(_get(s, "label", where, src))
        sensors.append(SensorSpec(label, _position(_get(s, "x", where, src), where, src)))
    spec = VehicleSpec(
        name=str(doc.get("name", p.stem)),
        length=_num(cb, "length", "carbody", src),
        pivot_spacing=_num(cb, "pivot_spacing", "carbody", src),
        shell_line_mass=_num(cb, "shell_line_mass", "carbody", src),
        fittings_line_mass=_num(cb, "fittings_line_mass", "carbody", src, positive=False),
        EI=_num(cb, "EI", "carbody", src), zeta_carbody=_num(cb, "zeta", "carbody", src,
                                                               positive=False),
        n_elements=int(n_el), cutoff_hz=_num(cb, "cutoff_hz", "carbody", src),
        bogie_mass=_num(bg, "mass", "bogie", src),
        bogie_pitch_inertia=_num(bg, "pitch_inertia", "bogie", src),
        wheelbase=_num(bg, "wheelbase", "bogie", src),
        k_primary=_num(pr, "k", "primary", src), c_primary=_num(pr, "c", "primary", src,
                                                                positive=False),
        k_secondary=_num(se, "k", "secondary", src),
        c_secondary=_num(se, "c", "secondary", src, positive=False),
        equipment=equipment, sensors=tuple(sensors),
        speed_kmh=_num(doc, "speed_kmh", "<top>", src, default=300.0), source=src)
    half = 0.5 * spec.length
    if spec.pivot_spacing >= spec.length:
        msg = (f"{src}: carbody.pivot_spacing: expected < length {spec.length}, got "
               f"{spec.pivot_spacing}")
        raise ConfigError(msg)
    for what, x in [(f"equipment {e.name}", e.x) for e in equipment] + [
            (f"sensor {s.label}", s.x) for s in sensors]:
        if abs(x) > half:
            msg = f"{src}: {what}.x: expected within +-{half} m of the centre, got {x}"
            raise ConfigError(msg)
    return spec
