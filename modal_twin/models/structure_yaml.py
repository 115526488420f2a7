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
    ``[{nodes: [ids] | node: id, m, inertia?: [Jxx, Jyy, Jzz], param?}]``; every listed node
    gets ``m`` (kg) and ``inertia`` (kg m^2). A body at an eccentric position:
    ``{m, at: id | [x, y, z], offset?: [dx, dy, dz], J?: [Jx, Jy, Jz], floor?, param?}`` is
    rigidly attached to node ``at`` (at ``offset`` from it), or, for a position, to the
    nearest node (of diaphragm ``floor`` if given); its 6x6 block
    ``m [[I, -S(r)], [S(r), J/m - S(r)^2]]`` is linear in ``m`` (one parameter ``param``
    scales translation, eccentricity and rotary inertia: :meth:`FEModel.add_point_mass`).
``links``
    ``[{name?, n1, n2?, k?: [kx, ky, kz], c?: [cx, cy, cz], kr?: [krx, kry, krz], cr?: [...],
    param?, c_param?}]``: a zero-length spring and dashpot between any two nodes, or from
    ``n1`` to ground when ``n2`` is omitted (storey springs of a rigid-diaphragm model).
    ``param`` (``c_param``) names a dimensionless factor, nominal 1, on the link's whole
    stiffness (damping): ``K(theta) = K0 + k_link (theta - 1)`` (Sec. 4 of [004]).
``groups``
    ``[{name, place?, nodes?: [ids or globs], between?: [floor, floor], sections?: [...],
    frames?: [entry numbers], links?: [names]}]``: a dimensionless stiffness factor (nominal
    1) of a set of frame entries and links: those with both end nodes matching ``nodes``
    (``fnmatch`` patterns, e.g. ``"*_1A"`` for a column line), with one end on each floor of
    ``between`` (a storey), optionally only of ``sections``; plus the listed ones.
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
    ``{n_isolation_modes, superstructure_zeta: [...], default_zeta, param?, mode_groups?,
    rayleigh?}`` (see :mod:`modal_twin.models.building`): added modal damping targets;
    ``param`` names a factor (nominal 1) on every target; ``mode_groups: [{name, modes:
    [first, last]}]`` (1-based) a factor on the targets of those modes; ``rayleigh: {alpha,
    beta} | {f_hz: [f1, f2], zeta: [z1, z2]}`` with ``alpha_param?`` / ``beta_param?`` adds
    ``alpha M + beta K`` (``zeta(w) = alpha / (2 w) + beta w / 2``).
``reduction``
    ``{n_modes}``.

Schema problems raise :class:`ConfigError`, physical ones (negative mass or stiffness, an
unknown node) :class:`ModelError`; both name the file and the entry.
"""

from __future__ import annotations

import fnmatch
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
    "GroupSpec",
    "LinkSpec",
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
             "damping", "reduction", "links", "groups")
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
class LinkSpec:
    """A spring-dashpot between two nodes (``n2 = None``: to ground), global axes.

    ``k``, ``c`` are (6,) diagonals on ``ux .. rz`` (N/m, N m/rad; N s/m, N m s/rad);
    ``param`` / ``c_param`` name dimensionless factors (nominal 1) on them.
    """

    name: str
    n1: NodeId
    n2: NodeId | None
    k: FloatArray
    c: FloatArray
    param: str | None = None
    c_param: str | None = None


@dataclass(frozen=True, slots=True)
class GroupSpec:
    """A named stiffness factor (nominal 1) of a set of elements.

    Attributes
    ----------
    name : str
        Parameter name (e.g. ``kcol_1A``, ``kst_1``).
    place : str
        Where it acts, for reports (``column line 1A``).
    frames : tuple of int
        Frame entries (0-based, file order) in the group.
    links : tuple of str
        Link names in the group.
    """

    name: str
    place: str
    frames: tuple[int, ...]
    links: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class DampingSpec:
    """Added modal and Rayleigh damping (see :func:`modal_twin.models.building.modal_reduction`).

    Attributes
    ----------
    n_isolation_modes : int
        Lowest modes that get no added damping (their damping comes from the devices).
    superstructure_zeta : tuple of float
        Target total damping ratio of the next modes, in order.
    default_zeta : float
        Target of every later mode.
    param : str or None
        Name of a factor (nominal 1) on every target (e.g. ``zeta_sup``).
    mode_groups : tuple of (name, first, last)
        Factors (nominal 1) on the targets of modes ``first .. last`` (1-based, inclusive).
    rayleigh_alpha, rayleigh_beta : float
        ``C += alpha M + beta K`` (1/s, s).
    alpha_param, beta_param : str or None
        Their parameter names.
    """

    n_isolation_modes: int = 0
    superstructure_zeta: tuple[float, ...] = ()
    default_zeta: float = 0.0
    param: str | None = None
    mode_groups: tuple[tuple[str, int, int], ...] = ()
    rayleigh_alpha: float = 0.0
    rayleigh_beta: float = 0.0
    alpha_param: str | None = None
    beta_param: str | None = None

    def parameters(self) -> dict[str, float]:
        """Nominal value of every damping parameter this spec names."""
        out = {name: 1.0 for name, _, _ in self.mode_groups}
        if self.param:
            out[self.param] = 1.0
        if self.alpha_param:
            out[self.alpha_param] = self.rayleigh_alpha
        if self.beta_param:
            out[self.beta_param] = self.rayleigh_beta
        return out


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
    links, groups : tuples of specs
        In file order.
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
    links: tuple[LinkSpec, ...] = ()
    groups: tuple[GroupSpec, ...] = ()


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
    entries = _frames(cx, doc, fem, materials, sections)
    floors = _floors(cx, doc)
    yaml_mass = _masses(cx, doc, fem, floors)
    _diaphragms(cx, doc, fem, floors)
    links = _links(cx, doc, fem)
    groups = _groups(cx, doc, fem, entries, links, floors)
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
        damping=damping, n_modes=n_modes, gravity=gravity, yaml_mass=yaml_mass,
        links=links[0], groups=groups)


def _guard(cx: _Ctx, where: str, call: Any) -> Any:
    """Run ``call`` and re-raise a builder ModelError with the entry's label."""
    try:
        return call()
    except ModelError as err:
        raise cx.model(at=where, what=str(err)) from err


