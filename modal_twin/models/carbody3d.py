"""Parametric 3D shell carbody of a high-speed trailer car ([002] Sec. 2, Table 1).

The carbody is a closed box of flat shells (:mod:`modal_twin.models.fe.shell`): length
``L`` (25 m), width ``W``, height ``H``, the underframe at ``z = 0``, the roof at ``z = H``,
two side walls at ``y = +-W/2`` and two end walls at ``x = +-L/2``. Each shell belongs to a
**zone** with its own ``E``, ``nu``, ``rho``, membrane and bending-equivalent thickness and
non-structural mass per area: the four zones of [002] Table 1 (underframe, side wall, roof,
end wall) plus the window belt and the door openings of the side walls. Every zone is an
*equivalent isotropic plate* (not orthotropic): ``t`` carries the membrane stiffness and the
structural mass, ``t_b`` the bending stiffness of the hollow double-skin extrusion. Zone
``E`` and ``rho`` are named parameters of the model (``E_<zone>``, ``rho_<zone>``), exact
linear ones (the carbody updating of [002] Sec. 4 acts on them).

In service the car carries what [002] Sec. 2 lists: the interior and fittings (seats,
panels, windows, cables, ducts) as non-structural mass per area of the zones, and the
equipment as rigid bodies (mass and inertia) hung from the underframe's side beams or
set on the roof by four hangers each, elastic (spring-damper mounts, a vertical mount
frequency) or rigid (bolted: stiff springs). Bolsters are frame beams across the floor at
the pivots (``x = +-s/2``, ``s`` = 17.8 m); their air-spring seats (``y = +-b``) and centre
pins are the interface nodes of the secondary suspension.

The defaults are a **tuned** model: zone thicknesses and moduli were set by hand (within
aluminium-extrusion values, ``E`` 60-80 GPa) so that the empty shell's first flexible mode
and the in-service car's first flexible mode (diamond) fall near the measured 13.03 Hz and
8.73 Hz of [002] Sec. 2; they are not a prediction from drawings.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np

from modal_twin._types import FloatArray, IntArray
from modal_twin.errors import ModelError, OptionError
from modal_twin.models.fe import FEAssembly, NodeId
from modal_twin.models.fe.shell import ShellModel

__all__ = [
    "ZONES",
    "ZONE_FACTOR_NAMES",
    "CarbodyFE",
    "CarbodyParams",
    "Equipment",
    "Zone",
    "build_carbody",
    "default_equipment",
    "default_zones",
]

ZONES: tuple[str, ...] = ("underframe", "side_wall", "roof", "end_wall", "window_belt", "door")
"""Zone names: the four of [002] Table 1, then the window belt and the door openings."""

ZONE_FACTOR_NAMES: tuple[str, ...] = tuple(f"{k}_{z}" for z in ZONES for k in ("E", "rho"))
"""Zone factors of the carbody updating (:mod:`modal_twin.updating.carbody`): ``E_<zone>``
and ``rho_<zone>``, the names of the shell matrices' linear parameters."""


@dataclass(frozen=True, slots=True)
class Zone:
    """Equivalent isotropic plate of one zone.

    Attributes
    ----------
    E : float
        Young's modulus, Pa.
    nu : float
        Poisson ratio.
    rho : float
        Density, kg/m^3.
    t : float
        Membrane (and structural mass) thickness, m.
    t_b : float
        Bending-equivalent thickness, m (``t_b^3 / 12`` = second moment per width).
    nsm : float
        Non-structural mass in service (interior, fittings), kg/m^2.
    E_service : float or None
        Modulus in service if it differs (bonded glazing and closed doors stiffen the
        openings of the window belt and door zones), Pa; None: ``E``.
    """

    E: float
    nu: float
    rho: float
    t: float
    t_b: float
    nsm: float = 0.0
    E_service: float | None = None

    def modulus(self, in_service: bool) -> float:
        """Return the modulus of the empty shell or of the car in service, Pa."""
        return self.E_service if in_service and self.E_service is not None else self.E


