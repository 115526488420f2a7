"""The 3D car with the shell carbody as a 3D scene: the shell's mesh, bogies, wheelsets.

The scene is in the vehicle's frame (x along the car, front +; y left; z up from the rail).
The carbody is the shell's mesh (:mod:`modal_twin.models.carbody3d`, lifted by the seat
height ``z0``): its longitudinal and circumferential lines, the end walls, the bolsters and
the equipment on their hangers, one scene node per FE node. Each bogie frame is a
rectangle at its centre height (corners at the primary suspensions, ``x_b +- a``,
``y = +-b``), with the air springs as lines from its side mid-points up to the seat nodes;
each wheelset is an axle line at the rolling radius. A box the file hangs on elastic
hangers (``hanger: elastic``: six coordinates of its own, left out of the shell) is the
uniform box of its mass and inertia about its centre of mass, moving as a rigid body with
those coordinates, with a line per hanger up (down) to the carbody's point.

A vehicle mode ``x`` (vehicle coordinates) moves the nodes by :attr:`Vehicle3DScene.move`:
a shell node by the recovery of the carbody coordinates (``T`` of the Craig-Bampton
reduction times the carbody basis, :meth:`ShellCarbody.recover`), a body point ``r`` of a
bogie or wheelset by its rigid motion ``u + theta x (r - r_G)`` (a wheelset: lateral ``y``
and yaw only; its vertical and roll follow the track). The coupled modes are complex (the
creep forces and Maxwell dampers make the damping non-proportional): a shape is turned so
that its largest carbody component is real, then its real part drawn. A record's track
drives the car for :func:`record_deflection`: every node over the record's strongest
stretch.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.errors import ModelError, OptionError
from modal_twin.models.carbody3d import CarbodyFE, Equipment
from modal_twin.models.carbody_shell import ShellCarbody
from modal_twin.models.fe import NodeId
from modal_twin.models.vehicle3d import N_AXLES, Vehicle3D, box_centre
from modal_twin.models.vehicle3d_ride import carbody_mode_shapes
from modal_twin.viz.scene import SceneModes, StructureGeometry, _edges_from_stiffness

__all__ = ["RecordDeflection", "Vehicle3DScene", "box_half_sizes", "record_deflection",
           "vehicle3d_scene"]

FRAME_HALF_WIDTH_M = 1.0
"""Half width of a bogie frame's rectangle, m (drawing only)."""


@dataclass(frozen=True, slots=True)
class Vehicle3DScene:
    """Wireframe of the 3D car and the map from vehicle coordinates to node translations.

    Attributes
    ----------
    geom : StructureGeometry
    move : (n_nodes, 3, n_dof) float array
        Translation of every wireframe node per unit of each vehicle coordinate.
    n_shell_nodes : int
        The first nodes are the shell's FE nodes, in the assembly's order.
    """

    geom: StructureGeometry
    move: FloatArray
    n_shell_nodes: int

    def modes(self, vehicle: Vehicle3D, speed: float, *, labels: Sequence[str] | None = None,
              n_modes: int = 6) -> SceneModes:
        """Return carbody modes of the coupled car at ``speed`` (m/s) on the wireframe.

        Parameters
        ----------
        vehicle : Vehicle3D
        speed : float
            m/s.
        labels : sequence of str, optional
            Carbody mode names (``"vertical bending 1"``, ``"diamond 1"``, ``"bounce"``
            ...); default the lowest ``n_modes`` carbody modes.
        n_modes : int

        Raises
        ------
        OptionError
            A label that names no carbody mode (the message lists them).
        """
        modes, X = carbody_mode_shapes(vehicle, speed)
        names = [m.label for m in modes]
        if labels is None:
            pick = list(range(min(max(n_modes, 0), len(modes))))
        else:
            missing = [lab for lab in labels if lab not in names]
            if missing:
                msg = (f"carbody mode {missing[0]!r}: expected one of the car's carbody modes "
                       f"at {3.6 * speed:g} km/h: {names}")
                raise OptionError(msg)
            pick = [names.index(lab) for lab in labels]
        nc = vehicle.carbody.n
        shapes = np.zeros((len(pick), self.move.shape[0], 3))
        for j, i in enumerate(pick):
            x = X[:, i]
            top = x[int(np.argmax(np.abs(x[:nc])))]
            xr = (x * (abs(top) / top)).real if top != 0 else x.real
            shapes[j] = self.move @ xr
        f = np.array([modes[i].f_hz for i in pick])
        zeta = np.array([modes[i].zeta for i in pick])
        caption = tuple(f"{modes[i].label}: {modes[i].f_hz:.2f} Hz, "
                        f"{100 * modes[i].zeta:.1f} %" for i in pick)
        return SceneModes(f, zeta, shapes, labels=caption)


