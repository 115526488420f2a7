"""The rail vehicle as a 3D scene: the car side, bogies, wheelsets, suspensions, equipment.

The vehicle model is vertical-plane (:mod:`modal_twin.models.vehicle`), so the scene is the
car seen from the side: the carbody as floor and roof lines over its beam nodes (joined at
the ends and over the pivots), each bogie frame over its two wheelsets (primary
suspensions), the secondary suspension from the bogie centre up to the pivot, every
underframe equipment item hanging under its attachment node. The car's x (front +) is the
scene's y, height is z. A mode moves every point vertically: the carbody nodes by the
Craig-Bampton recovery of the beam (``uz`` rows of ``T``), a bogie point at ``x`` by
``z_b + (x - x_b) beta_b``, an elastic item by its own ``z_e``, a rigid one with its node;
the wheelsets follow the track and stay still in the free modes.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.models.vehicle import VehicleModel
from modal_twin.viz.scene import SceneModes, StructureGeometry

__all__ = ["VehicleScene", "vehicle_scene"]

FLOOR_M, ROOF_M, BOGIE_M, AXLE_M, HANG_M = 1.25, 3.85, 0.85, 0.46, 0.6
"""Heights of the floor, roof, bogie frame and axles, and how far equipment hangs, m."""


@dataclass(frozen=True, slots=True)
class VehicleScene:
    """Wireframe of a vehicle and the map from its coordinates to the wireframe's heights.

    Attributes
    ----------
    geom : StructureGeometry
    lift : (n_nodes, n_dof) float array
        Vertical displacement of every wireframe node per unit of each model coordinate.
    """

    geom: StructureGeometry
    lift: FloatArray

    def modes(self, vm: VehicleModel, n_modes: int) -> SceneModes:
        """Return the lowest ``n_modes`` coupled modes on the wireframe (vertical motion).

        Damping ratios are the diagonal of ``Phi' C Phi / (2 omega)`` (the suspensions make
        the damping non-classical: the modal equivalent).
        """
        k = min(n_modes, vm.Phi.shape[1])
        phi = vm.Phi[:, :k]
        dz = self.lift @ phi  # (n_nodes, k)
        shapes = np.zeros((k, dz.shape[0], 3))
        shapes[:, :, 2] = dz.T
        zeta = np.einsum("ik,ij,jk->k", phi, vm.C, phi) / (2.0 * vm.omega[:k])
        return SceneModes(vm.f_hz[:k].copy(), zeta, shapes)


def vehicle_scene(vm: VehicleModel) -> VehicleScene:
    """Build the side-view wireframe of a coupled vehicle model (module docstring)."""
    spec, car = vm.spec, vm.carbody
    n = vm.M.shape[0]
    n_cb = car.cb.T.shape[1]
    xyz: list[tuple[float, float, float]] = []
    lift: list[FloatArray] = []
    edges: list[tuple[int, int]] = []

    def node(x: float, z: float, row: FloatArray) -> int:
        xyz.append((0.0, float(x), z))
        lift.append(row)
        return len(xyz) - 1

    def on_car(x: float) -> FloatArray:
        r = np.zeros(n)
        r[:n_cb] = car.uz_row(x)
        return r

    floor = [node(x, FLOOR_M, on_car(x)) for x in car.node_x]
    roof = [node(x, ROOF_M, on_car(x)) for x in car.node_x]
    edges += [(a, b) for line in (floor, roof) for a, b in itertools.pairwise(line)]
    devices: dict[str, FloatArray] = {}
    for b, (xb, side) in enumerate(zip(spec.pivot_x, ("front", "rear"), strict=True)):
        up = car.node_at(xb)
        edges.append((floor[up], roof[up]))
        frame = []
        for off in (0.5 * spec.wheelbase, 0.0, -0.5 * spec.wheelbase):
            r = np.zeros(n)
            r[n_cb + 2 * b], r[n_cb + 2 * b + 1] = 1.0, off
            frame.append(node(xb + off, BOGIE_M, r))
        edges += [(frame[0], frame[1]), (frame[1], frame[2]), (frame[1], floor[up])]
        for s, end in enumerate((frame[0], frame[2])):
            wheel = node(xyz[end][1], AXLE_M, np.zeros(n))
            edges.append((end, wheel))
            devices[f"primary_{2 * b + s + 1}"] = np.array(xyz[wheel])
        devices[f"secondary_{side}"] = 0.5 * (np.array(xyz[frame[1]]) + np.array(xyz[floor[up]]))
    edges += [(floor[0], roof[0]), (floor[-1], roof[-1])]
    elastic = [e.name for e in spec.equipment if e.mount == "elastic"]
    for e in spec.equipment:
        r = on_car(e.x)
        if e.name in elastic:
            r = np.zeros(n)
            r[n_cb + 4 + elastic.index(e.name)] = 1.0
        box = node(e.x, FLOOR_M - HANG_M, r)
        edges.append((box, floor[car.node_at(e.x)]))
        devices[e.name] = np.array(xyz[box])
    sensors = {f"floor_{s.label}": np.array(xyz[floor[car.node_at(s.x)]]) for s in spec.sensors}
    geom = StructureGeometry(spec.name, np.array(xyz), np.array(edges, dtype=np.int64),
                             sensors, devices)
    return VehicleScene(geom, np.array(lift))