@dataclass(frozen=True, slots=True)
class Equipment:
    """A piece of equipment: a rigid body on four hangers.

    Attributes
    ----------
    name : str
    x : float
        Longitudinal position of its centre of mass, m (0 = carbody centre).
    mass : float
        kg.
    inertia : (3,) tuple
        ``Jxx, Jyy, Jzz`` about its centre of mass, kg m^2.
    mount : {"underframe", "roof"}
        Underframe equipment hangs from the side beams (centre of mass ``depth`` below the
        floor); roof equipment sits ``depth`` above the roof.
    hanger : {"elastic", "rigid"}
        Elastic mounts (``f_mount_hz``, ``zeta``) or bolted (stiff springs, ``k_rigid``).
    half_length : float
        Hangers at ``x +- half_length``, m.
    half_width : float
        Hangers at ``y = +-half_width`` (roof), m; underframe hangers are on the side beams.
    depth : float
        Distance of the centre of mass from the floor (below) or roof (above), m.
    f_mount_hz : float
        Vertical mount frequency of the body on its elastic hangers, Hz.
    lateral_ratio : float
        Lateral / longitudinal mount stiffness over the vertical one.
    zeta : float
        Damping ratio of the mounts (vertical).
    """

    name: str
    x: float
    mass: float
    inertia: tuple[float, float, float]
    mount: Literal["underframe", "roof"] = "underframe"
    hanger: Literal["elastic", "rigid"] = "elastic"
    half_length: float = 0.8
    half_width: float = 0.8
    depth: float = 0.5
    f_mount_hz: float = 16.0
    lateral_ratio: float = 1.0
    zeta: float = 0.1


def default_zones() -> dict[str, Zone]:
    """Return the tuned zones of the carbody (module docstring).

    Thicknesses: hollow double-skin aluminium extrusions, ``t`` the equivalent solid
    thickness (skins and webs), ``t_b = (6 s d^2)^(1/3)`` for skins ``s`` at a depth ``d``;
    the window belt and the door zones are the side wall with its openings (lower
    equivalent modulus and thickness). ``nsm``: interior and fittings, about 18 t in all.
    """
    return {
        "underframe": Zone(E=70e9, nu=0.33, rho=2700.0, t=0.018, t_b=0.090, nsm=210.0),
        "side_wall": Zone(E=70e9, nu=0.33, rho=2700.0, t=0.010, t_b=0.0285, nsm=20.0),
        "roof": Zone(E=70e9, nu=0.33, rho=2700.0, t=0.009, t_b=0.080, nsm=20.0),
        "end_wall": Zone(E=70e9, nu=0.33, rho=2700.0, t=0.010, t_b=0.030, nsm=30.0),
        "window_belt": Zone(E=6e9, nu=0.33, rho=2700.0, t=0.004, t_b=0.036, nsm=25.0,
                            E_service=12e9),
        "door": Zone(E=3e9, nu=0.33, rho=2700.0, t=0.004, t_b=0.015, nsm=40.0),
    }


def default_equipment() -> tuple[Equipment, ...]:
    """Return the equipment of a trailer car ([002] Fig. 3: under the underframe; roof AC)."""
    return (
        Equipment("traction_transformer", 0.0, 5000.0, (1300.0, 2800.0, 3300.0),
                  half_length=1.2, depth=0.55),
        Equipment("auxiliary_converter", 5.2, 1400.0, (300.0, 500.0, 600.0), f_mount_hz=22.0),
        Equipment("auxiliary_compressor", -4.6, 600.0, (80.0, 100.0, 120.0), half_length=0.5,
                  depth=0.45, f_mount_hz=22.0),
        Equipment("sewage_tank", -10.6, 900.0, (150.0, 200.0, 250.0), hanger="rigid",
                  half_length=0.6),
        Equipment("brake_module", 7.4, 350.0, (40.0, 50.0, 60.0), hanger="rigid",
                  half_length=0.4, depth=0.35),
        Equipment("air_cylinder", 3.0, 200.0, (20.0, 30.0, 30.0), hanger="rigid",
                  half_length=0.4, depth=0.3),
        Equipment("air_conditioner", 6.0, 900.0, (250.0, 450.0, 500.0), mount="roof",
                  half_length=1.0, half_width=0.8, depth=0.25, f_mount_hz=22.0),
    )