@dataclass(frozen=True, slots=True)
class RecordDeflection:
    """The car's deflection over a stretch of a record, on every wireframe node.

    Attributes
    ----------
    frames : (n_frames, n_nodes, 3) float array
        Node displacements, m (:attr:`Vehicle3DScene.move` times the coordinates).
    t0_s, dt_s : float
        Record time of the first frame and between frames, s.
    floor : (n_floor, nt) float array
        The model's floor accelerations over the whole record, m/s^2.
    floor_names : tuple of str
    """

    frames: FloatArray
    t0_s: float
    dt_s: float
    floor: FloatArray
    floor_names: tuple[str, ...]


def record_deflection(scene: Vehicle3DScene, vehicle: Vehicle3D, w: FloatArray,
                      fs_hz: float, *, window_s: float, n_frames: int = 96
                      ) -> RecordDeflection:
    """Run the car on a record's track input ``w`` and draw its strongest stretch.

    The car (:meth:`~modal_twin.models.vehicle3d.Vehicle3D.simulate`, exact zero-order
    hold from rest at the file's speed) gives every coordinate; the ``window_s`` with the
    largest carbody motion is cut into ``n_frames`` (every ``step``-th sample) and each
    frame's coordinates moved onto the nodes by :attr:`Vehicle3DScene.move`.

    Parameters
    ----------
    scene : Vehicle3DScene
    vehicle : Vehicle3D
    w : (24, nt) float array
        ``[u; u']`` of :func:`modal_twin.models.track3d.track_inputs_3d`.
    fs_hz : float
    window_s : float
    n_frames : int
    """
    from modal_twin.viz.motion import strongest_window

    sim = vehicle.simulate(w, fs_hz, vehicle.spec.speed, dofs=vehicle.dof_names)
    q = sim.dofs
    win = strongest_window(q[: vehicle.carbody.n], max(2, round(window_s * fs_hz)))
    step = max(1, (win.stop - win.start) // max(n_frames, 1))
    idx = np.arange(win.start, win.stop, step)
    frames = np.einsum("nck,kt->tnc", scene.move, q[:, idx])
    return RecordDeflection(frames, win.start / fs_hz, step / fs_hz, sim.floor,
                            sim.floor_names)


def _rigid_rows(n: int, col: int, r: FloatArray, dofs: Sequence[int] = range(6)
                ) -> FloatArray:
    """(3, n): translation of a point at offset ``r`` from a body's centre per coordinate.

    ``dofs``: which of the body's (x, y, z, roll, pitch, yaw) follow from columns
    ``col, col + 1, ...`` in that order (a wheelset: y and yaw).
    """
    full = np.zeros((3, 6))
    full[:, :3] = np.eye(3)
    rx, ry, rz = r
    full[:, 3:] = -np.array([[0.0, -rz, ry], [rz, 0.0, -rx], [-ry, rx, 0.0]])  # theta x r
    out = np.zeros((3, n))
    for k, d in enumerate(dofs):
        out[:, col + k] = full[:, d]
    return out


def vehicle3d_scene(vehicle: Vehicle3D) -> Vehicle3DScene:
    """Build the wireframe of a 3D car with the shell carbody (module docstring).

    Raises
    ------
    ModelError
        The car's carbody is not the shell (a rigid carbody has no mesh to draw).
    """
    src = vehicle.carbody.source
    if not isinstance(src, ShellCarbody):
        msg = (f"carbody: expected the shell carbody to draw, got {vehicle.carbody.name!r} "
               "(carbody.model: shell)")
        raise ModelError(msg)
    spec, car, asm = vehicle.spec, src.car, src.car.asm
    n, nc = vehicle.n_dof, vehicle.carbody.n
    index = {node: k for k, node in enumerate(asm.nodes)}
    xyz = [np.array(p, dtype=float) + np.array([0.0, 0.0, src.z0]) for p in asm.xyz]
    full = np.asarray(asm.expand(src.recover(np.eye(nc))))  # (6 n_nodes, nc): slaves too
    move = []
    for k in range(len(xyz)):
        m = np.zeros((3, n))
        m[:, :nc] = full[6 * k:6 * k + 3]
        move.append(m)
    edges = _shell_edges(vehicle, index)
    v = spec.v
    seats = {s: index[node] for s, node in car.seats.items()}

    def add(p: FloatArray, rows_: FloatArray) -> int:
        xyz.append(np.asarray(p, dtype=float))
        move.append(rows_)
        return len(xyz) - 1

    a, zb = 0.5 * v("bogie", "wheelbase"), v("bogie", "cg_height")
    b = FRAME_HALF_WIDTH_M
    for k, xb in enumerate(spec.pivot_x):
        col = nc + 6 * k
        G = np.array([xb, 0.0, zb])
        corners = [add(G + r, _rigid_rows(n, col, r)) for r in (
            np.array([a, b, 0.0]), np.array([-a, b, 0.0]), np.array([-a, -b, 0.0]),
            np.array([a, -b, 0.0]))]
        edges += [(corners[i], corners[(i + 1) % 4]) for i in range(4)]
        for side in ("left", "right"):
            seat = seats[f"{'front' if k == 0 else 'rear'}_{side}"]
            y = xyz[seat][1]
            r = np.array([0.0, y, 0.0])
            edges.append((add(G + r, _rigid_rows(n, col, r)), seat))
    r0 = v("contact", "r0")
    for w, xw in enumerate(spec.axle_x):
        col = nc + 12 + 2 * w
        ends = [add(np.array([xw, y, r0]), _rigid_rows(n, col, np.array([0.0, y, 0.0]),
                                                        dofs=(1, 5)))
                for y in (-0.75, 0.75)]
        edges.append((ends[0], ends[1]))
    for i, box in enumerate(spec.hung_equipment):
        edges += _hung_box(vehicle, box, nc + 12 + 2 * N_AXLES + 6 * i, add)
    pos = np.array(xyz)
    sensors = {p.label: pos[index[_nearest_floor(car, p.x, p.y)]] for p in spec.floor_points}
    geom = StructureGeometry(f"{spec.name} (shell carbody)", pos,
                             np.array(sorted({(min(p, q), max(p, q)) for p, q in edges}),
                                      dtype=np.int64), sensors, {})
    return Vehicle3DScene(geom, np.array(move), len(asm.nodes))


def box_half_sizes(box: Equipment) -> FloatArray:
    """Half sizes ``(x, y, z)`` of the uniform box with the equipment's mass and inertia, m.

    ``J_xx = m (L_y^2 + L_z^2) / 12`` and its two companions, so ``L_x^2 = 6 (J_yy + J_zz -
    J_xx) / m`` ...; drawing only (a side an inertia cannot give is drawn 0.1 m).
    """
    j = np.asarray(box.inertia, dtype=float)
    sq = 6.0 * (j.sum() - 2.0 * j) / box.mass
    return 0.5 * np.sqrt(np.maximum(sq, 0.01))


def _hung_box(vehicle: Vehicle3D, box: Equipment, col: int,
              add: Callable[[FloatArray, FloatArray], int]) -> list[tuple[int, int]]:
    """Draw a box on elastic hangers; return its lines.

    The box of :func:`box_half_sizes` about its centre of mass
    (:func:`~modal_twin.models.vehicle3d.box_centre`), its corners moving with the box's own
    six coordinates from column ``col`` (``u + theta x r``), and a line per hanger from the
    box's face below (above) the hanger point to the carbody's point there (its translation
    from the carbody coordinates, ``ReducedCarbody.hangers``).
    """
    n, nc = vehicle.n_dof, vehicle.carbody.n
    E, h = box_centre(vehicle.spec, box), box_half_sizes(box)
    signs = list(itertools.product((-1.0, 1.0), repeat=3))
    corners = [add(E + h * sg, _rigid_rows(n, col, h * np.array(sg))) for sg in signs]
    edges = [(corners[a], corners[b]) for a, b in itertools.combinations(range(8), 2)
             if sum(x != y for x, y in zip(signs[a], signs[b], strict=True)) == 1]
    for j in range(4):
        p, P = vehicle.carbody.hangers[f"{box.name}_h{j + 1}"]
        rows = np.zeros((3, n))
        rows[:, :nc] = P
        r = np.array([p[0] - E[0], p[1] - E[1], np.sign(p[2] - E[2]) * h[2]])
        edges.append((add(E + r, _rigid_rows(n, col, r)), add(p, rows)))
    return edges


def _shell_edges(vehicle: Vehicle3D, index: dict[NodeId, int]) -> list[tuple[int, int]]:
    """Return the lines of the shell's mesh.

    The ring's sides (no diagonals), then every other pair of nodes an element joins (end
    walls, bolsters, hangers, equipment).
    """
    src = vehicle.carbody.source
    assert isinstance(src, ShellCarbody)
    ring, asm = src.car.ring, src.car.asm
    nr = ring.shape[1]
    edges: set[tuple[int, int]] = set()
    for i, k in itertools.product(range(ring.shape[0]), range(nr)):
        a = index[ring[i, k]]
        nbrs = [ring[i, (k + 1) % nr]] + ([ring[i + 1, k]] if i + 1 < ring.shape[0] else [])
        edges.update((min(a, index[o]), max(a, index[o])) for o in nbrs)
    on_ring = np.zeros(len(index), dtype=bool)
    on_ring[[index[node] for node in ring.ravel()]] = True
    T = asm.T
    pairs = _edges_from_stiffness(T @ asm.K @ T.T)
    keep = ~(on_ring[pairs[:, 0]] & on_ring[pairs[:, 1]])
    edges.update((int(a), int(b)) for a, b in pairs[keep])
    return sorted(edges)


def _nearest_floor(car: CarbodyFE, x: float, y: float) -> NodeId:
    """Return the underframe ring node nearest ``(x, y)`` (as the shell car's floor points)."""
    i = int(np.argmin(np.abs(car.stations - x)))
    floor = np.flatnonzero(np.abs(car.ring_yz[:, 1]) < 1e-9)
    k = int(floor[np.argmin(np.abs(car.ring_yz[floor, 0] - y))])
    node: NodeId = car.ring[i, k]
    return node
