"""Structure YAML -> :class:`~modal_twin.models.fe.FEModel` plus devices, sensors and damping.

A structure file (``config/structures/*.yaml``) lists, in SI units:

``materials``
    ``{name: {E, nu | G, param?}}``; ``param`` names the modulus as an updating parameter
    (``K = K0 + sum K_i (theta_i - theta_i0)``, Sec. 4 of [004]).
``sections``
    ``{name: {A, Iy, Iz, J, Asy?, Asz?}}`` in the frame's local axes (see
    :func:`modal_twin.models.fe.frame_rotation`: columns have local y = global X, so ``Iz``
    resists sway along X; horizontal beams have local y = global Z, so ``Iz`` is the
    vertical bending inertia). ``Asy`` / ``Asz`` given -> Timoshenko.
``nodes``
    ``{id: [x, y, z]}``.
``frames``
    ``[{n1, n2, material, section, via?: [ids], n_elements?}]``; ``via`` lists existing
    intermediate nodes (one element between consecutive nodes).
``masses``
    ``[{nodes: [ids] | node: id, m, inertia?: [Jxx, Jyy, Jzz]}]``; every listed node gets
    ``m`` (kg) and ``inertia`` (kg m^2).
``diaphragms``
    ``[{name, master, nodes: [ids]}]``: rigid floors (normal z); ``name`` labels the floor.
``supports``
    ``[{node, dofs: all | [names]}]``.
``devices``
    ``[{name, node, type, k: [kx, ky], c: [cx, cy], kz, params?}]``: a device is, in the
    nominal linear model, a grounded 6-DOF spring ``(kx, ky, kz)`` and dashpot ``(cx, cy)``
    at ``node`` (Eq. (1) of [004]); ``k`` and ``c`` become parameters ``k_<name>_x`` ...
    ``type`` names its nonlinear law (one of :data:`DEVICE_TYPES`) built from ``params``.
``sensors``
    ``[{name, node, directions?: [x, y, z]}]``: channel ``<name>_<dir>``.
``input``
    ``{origin: [x, y, z]}``: point about which the 6-DOF base input is given.
``damping``
    ``{n_isolation_modes, superstructure_zeta: [...], default_zeta}`` (see
    :mod:`modal_twin.models.building`).
``reduction``
    ``{n_modes}``.

Schema problems raise :class:`ConfigError`, physical ones (negative mass or stiffness, an
unknown node) :class:`ModelError`; both name the file and the entry.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.errors import ConfigError, ModelError
from modal_twin.models.devices import Device
from modal_twin.models.devices.registry import ALIASES, LAWS, Site, build_device, canonical_law
from modal_twin.models.fe import FEModel, NodeId
from modal_twin.yaml_files import read_yaml

__all__ = [
    "DEVICE_TYPES",
    "DampingSpec",
    "DeviceSpec",
    "FloorSpec",
    "SensorSpec",
    "StructureSpec",
    "load_structure",
    "make_device",
    "parse_structure",
]

DEVICE_TYPES: tuple[str, ...] = tuple(LAWS)
"""Device laws a structure file may name: the registry's canonical names
(:mod:`modal_twin.models.devices.registry`; its deprecated aliases are accepted too)."""

_TOP_KEYS = ("name", "description", "source", "gravity", "materials", "sections", "nodes",
             "frames", "masses", "diaphragms", "supports", "devices", "sensors", "input",
             "damping", "reduction")
_DIRS = ("x", "y", "z")


@dataclass(frozen=True, slots=True)
class DeviceSpec:
    """One isolation device: nominal linear spring-dashpot and its nonlinear law.

    Attributes
    ----------
    name : str
        Label (``RB1`` ...).
    node : NodeId
        Node the device supports (its other end is the table / ground).
    k : (2,) float array
        Nominal linear horizontal stiffness (x, y), N/m (Table 6 of [004]).
    c : (2,) float array
        Nominal linear viscous damping (x, y), N s/m.
    kz : float
        Vertical stiffness, N/m (0: the device carries no vertical load).
    type : str
        Nonlinear law, one of :data:`DEVICE_TYPES` (a parsed file's aliases are replaced by
        the canonical name).
    params : dict
        Keyword parameters of the law (SI).
    """

    name: str
    node: NodeId
    k: FloatArray
    c: FloatArray
    kz: float
    type: str
    params: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class SensorSpec:
    """An accelerometer at ``node`` measuring ``directions`` (channel ``<name>_<dir>``)."""

    name: str
    node: NodeId
    directions: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class FloorSpec:
    """A rigid floor: its label, master node and all its nodes (master first)."""

    name: str
    master: NodeId
    nodes: tuple[NodeId, ...]


@dataclass(frozen=True, slots=True)
class DampingSpec:
    """Added modal damping (see :func:`modal_twin.models.building.modal_reduction`).

    Attributes
    ----------
    n_isolation_modes : int
        Lowest modes that get no added damping (their damping comes from the devices).
    superstructure_zeta : tuple of float
        Target total damping ratio of the next modes, in order.
    default_zeta : float
        Target of every later mode.
    """

    n_isolation_modes: int = 0
    superstructure_zeta: tuple[float, ...] = ()
    default_zeta: float = 0.0


@dataclass(frozen=True, slots=True)
class StructureSpec:
    """A parsed structure file.

    Attributes
    ----------
    name, source : str
        Structure name and the file (or ``"<dict>"``) it came from.
    model : FEModel
        Builder holding every element, mass, diaphragm and device spring.
    devices, sensors, floors : tuples of specs
        In file order.
    input_origin : (3,) float array
        Reference point of the 6-DOF base input, m.
    damping : DampingSpec
    n_modes : int
        Default number of modes of the reduction.
    gravity : float
        m/s^2.
    yaml_mass : float
        Sum of all masses in the file, kg.
    """

    name: str
    source: str
    model: FEModel
    devices: tuple[DeviceSpec, ...]
    sensors: tuple[SensorSpec, ...]
    floors: tuple[FloorSpec, ...]
    input_origin: FloatArray
    damping: DampingSpec
    n_modes: int
    gravity: float
    yaml_mass: float


class _Ctx:
    """Error helper carrying the source label."""

    def __init__(self, source: str) -> None:
        self.source = source

    def config(self, *, at: str, what: str) -> ConfigError:
        return ConfigError(f"{self.source}: {at}: {what}")

    def model(self, *, at: str, what: str) -> ModelError:
        return ModelError(f"{self.source}: {at}: {what}")

    def get(self, entry: Mapping[str, Any], key: str, where: str) -> Any:
        if not isinstance(entry, Mapping):
            raise self.config(at=where, what=f"expected a mapping, got {type(entry).__name__}")
        if key not in entry:
            raise self.config(at=where, what=f"missing key {key!r} (keys: {sorted(entry)})")
        return entry[key]

    def number(self, value: Any, where: str, *, min_value: float | None = 0.0,
               strict: bool = False) -> float:
        if isinstance(value, str):  # PyYAML (YAML 1.1) reads 1.5e6 as a string
            try:
                value = float(value)
            except ValueError:
                raise self.config(at=where, what=f"expected a number, got {value!r}") from None
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.config(at=where, what=f"expected a number, got {value!r}")
        v = float(value)
        if not math.isfinite(v):
            raise self.model(at=where, what=f"expected a finite value, got {value!r}")
        if min_value is not None and (v < min_value or (strict and v == min_value)):
            op = ">" if strict else ">="
            raise self.model(at=where, what=f"expected {op} {min_value:g}, got {value!r}")
        return v

    def vector(self, value: Any, n: int, where: str) -> FloatArray:
        if not isinstance(value, Sequence) or isinstance(value, str) or len(value) != n:
            raise self.config(at=where, what=f"expected a list of {n} numbers, got {value!r}")
        return np.array([self.number(v, f"{where}[{i}]", min_value=None)
                         for i, v in enumerate(value)])

    def items(self, doc: Mapping[str, Any], key: str, *, required: bool = True) -> list[Any]:
        val = doc.get(key)
        if val is None:
            if required:
                raise self.config(at=key, what="missing section")
            return []
        if not isinstance(val, list):
            raise self.config(at=key, what=f"expected a list, got {type(val).__name__}")
        return val


def load_structure(path: str | Path) -> StructureSpec:
    """Read a structure YAML file and build its model (see the module docstring).

    Parameters
    ----------
    path : str or Path
        YAML file.

    Returns
    -------
    StructureSpec

    Raises
    ------
    ConfigError
        Unreadable file, bad YAML, a missing key, a value of the wrong type, an unknown
        device type (the message lists :data:`DEVICE_TYPES`).
    ModelError
        Negative mass or stiffness, an unknown node, an invalid element.
    """
    p = Path(path)
    doc = read_yaml(p, "structure file", mapping=False)  # parse_structure names a non-mapping
    return parse_structure(doc, source=str(p))


def parse_structure(doc: Any, *, source: str = "<dict>") -> StructureSpec:
    """Build a :class:`StructureSpec` from a parsed document (see :func:`load_structure`)."""
    cx = _Ctx(source)
    if not isinstance(doc, Mapping):
        raise cx.config(at="document",
                        what=f"expected a mapping at top level, got {type(doc).__name__}")
    unknown = sorted(set(doc) - set(_TOP_KEYS))
    if unknown:
        raise cx.config(at="document", what=f"unknown keys {unknown}; valid: {list(_TOP_KEYS)}")
    fem = FEModel()
    nodes = doc.get("nodes")
    if not isinstance(nodes, Mapping) or not nodes:
        raise cx.config(at="nodes", what="expected a non-empty mapping id -> [x, y, z]")
    for nid, xyz in nodes.items():
        fem.add_node(nid, cx.vector(xyz, 3, f"nodes[{nid!r}]"))
    materials = _materials(cx, doc)
    sections = _sections(cx, doc)
    _frames(cx, doc, fem, materials, sections)
    yaml_mass = _masses(cx, doc, fem)
    floors = _diaphragms(cx, doc, fem)
    for i, entry in enumerate(cx.items(doc, "supports", required=False)):
        where = f"supports[{i}]"
        dofs = entry.get("dofs", "all") if isinstance(entry, Mapping) else None
        _guard(cx, where, lambda e=entry, d=dofs, w=where: fem.fix(cx.get(e, "node", w), d))
    devices = _devices(cx, doc, fem)
    sensors = _sensors(cx, doc, fem)
    inp = doc.get("input") or {}
    origin = cx.vector(inp.get("origin", [0.0, 0.0, 0.0]), 3, "input.origin")
    damping = _damping(cx, doc.get("damping") or {})
    red = doc.get("reduction") or {}
    n_modes = red.get("n_modes", 36)
    if isinstance(n_modes, bool) or not isinstance(n_modes, int) or n_modes < 1:
        raise cx.config(at="reduction.n_modes", what=f"expected an int >= 1, got {n_modes!r}")
    gravity = cx.number(doc.get("gravity", 9.80665), "gravity", strict=True)
    return StructureSpec(
        name=str(doc.get("name", Path(source).stem)), source=source, model=fem,
        devices=devices, sensors=sensors, floors=floors, input_origin=origin,
        damping=damping, n_modes=n_modes, gravity=gravity, yaml_mass=yaml_mass)


def _guard(cx: _Ctx, where: str, call: Any) -> Any:
    """Run ``call`` and re-raise a builder ModelError with the entry's label."""
    try:
        return call()
    except ModelError as err:
        raise cx.model(at=where, what=str(err)) from err