@dataclass(frozen=True, slots=True)
class CarbodyParams:
    """Geometry, zones, equipment and mesh of the 3D carbody.

    Attributes
    ----------
    length, pivot_spacing, width, height : float
        m ([002] Fig. 1: 25.0 and 17.8).
    seat_half_spacing : float
        Air-spring seats at ``y = +-seat_half_spacing``, m.
    belt : (2,) tuple
        Window belt from ``z = belt[0]`` to ``belt[1]``, m above the floor.
    door_width, door_height : float
        Door openings (both sides, both ends), m.
    door_offset : float
        Distance of a door's inner edge from the carbody end, m.
    zones : dict zone name -> Zone
    equipment : tuple of Equipment
    in_service : bool
        False: the empty shell (no non-structural mass, no equipment).
    equipment_bodies : bool
        False: the hanger nodes are placed and named but the equipment bodies and their
        hangers are left out (a vehicle model adds them, the hangers as devices).
    hung_outside : tuple of str
        Equipment whose body and hangers are left out while its hanger nodes are placed
        and named (also in the empty shell): the 3D vehicle hangs these boxes itself
        (:mod:`modal_twin.models.vehicle3d`).
    n_length, n_width, n_height : int
        Elements along the length, across the floor / roof and up a side wall (minimum
        counts: break lines at the pivots, seats, belt and doors are added).
    bolster_ei : float
        Bending stiffness of the bolster beams (both planes), N m^2.
    drilling : float
        Drilling penalty factor of the shells.
    """

    length: float = 25.0
    pivot_spacing: float = 17.8
    width: float = 3.2
    height: float = 2.9
    seat_half_spacing: float = 1.2
    belt: tuple[float, float] = (0.95, 1.9)
    door_width: float = 1.0
    door_height: float = 2.0
    door_offset: float = 1.5
    zones: dict[str, Zone] = field(default_factory=default_zones)
    equipment: tuple[Equipment, ...] = field(default_factory=default_equipment)
    in_service: bool = True
    equipment_bodies: bool = True
    hung_outside: tuple[str, ...] = ()
    n_length: int = 30
    n_width: int = 4
    n_height: int = 4
    bolster_ei: float = 2e7
    drilling: float = 1e-2

    def empty(self) -> CarbodyParams:
        """Return the same carbody as an empty shell."""
        return replace(self, in_service=False)

    def with_zone_factors(self, factors: Mapping[str, float]) -> CarbodyParams:
        """Return a copy with zone moduli and densities times ``factors``.

        ``factors`` maps :data:`ZONE_FACTOR_NAMES` entries (the carbody updating's
        parameters) to factors: ``E_<zone>`` scales the zone's modulus empty and in service
        (``E`` and ``E_service``), ``rho_<zone>`` its structural density (the
        non-structural mass stays). Both enter the shell matrices linearly, so the copy's
        matrices are those of the updating's parametric model at ``factors``.

        Raises
        ------
        OptionError
            An unknown name, or a factor not finite and > 0.
        """
        zones = dict(self.zones)
        for name, value in factors.items():
            if name not in ZONE_FACTOR_NAMES:
                msg = f"zone factor {name!r}: expected one of {list(ZONE_FACTOR_NAMES)}"
                raise OptionError(msg)
            f = float(value)
            if not (math.isfinite(f) and f > 0.0):
                msg = f"zone factor {name}: expected a finite value > 0, got {value!r}"
                raise OptionError(msg)
            kind, zone = name.split("_", 1)
            z = zones[zone]
            fields = ("E", "E_service") if kind == "E" else ("rho",)
            zones[zone] = replace(z, **{k: getattr(z, k) * f for k in fields
                                        if getattr(z, k) is not None})
        return replace(self, zones=zones)


@dataclass(frozen=True, slots=True)
class CarbodyFE:
    """An assembled carbody with its named nodes.

    Attributes
    ----------
    params : CarbodyParams
    asm : FEAssembly
    stations : (n_st,) float array
        ``x`` of the cross-section rings, m.
    ring : (n_st, n_ring) object array
        Node ids of each ring (perimeter order: floor, right wall, roof, left wall).
    ring_yz : (n_ring, 2) float array
        ``(y, z)`` of the ring's nodes, m.
    seats : dict name -> NodeId
        Air-spring seats ``"front_left"`` ... (front: ``x > 0``; left: ``y > 0``).
    pivots : dict name -> NodeId
        Centre pins ``"front"``, ``"rear"``.
    hangers : dict equipment name -> tuple of NodeId
        Carbody nodes of each equipment's hangers.
    equipment_nodes : dict equipment name -> NodeId
        Centre-of-mass node of each equipment (in service only).
    zone_of_shell : tuple of str
        Zone of each shell, in shell order.
    """

    params: CarbodyParams
    asm: FEAssembly
    stations: FloatArray
    ring: np.ndarray
    ring_yz: FloatArray
    seats: dict[str, NodeId]
    pivots: dict[str, NodeId]
    hangers: dict[str, tuple[NodeId, ...]]
    equipment_nodes: dict[str, NodeId]
    zone_of_shell: tuple[str, ...]

    def interface_nodes(self) -> list[NodeId]:
        """Return the seats, the centre pins and the hanger nodes (no duplicates)."""
        out: list[NodeId] = [*self.seats.values(), *self.pivots.values()]
        for nodes in self.hangers.values():
            out += [n for n in nodes if n not in out]
        return out

    def interface_dofs(self) -> IntArray:
        """Return the free DOF indices of :meth:`interface_nodes` (6 per node)."""
        names = ("ux", "uy", "uz", "rx", "ry", "rz")
        return np.array([self.asm.dof_index(n, d) for n in self.interface_nodes()
                         for d in names], dtype=np.int64)