def _materials(cx: _Ctx, doc: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    out: dict[str, dict[str, Any]] = {}
    mats = doc.get("materials", {} if "links" in doc else None)
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
    secs = doc.get("sections", {} if "links" in doc else None)
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


@dataclass(frozen=True, slots=True)
class _FrameEntry:
    """A frame entry of the file: its end nodes, section and frame numbers."""

    n1: NodeId
    n2: NodeId
    section: str
    numbers: range


def _frames(cx: _Ctx, doc: Mapping[str, Any], fem: FEModel,
            materials: dict[str, dict[str, Any]], sections: dict[str, dict[str, float]]
            ) -> list[_FrameEntry]:
    entries = []
    # a model of links and masses needs no frames (nor materials and sections)
    for i, f in enumerate(cx.items(doc, "frames", required="links" not in doc)):
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

        first = fem.n_frames
        _guard(cx, where, add)
        entries.append(_FrameEntry(n1, n2, str(sec_name), range(first, fem.n_frames)))
    return entries


def _masses(cx: _Ctx, doc: Mapping[str, Any], fem: FEModel,
            floors: tuple[FloorSpec, ...]) -> float:
    total = 0.0
    for i, entry in enumerate(cx.items(doc, "masses")):
        where = f"masses[{i}]"
        if isinstance(entry, Mapping) and "at" in entry:
            total += _point_mass(cx, entry, where, fem, floors)
            continue
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


def _point_mass(cx: _Ctx, entry: Mapping[str, Any], where: str, fem: FEModel,
                floors: tuple[FloorSpec, ...]) -> float:
    """One body at an eccentric position (module docstring, ``masses`` with ``at``)."""
    extra = sorted(set(entry) & {"node", "nodes", "inertia"})
    if extra:
        raise cx.config(at=where, what=f"'at' excludes {extra} (use 'offset' and 'J')")
    at = entry["at"]
    m = cx.number(cx.get(entry, "m", where), f"{where}.m", strict=True)
    offset = cx.vector(entry.get("offset", [0.0, 0.0, 0.0]), 3, f"{where}.offset")
    J = cx.vector(entry.get("J", [0.0, 0.0, 0.0]), 3, f"{where}.J")
    if np.any(J < 0.0):
        raise cx.model(at=f"{where}.J", what=f"expected values >= 0, got {list(J)}")
    param = entry.get("param")
    if param is not None and not isinstance(param, str):
        raise cx.config(at=f"{where}.param", what=f"expected a name, got {param!r}")
    if isinstance(at, Sequence) and not isinstance(at, str):
        xyz = cx.vector(at, 3, f"{where}.at")
        floor = entry.get("floor")
        pool: Sequence[NodeId] = fem.nodes
        if floor is not None:
            hits = [f for f in floors if f.name == floor]
            if not hits:
                raise cx.config(at=f"{where}.floor", what=
                                f"unknown floor {floor!r}; floors: {[f.name for f in floors]}")
            pool = hits[0].nodes
        dist = [float(np.linalg.norm(fem.xyz(n) - xyz)) for n in pool]
        node = pool[int(np.argmin(dist))]
        offset = offset + xyz - fem.xyz(node)
    else:
        node = at
    _guard(cx, f"{where} (at {node!r})", lambda: fem.add_point_mass(
        node, m, offset=[float(x) for x in offset], J=J, m_param=param))
    return m


def _floors(cx: _Ctx, doc: Mapping[str, Any]) -> tuple[FloorSpec, ...]:
    floors = []
    for i, d in enumerate(cx.items(doc, "diaphragms", required=False)):
        where = f"diaphragms[{i}]"
        master = cx.get(d, "master", where)
        nodes = cx.get(d, "nodes", where)
        if not isinstance(nodes, list):
            raise cx.config(at=f"{where}.nodes", what=f"expected a list, got {nodes!r}")
        slaves = [n for n in nodes if n != master]
        floors.append(FloorSpec(name=str(d.get("name", master)), master=master,
                                nodes=(master, *slaves)))
    names = [f.name for f in floors]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise cx.config(at="diaphragms", what=f"duplicate floor names {dup}")
    return tuple(floors)


def _diaphragms(cx: _Ctx, doc: Mapping[str, Any], fem: FEModel,
                floors: tuple[FloorSpec, ...]) -> None:
    for i, f in enumerate(floors):
        _guard(cx, f"diaphragms[{i}] ({f.name})",
               lambda f=f: fem.add_rigid_diaphragm(f.master, f.nodes[1:]))


def _dof_diagonal(cx: _Ctx, entry: Mapping[str, Any], lin: str, rot: str, where: str
                  ) -> FloatArray:
    """(6,) diagonal from ``lin: [x, y, z]`` and ``rot: [rx, ry, rz]`` (both >= 0)."""
    out = np.zeros(6)
    for key, sl in ((lin, slice(0, 3)), (rot, slice(3, 6))):
        if key in entry:
            v = cx.vector(entry[key], 3, f"{where}.{key}")
            if np.any(v < 0.0):
                raise cx.model(at=f"{where}.{key}", what=f"expected values >= 0, got {list(v)}")
            out[sl] = v
    return out


def _links(cx: _Ctx, doc: Mapping[str, Any], fem: FEModel
           ) -> tuple[tuple[LinkSpec, ...], dict[str, int]]:
    out: list[LinkSpec] = []
    numbers: dict[str, int] = {}
    for i, e in enumerate(cx.items(doc, "links", required=False)):
        where = f"links[{i}]"
        n1 = cx.get(e, "n1", where)
        n2 = e.get("n2")
        name = str(e.get("name", f"link{i}"))
        where = f"links[{i}] ({name}: {n1!r}-{n2!r})"
        bad = sorted(set(e) - {"name", "n1", "n2", "k", "c", "kr", "cr", "param", "c_param"})
        if bad:
            raise cx.config(at=where, what=f"unknown keys {bad}; valid: name, n1, n2, k, c, "
                            "kr, cr, param, c_param")
        if n2 is not None and n2 == n1:
            raise cx.model(at=where, what=f"expected two distinct nodes, got {n1!r} twice "
                           "(omit n2 for a link to ground)")
        if any(x.name == name for x in out):
            raise cx.config(at=where, what=f"duplicate link name {name!r}")
        k = _dof_diagonal(cx, e, "k", "kr", where)
        c = _dof_diagonal(cx, e, "c", "cr", where)
        if not (np.any(k > 0.0) or np.any(c > 0.0)):
            raise cx.model(at=where, what="expected some stiffness (k, kr) or damping (c, cr) "
                           "> 0, got none")
        param, c_param = e.get("param"), e.get("c_param")
        for key, val, arr in (("param", param, k), ("c_param", c_param, c)):
            if val is not None and (not isinstance(val, str) or not np.any(arr > 0.0)):
                raise cx.config(at=f"{where}.{key}", what=
                                f"expected a name on a link with {key[:1]} > 0, got {val!r}")
        number = _guard(cx, where, lambda n1=n1, n2=n2, k=k, c=c, p=param, q=c_param:
                        fem.add_spring(n1, n2, k=k if np.any(k > 0.0) else None,
                                       c=c if np.any(c > 0.0) else None, k_scale=p, c_scale=q))
        out.append(LinkSpec(name, n1, n2, k, c, param, c_param))
        numbers[name] = number
    return tuple(out), numbers


_GROUP_KEYS = ("name", "place", "nodes", "between", "sections", "frames", "links")


def _groups(cx: _Ctx, doc: Mapping[str, Any], fem: FEModel, entries: list[_FrameEntry],
            links: tuple[tuple[LinkSpec, ...], dict[str, int]],
            floors: tuple[FloorSpec, ...]) -> tuple[GroupSpec, ...]:
    """Element-group stiffness factors (module docstring, ``groups``)."""
    out: list[GroupSpec] = []
    specs, numbers = links
    ends = [(e.n1, e.n2, e.section) for e in entries]
    ends_links = [(x.n1, x.n2, None) for x in specs]
    for i, g in enumerate(cx.items(doc, "groups", required=False)):
        where = f"groups[{i}]"
        name = cx.get(g, "name", where)
        where = f"groups[{i}] ({name})"
        if not isinstance(name, str) or not name:
            raise cx.config(at=where, what=f"expected a non-empty name, got {name!r}")
        bad = sorted(set(g) - set(_GROUP_KEYS))
        if bad:
            raise cx.config(at=where, what=f"unknown keys {bad}; valid: {list(_GROUP_KEYS)}")
        if any(x.name == name for x in out):
            raise cx.config(at=where, what=f"duplicate group name {name!r}")
        match = _group_selector(cx, g, where, floors)
        frames = sorted({j for j, e in enumerate(ends) if match(*e)}
                        | set(_listed(cx, g, "frames", where, range(len(entries)))))
        names = [x.name for x in specs]
        lk = sorted({names[j] for j, e in enumerate(ends_links) if match(*e)}
                    | set(_listed(cx, g, "links", where, names)), key=names.index)
        if not frames and not lk:
            raise cx.model(at=where, what="expected at least one frame or link, got none "
                           "(check nodes / between / sections)")
        fr = [n for j in frames for n in entries[j].numbers]
        _guard(cx, where, lambda n=name, fr=fr, lk=lk: fem.add_stiffness_group(
            n, frames=fr, springs=[numbers[x] for x in lk]))
        out.append(GroupSpec(name, str(g.get("place", name)), tuple(frames), tuple(lk)))
    return tuple(out)


def _listed(cx: _Ctx, g: Mapping[str, Any], key: str, where: str, valid: Sequence[Any]
            ) -> list[Any]:
    val = g.get(key, [])
    if not isinstance(val, list):
        raise cx.config(at=f"{where}.{key}", what=f"expected a list, got {val!r}")
    bad = [v for v in val if v not in valid]
    if bad:
        raise cx.config(at=f"{where}.{key}", what=f"unknown entries {bad}")
    return val


def _group_selector(cx: _Ctx, g: Mapping[str, Any], where: str,
                    floors: tuple[FloorSpec, ...]) -> Any:
    """Return ``match(n1, n2.

    Section) -> bool`` of a group's ``nodes`` / ``between`` / ``sections`` (an element matches
    every selector given; none given: nothing matches).
    """
    pats = g.get("nodes")
    between = g.get("between")
    sections = g.get("sections")
    if pats is not None and (not isinstance(pats, list) or not pats):
        raise cx.config(at=f"{where}.nodes", what=f"expected a list of ids or globs, got {pats!r}")
    sets: list[frozenset[NodeId]] = []
    if between is not None:
        fl = {f.name: f for f in floors}
        if not isinstance(between, list) or len(between) != 2 or any(b not in fl for b in between):
            raise cx.config(at=f"{where}.between", what=f"expected two floor names from "
                            f"{list(fl)}, got {between!r}")
        sets = [frozenset(fl[b].nodes) for b in between]
    if sections is not None and not isinstance(sections, list):
        raise cx.config(at=f"{where}.sections", what=f"expected a list, got {sections!r}")

    def node_ok(n: NodeId | None) -> bool:
        return n is not None and any(fnmatch.fnmatchcase(str(n), str(p)) for p in pats or ())

    def match(n1: NodeId, n2: NodeId | None, section: str | None) -> bool:
        if pats is None and between is None:
            return False
        if pats is not None and not (node_ok(n1) and node_ok(n2)):
            return False
        if sets and not ((n1 in sets[0] and n2 in sets[1]) or (n1 in sets[1] and n2 in sets[0])):
            return False
        return sections is None or section in sections

    return match


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
    bad = sorted(set(d) - set(_DAMPING_KEYS))
    if bad:
        raise cx.config(at="damping", what=f"unknown keys {bad}; valid: {list(_DAMPING_KEYS)}")
    param = _name(cx, d.get("param"), "damping.param")
    groups = []
    for i, g in enumerate(d.get("mode_groups") or []):
        where = f"damping.mode_groups[{i}]"
        modes = cx.get(g, "modes", where)
        ok = (isinstance(modes, list) and len(modes) == 2
              and all(isinstance(v, int) and not isinstance(v, bool) for v in modes)
              and 1 <= modes[0] <= modes[1])
        if not ok:
            raise cx.config(at=f"{where}.modes",
                            what=f"expected [first, last] with 1 <= first <= last, got {modes!r}")
        groups.append((_name(cx, cx.get(g, "name", where), f"{where}.name"), *modes))
    alpha, beta, a_param, b_param = _rayleigh(cx, d.get("rayleigh"))
    names = [n for n in (param, a_param, b_param, *(g[0] for g in groups)) if n]
    if len(set(names)) != len(names):
        raise cx.config(at="damping", what=f"expected distinct parameter names, got {names}")
    return DampingSpec(n_isolation_modes=n_iso, superstructure_zeta=zeta, default_zeta=default,
                       param=param, mode_groups=tuple(groups), rayleigh_alpha=alpha,
                       rayleigh_beta=beta, alpha_param=a_param, beta_param=b_param)


_DAMPING_KEYS = ("n_isolation_modes", "superstructure_zeta", "default_zeta", "param",
                 "mode_groups", "rayleigh")


def _name(cx: _Ctx, val: Any, where: str) -> str | None:
    if val is not None and (not isinstance(val, str) or not val):
        raise cx.config(at=where, what=f"expected a parameter name, got {val!r}")
    return val


def _rayleigh(cx: _Ctx, r: Any) -> tuple[float, float, str | None, str | None]:
    """Rayleigh ``(alpha, beta)`` from the coefficients or from two frequencies' ratios.

    ``zeta(w) = alpha / (2 w) + beta w / 2`` through ``(w1, z1)`` and ``(w2, z2)``:
    ``beta = 2 (z2 w2 - z1 w1) / (w2^2 - w1^2)``, ``alpha = 2 w1 w2 (z1 w2 - z2 w1) /
    (w2^2 - w1^2)`` (Chopra, *Dynamics of Structures*, Eq. 11.4.9).
    """
    if r is None:
        return 0.0, 0.0, None, None
    w = "damping.rayleigh"
    if not isinstance(r, Mapping):
        raise cx.config(at=w, what=f"expected a mapping, got {r!r}")
    bad = sorted(set(r) - {"alpha", "beta", "f_hz", "zeta", "alpha_param", "beta_param"})
    if bad or (("f_hz" in r) == ("alpha" in r or "beta" in r)):
        raise cx.config(at=w, what=f"expected {{alpha, beta}} or {{f_hz: [f1, f2], zeta: [z1, "
                        f"z2]}} (with alpha_param / beta_param), got keys {sorted(r)}")
    if "f_hz" in r:
        f = cx.vector(r["f_hz"], 2, f"{w}.f_hz")
        z = cx.vector(cx.get(r, "zeta", w), 2, f"{w}.zeta")
        if not (0.0 < f[0] < f[1]) or np.any(z < 0.0) or np.any(z >= 1.0):
            raise cx.model(at=w, what=f"expected 0 < f1 < f2 and 0 <= zeta < 1, got f_hz "
                           f"{list(f)}, zeta {list(z)}")
        w1, w2 = 2.0 * np.pi * f
        beta = 2.0 * (z[1] * w2 - z[0] * w1) / (w2**2 - w1**2)
        alpha = 2.0 * w1 * w2 * (z[0] * w2 - z[1] * w1) / (w2**2 - w1**2)
        if alpha < 0.0 or beta < 0.0:
            raise cx.model(at=w, what=f"these ratios need a negative coefficient (alpha "
                           f"{alpha:.4g}, beta {beta:.4g}); choose others")
    else:
        alpha = cx.number(r.get("alpha", 0.0), f"{w}.alpha")
        beta = cx.number(r.get("beta", 0.0), f"{w}.beta")
    return (float(alpha), float(beta), _name(cx, r.get("alpha_param"), f"{w}.alpha_param"),
            _name(cx, r.get("beta_param"), f"{w}.beta_param"))


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