def _materials(cx: _Ctx, doc: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    out: dict[str, dict[str, Any]] = {}
    mats = doc.get("materials")
    if not isinstance(mats, Mapping):
        raise cx.config(at="materials", what="expected a mapping name -> {E, nu | G, param?}")
    for name, m in mats.items():
        where = f"materials[{name!r}]"
        E = cx.number(cx.get(m, "E", where), f"{where}.E", strict=True)
        if "G" in m:
            G = cx.number(m["G"], f"{where}.G", strict=True)
        else:
            nu = cx.number(cx.get(m, "nu", where), f"{where}.nu", min_value=None)
            if not -1.0 < nu < 0.5:
                raise cx.model(at=f"{where}.nu", what=f"expected -1 < nu < 0.5, got {nu!r}")
            G = E / (2.0 * (1.0 + nu))
        rho = cx.number(m.get("rho", 0.0), f"{where}.rho")
        out[str(name)] = {"E": E, "G": G, "rho": rho, "E_param": m.get("param")}
    return out


def _sections(cx: _Ctx, doc: Mapping[str, Any]) -> dict[str, dict[str, float]]:
    out: dict[str, dict[str, float]] = {}
    secs = doc.get("sections")
    if not isinstance(secs, Mapping):
        raise cx.config(at="sections",
                        what="expected a mapping name -> {A, Iy, Iz, J, Asy?, Asz?}")
    for name, s in secs.items():
        where = f"sections[{name!r}]"
        d = {k: cx.number(cx.get(s, k, where), f"{where}.{k}", strict=True)
             for k in ("A", "Iy", "Iz", "J")}
        for k in ("Asy", "Asz"):
            if k in s:
                d[k] = cx.number(s[k], f"{where}.{k}", strict=True)
        out[str(name)] = d
    return out


def _frames(cx: _Ctx, doc: Mapping[str, Any], fem: FEModel,
            materials: dict[str, dict[str, Any]], sections: dict[str, dict[str, float]]) -> None:
    for i, f in enumerate(cx.items(doc, "frames")):
        where = f"frames[{i}]"
        n1, n2 = cx.get(f, "n1", where), cx.get(f, "n2", where)
        where = f"frames[{i}] ({n1!r}-{n2!r})"
        mat_name, sec_name = cx.get(f, "material", where), cx.get(f, "section", where)
        if mat_name not in materials:
            raise cx.config(at=f"{where}.material", what=
                            f"unknown material {mat_name!r}; defined: {sorted(materials)}")
        if sec_name not in sections:
            raise cx.config(at=f"{where}.section", what=
                            f"unknown section {sec_name!r}; defined: {sorted(sections)}")
        props: dict[str, Any] = {**materials[mat_name], **sections[sec_name]}
        via = f.get("via", [])
        n_el = f.get("n_elements", 1)
        if via and n_el != 1:
            raise cx.config(at=where, what="give either 'via' or 'n_elements', not both")
        chain = [n1, *via, n2]

        def add(chain: list[NodeId] = chain, n_el: int = n_el,
                props: dict[str, Any] = props) -> None:
            if len(chain) == 2:
                fem.add_member(chain[0], chain[1], n_el, **props)
            else:
                for a, b in itertools.pairwise(chain):
                    fem.add_frame(a, b, **props)

        _guard(cx, where, add)


def _masses(cx: _Ctx, doc: Mapping[str, Any], fem: FEModel) -> float:
    total = 0.0
    for i, entry in enumerate(cx.items(doc, "masses")):
        where = f"masses[{i}]"
        if isinstance(entry, Mapping) and "node" in entry:
            targets = [entry["node"]]
        else:
            targets = cx.get(entry, "nodes", where)
            if not isinstance(targets, list) or not targets:
                raise cx.config(at=f"{where}.nodes",
                                what=f"expected a non-empty list, got {targets!r}")
        m = cx.number(cx.get(entry, "m", where), f"{where}.m (nodes {targets})")
        inertia = entry.get("inertia")
        if inertia is not None:
            inertia = cx.vector(inertia, 3, f"{where}.inertia")
            if np.any(inertia < 0.0):
                raise cx.model(at=f"{where}.inertia",
                               what=f"expected values >= 0, got {list(inertia)}")
        param = entry.get("param")  # a mass parameter (e.g. added mass on a floor)
        if param is not None and (not isinstance(param, str) or len(targets) != 1):
            raise cx.config(at=f"{where}.param",
                            what="expected a name, on an entry with one node")
        for nid in targets:
            _guard(cx, f"{where} (node {nid!r})",
                   lambda n=nid, m=m, j=inertia, q=param: fem.add_mass(n, m, inertia=j,
                                                                       m_param=q))
            total += m
    return total


def _diaphragms(cx: _Ctx, doc: Mapping[str, Any], fem: FEModel) -> tuple[FloorSpec, ...]:
    floors = []
    for i, d in enumerate(cx.items(doc, "diaphragms", required=False)):
        where = f"diaphragms[{i}]"
        master = cx.get(d, "master", where)
        slaves = [n for n in cx.get(d, "nodes", where) if n != master]
        name = str(d.get("name", master))
        _guard(cx, f"{where} ({name})",
               lambda m=master, s=slaves: fem.add_rigid_diaphragm(m, s))
        floors.append(FloorSpec(name=name, master=master, nodes=(master, *slaves)))
    return tuple(floors)


def _devices(cx: _Ctx, doc: Mapping[str, Any], fem: FEModel) -> tuple[DeviceSpec, ...]:
    out: list[DeviceSpec] = []
    for i, d in enumerate(cx.items(doc, "devices", required=False)):
        where = f"devices[{i}]"
        name = str(cx.get(d, "name", where))
        where = f"devices[{i}] ({name})"
        node = cx.get(d, "node", where)
        dtype = cx.get(d, "type", where)
        if dtype not in DEVICE_TYPES and dtype not in ALIASES:
            raise cx.config(at=f"{where}.type", what=
                            f"unknown device type {dtype!r}; valid: {list(DEVICE_TYPES)}")
        k = cx.vector(cx.get(d, "k", where), 2, f"{where}.k")
        c = cx.vector(d.get("c", [0.0, 0.0]), 2, f"{where}.c")
        for lab, arr in (("k", k), ("c", c)):
            if np.any(arr < 0.0):
                raise cx.model(at=f"{where}.{lab}", what=f"expected values >= 0, got {list(arr)}")
        kz = cx.number(d.get("kz", 0.0), f"{where}.kz")
        params = d.get("params") or {}
        if not isinstance(params, Mapping):
            raise cx.config(at=f"{where}.params", what=f"expected a mapping, got {params!r}")
        if any(x.name == name for x in out):
            raise cx.config(at=where, what=f"duplicate device name {name!r}")
        # Eq. (1) of [004]: nominal linear k-c spring per horizontal direction.
        _guard(cx, where, lambda n=node, k=k, c=c, kz=kz, nm=name: fem.add_spring(
            n, None, k={"ux": k[0], "uy": k[1], "uz": kz}, c={"ux": c[0], "uy": c[1]},
            k_params={"ux": f"k_{nm}_x", "uy": f"k_{nm}_y"},
            c_params={"ux": f"c_{nm}_x", "uy": f"c_{nm}_y"}))
        spec = DeviceSpec(name=name, node=node, k=k, c=c, kz=kz, type=canonical_law(dtype),
                          params=dict(params))
        try:
            make_device(spec, weight=1.0)  # validate the law's parameters now
        except KeyError as err:
            raise cx.config(at=f"{where}.params", what=f"missing law parameter {err}") from err
        except TypeError as err:
            raise cx.config(at=f"{where}.params", what=f"unexpected law parameter: {err}") from err
        except ModelError as err:
            raise cx.model(at=f"{where}.params", what=str(err)) from err
        out.append(spec)
    return tuple(out)


def _sensors(cx: _Ctx, doc: Mapping[str, Any], fem: FEModel) -> tuple[SensorSpec, ...]:
    out = []
    for i, s in enumerate(cx.items(doc, "sensors", required=False)):
        where = f"sensors[{i}]"
        name, node = str(cx.get(s, "name", where)), cx.get(s, "node", where)
        _guard(cx, f"{where} ({name})", lambda n=node: fem.xyz(n))
        dirs = tuple(s.get("directions", _DIRS))
        bad = [d for d in dirs if d not in _DIRS]
        if bad:
            raise cx.config(at=f"{where}.directions",
                            what=f"expected some of {list(_DIRS)}, got {bad}")
        out.append(SensorSpec(name=name, node=node, directions=dirs))
    return tuple(out)


def _damping(cx: _Ctx, d: Mapping[str, Any]) -> DampingSpec:
    if not isinstance(d, Mapping):
        raise cx.config(at="damping", what=f"expected a mapping, got {d!r}")
    n_iso = d.get("n_isolation_modes", 0)
    if isinstance(n_iso, bool) or not isinstance(n_iso, int) or n_iso < 0:
        raise cx.config(at="damping.n_isolation_modes",
                        what=f"expected an int >= 0, got {n_iso!r}")
    zs = d.get("superstructure_zeta", [])
    if not isinstance(zs, list):
        raise cx.config(at="damping.superstructure_zeta", what=f"expected a list, got {zs!r}")
    zeta = tuple(cx.number(z, f"damping.superstructure_zeta[{i}]") for i, z in enumerate(zs))
    default = cx.number(d.get("default_zeta", 0.0), "damping.default_zeta")
    if max((*zeta, default)) >= 1.0:
        raise cx.model(at="damping", what=f"expected damping ratios < 1, got {[*zeta, default]}")
    return DampingSpec(n_isolation_modes=n_iso, superstructure_zeta=zeta, default_zeta=default)


def make_device(spec: DeviceSpec, *, weight: float | None = None) -> Device:
    """Build the nonlinear law of a device from its spec.

    Parameters
    ----------
    spec : DeviceSpec
        Device; ``spec.type`` a law of the registry
        (:mod:`modal_twin.models.devices.registry`, aliases accepted with a deprecation
        note) and ``spec.params`` its absolute parameters. A ``linear`` law defaults to the
        nominal ``k`` and ``c``; ``c`` of every law defaults to the nominal ``c``.
    weight : float, optional
        Vertical load on the device, N: used by ``bouc_wen_esb`` when ``params.W`` is absent
        or ``"auto"`` (Eq. (11a) of [004] needs the weight carried).

    Returns
    -------
    Device
        A bidirectional law named ``spec.name`` (``prandtl``: uniaxial, x).

    Raises
    ------
    ConfigError
        Unknown type (lists :data:`DEVICE_TYPES`) or an ESB without a weight.
    ModelError
        Parameters the law refuses.
    """
    if spec.type not in DEVICE_TYPES and spec.type not in ALIASES:
        msg = f"device {spec.name}: unknown type {spec.type!r}; valid: {list(DEVICE_TYPES)}"
        raise ConfigError(msg)
    return build_device(spec.type, spec.params, Site(spec.name, spec.k, spec.c, weight))