def _grid(lo: float, hi: float, n: int, breaks: list[float]) -> FloatArray:
    """``n`` (at least) nearly uniform intervals on ``[lo, hi]`` through every break."""
    pts = sorted({lo, hi, *[b for b in breaks if lo < b < hi]})
    out: list[float] = [pts[0]]
    span = hi - lo
    for a, b in itertools.pairwise(pts):
        k = max(1, math.ceil(round((b - a) / span * n, 6)))
        out += list(np.linspace(a, b, k + 1)[1:])
    return np.asarray(out)


def _check(p: CarbodyParams) -> None:
    if set(p.zones) != set(ZONES):
        msg = f"zones: expected exactly {list(ZONES)}, got {sorted(p.zones)}"
        raise ModelError(msg)
    for name, val in (("length", p.length), ("width", p.width), ("height", p.height),
                      ("pivot_spacing", p.pivot_spacing)):
        if not (math.isfinite(val) and val > 0.0):
            msg = f"{name}: expected a finite value > 0, got {val!r}"
            raise ModelError(msg)
    if not p.pivot_spacing < p.length:
        msg = f"pivot_spacing: expected < length {p.length}, got {p.pivot_spacing}"
        raise ModelError(msg)
    if not 0.0 < p.seat_half_spacing < p.width / 2:
        msg = f"seat_half_spacing: expected in (0, {p.width / 2}), got {p.seat_half_spacing}"
        raise ModelError(msg)
    if not 0.0 < p.belt[0] < p.belt[1] < p.height:
        msg = f"belt: expected 0 < low < high < {p.height}, got {p.belt}"
        raise ModelError(msg)
    for name, n in (("n_length", p.n_length), ("n_width", p.n_width),
                    ("n_height", p.n_height)):
        if not (isinstance(n, int) and 2 <= n <= 2000):
            msg = f"{name}: expected an int in [2, 2000], got {n!r}"
            raise ModelError(msg)


def _ring(ys: FloatArray, zs: FloatArray) -> FloatArray:
    """Perimeter ``(y, z)``: floor (-W/2 -> W/2), right wall up, roof back, left wall down."""
    floor = [(y, zs[0]) for y in ys[:-1]]
    right = [(ys[-1], z) for z in zs[:-1]]
    roof = [(y, zs[-1]) for y in ys[::-1][:-1]]
    left = [(ys[0], z) for z in zs[::-1][:-1]]
    return np.array(floor + right + roof + left)


def _shell_zone(p: CarbodyParams, x: float, z: float, H: float) -> str:
    """Zone of a side-wall / floor / roof shell from its centre."""
    if abs(z) < 1e-9:
        return "underframe"
    if abs(z - H) < 1e-9:
        return "roof"
    half = p.length / 2
    from_end = half - abs(x)
    if p.door_offset - p.door_width <= from_end <= p.door_offset and z < p.door_height:
        return "door"
    if p.belt[0] < z < p.belt[1]:
        return "window_belt"
    return "side_wall"


def build_carbody(p: CarbodyParams | None = None) -> CarbodyFE:
    """Build and assemble the 3D shell carbody (module docstring).

    Parameters
    ----------
    p : CarbodyParams, optional
        Default: the tuned trailer car in service.

    Returns
    -------
    CarbodyFE

    Raises
    ------
    ModelError
        Inconsistent parameters.

    Examples
    --------
    >>> cb = build_carbody(CarbodyParams(n_length=8, n_width=2, n_height=2, in_service=False))
    >>> round(cb.asm.total_mass() / 1e3, 1) > 5.0
    True
    """
    p = CarbodyParams() if p is None else p
    _check(p)
    W, H, half = p.width, p.height, p.length / 2
    xp = p.pivot_spacing / 2
    door_x = [half - p.door_offset, half - p.door_offset + p.door_width]
    eq_x: list[float] = []  # hanger lines, in the empty shell's mesh too (same nodes)
    for e in p.equipment:
        eq_x += [e.x - e.half_length, e.x + e.half_length]
    xs = _grid(-half, half, p.n_length, [-xp, xp, *door_x, *[-d for d in door_x], *eq_x])
    ys = _grid(-W / 2, W / 2, p.n_width, [0.0, -p.seat_half_spacing, p.seat_half_spacing])
    zs = _grid(0.0, H, p.n_height, [*p.belt, p.door_height])
    ring_yz = _ring(ys, zs)
    n_ring = ring_yz.shape[0]
    fem = ShellModel()
    ring = np.empty((xs.size, n_ring), dtype=object)
    for i, x in enumerate(xs):
        for k, (y, z) in enumerate(ring_yz):
            ring[i, k] = fem.add_node(f"r{i}_{k}", (x, y, z))
    quads: dict[str, list[tuple[NodeId, NodeId, NodeId, NodeId]]] = {z: [] for z in ZONES}
    for i in range(xs.size - 1):
        xc = 0.5 * (xs[i] + xs[i + 1])
        for k in range(n_ring):
            k2 = (k + 1) % n_ring
            zc = 0.5 * (ring_yz[k, 1] + ring_yz[k2, 1])
            zone = _shell_zone(p, xc, zc, H)
            quads[zone].append((ring[i, k], ring[i + 1, k], ring[i + 1, k2], ring[i, k2]))
    _end_walls(fem, xs, ys, zs, ring, ring_yz, quads)
    zone_of_shell: list[str] = []
    for zone in ZONES:
        zp = p.zones[zone]
        fem.add_shells(quads[zone], E=zp.modulus(p.in_service), nu=zp.nu, rho=zp.rho, t=zp.t,
                       t_b=zp.t_b, nsm=zp.nsm if p.in_service else 0.0, E_param=f"E_{zone}",
                       rho_param=f"rho_{zone}", drilling=p.drilling)
        zone_of_shell += [zone] * len(quads[zone])
    seats, pivots = _bolsters(fem, p, xs, ring, ring_yz)
    hangers: dict[str, tuple[NodeId, ...]] = {}
    eq_nodes: dict[str, NodeId] = {}
    for e in p.equipment:
        outside = e.name in p.hung_outside
        if p.in_service or outside:
            hangers[e.name] = _hanger_nodes(e, xs, ring, ring_yz, W, H)
            if p.in_service and p.equipment_bodies and not outside:
                eq_nodes[e.name] = _equipment(fem, e, hangers[e.name], H)
    return CarbodyFE(params=p, asm=fem.assemble(), stations=xs, ring=ring, ring_yz=ring_yz,
                     seats=seats, pivots=pivots, hangers=hangers, equipment_nodes=eq_nodes,
                     zone_of_shell=tuple(zone_of_shell))


def _end_walls(fem: ShellModel, xs: FloatArray, ys: FloatArray, zs: FloatArray,
               ring: np.ndarray, ring_yz: FloatArray,
               quads: dict[str, list[tuple[NodeId, NodeId, NodeId, NodeId]]]) -> None:
    """Add the end walls' interior nodes and shells (grid ``ys x zs`` at ``x = +-L/2``)."""
    lookup = {(round(y, 9), round(z, 9)): k for k, (y, z) in enumerate(ring_yz)}
    for end, i in (("rear", 0), ("front", xs.size - 1)):
        grid = np.empty((ys.size, zs.size), dtype=object)
        for a, y in enumerate(ys):
            for b, z in enumerate(zs):
                k = lookup.get((round(y, 9), round(z, 9)))
                grid[a, b] = (ring[i, k] if k is not None
                              else fem.add_node(f"e{end}_{a}_{b}", (xs[i], y, z)))
        for a in range(ys.size - 1):
            for b in range(zs.size - 1):
                quads["end_wall"].append((grid[a, b], grid[a + 1, b], grid[a + 1, b + 1],
                                          grid[a, b + 1]))


def _floor_node(xs: FloatArray, ring: np.ndarray, ring_yz: FloatArray, x: float,
                y: float) -> NodeId:
    i = int(np.argmin(np.abs(xs - x)))
    k = int(np.argmin(np.abs(ring_yz[:, 0] - y) + 1e3 * np.abs(ring_yz[:, 1])))
    node: NodeId = ring[i, k]
    return node


def _bolsters(fem: ShellModel, p: CarbodyParams, xs: FloatArray, ring: np.ndarray,
              ring_yz: FloatArray) -> tuple[dict[str, NodeId], dict[str, NodeId]]:
    """Bolster beams across the floor at the pivots; return the seats and centre pins."""
    seats: dict[str, NodeId] = {}
    pivots: dict[str, NodeId] = {}
    floor = [k for k, (_, z) in enumerate(ring_yz) if abs(z) < 1e-9]
    order = sorted(floor, key=lambda k: ring_yz[k, 0])
    E, G = 70e9, 26e9  # aluminium box beam; its mass is in the underframe zone
    inertia = p.bolster_ei / E
    for name, x in (("front", p.pivot_spacing / 2), ("rear", -p.pivot_spacing / 2)):
        i = int(np.argmin(np.abs(xs - x)))
        nodes = [ring[i, k] for k in order]
        for a, b in itertools.pairwise(nodes):
            fem.add_frame(a, b, orientation=(0.0, 0.0, 1.0), E=E, G=G, A=0.02, Iy=inertia,
                          Iz=inertia, J=2.0 * inertia, rho=0.0)
        pivots[name] = _floor_node(xs, ring, ring_yz, x, 0.0)
        seats[f"{name}_left"] = _floor_node(xs, ring, ring_yz, x, p.seat_half_spacing)
        seats[f"{name}_right"] = _floor_node(xs, ring, ring_yz, x, -p.seat_half_spacing)
    return seats, pivots


def _hanger_nodes(e: Equipment, xs: FloatArray, ring: np.ndarray, ring_yz: FloatArray,
                  W: float, H: float) -> tuple[NodeId, ...]:
    """Carbody nodes of the four hangers: side beams (underframe) or roof, ``x +- a``.

    The mesh has lines at ``x +- a``; across the roof the nearest node to ``+-half_width``.
    """
    zh = H if e.mount == "roof" else 0.0
    hy = e.half_width if e.mount == "roof" else W / 2
    out: list[NodeId] = []
    for sx in (-1.0, 1.0):
        i = int(np.argmin(np.abs(xs - (e.x + sx * e.half_length))))
        for sy in (-1.0, 1.0):
            dist = np.abs(ring_yz[:, 0] - sy * hy) + 1e3 * np.abs(ring_yz[:, 1] - zh)
            out.append(ring[i, int(np.argmin(dist))])
    return tuple(out)


def _equipment(fem: ShellModel, e: Equipment, body_nodes: tuple[NodeId, ...],
               H: float) -> NodeId:
    """Add one equipment body on its four hangers; return its centre-of-mass node.

    Each hanger is a node at the carbody node's position, rigidly tied to the body, and a
    zero-length spring-dashpot to the carbody node (elastic: vertical ``k = m (2 pi f)^2 / 4``
    per hanger, lateral and longitudinal ``lateral_ratio k``, ``c = 2 zeta sqrt(k m / 4)``;
    rigid: ``1e9`` N/m in every direction, no damping).
    """
    if not (math.isfinite(e.mass) and e.mass > 0.0):
        msg = f"equipment {e.name!r} mass: expected a finite value > 0, got {e.mass!r}"
        raise ModelError(msg)
    zc = H + e.depth if e.mount == "roof" else -e.depth
    cog = fem.add_node(f"eq_{e.name}", (e.x, 0.0, zc))
    fem.add_point_mass(cog, e.mass, J=e.inertia)
    rigid = e.hanger == "rigid"
    kz = 1e9 if rigid else e.mass * (2.0 * math.pi * e.f_mount_hz) ** 2 / 4.0
    kl = kz if rigid else kz * e.lateral_ratio
    cz = 0.0 if rigid else 2.0 * e.zeta * math.sqrt(kz * e.mass / 4.0)
    for j, n in enumerate(body_nodes):
        h = fem.add_node(f"eq_{e.name}_h{j}", tuple(fem.xyz(n)))
        fem.add_rigid_link(cog, h)
        c = {"ux": cz * e.lateral_ratio, "uy": cz * e.lateral_ratio, "uz": cz} if cz else None
        fem.add_spring(h, n, k={"ux": kl, "uy": kl, "uz": kz}, c=c)
    return cog
