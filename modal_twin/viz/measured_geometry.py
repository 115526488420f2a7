"""A test's own geometry (UFF 15 / 82 / 2411 nodes and trace lines) as a 3D scene.

Modal-test software describes the measured structure by its test geometry, not a finite
element model: nodes (UFF 15 / 2411) joined by trace lines (UFF 82, a node number 0 lifts
the pen). ``modal-twin import`` keeps it beside the bag (``geometry_<file>.json``); here it
becomes a :class:`~modal_twin.viz.scene.StructureGeometry` (the nodes that carry a channel
are its sensors), and identified modes are drawn on it at the nodes and directions their
channels measure (the other nodes stay at rest: a test geometry has no model to expand
with). Node coordinates are taken as given in the global system (UFF 15 definition
systems other than the global one are not applied).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from modal_twin.errors import ConfigError
from modal_twin.viz.mode_pairs import real_shapes
from modal_twin.viz.scene import SceneModes, StructureGeometry

__all__ = ["MeasuredGeometry", "geometry_from_uff", "modes_on_nodes"]

_AXIS = {"x": 0, "y": 1, "z": 2}


class MeasuredGeometry:
    """A test geometry: the scene's wireframe and the node id of each of its rows.

    Attributes
    ----------
    geom : StructureGeometry
    ids : list of str
        Node id (as in the file) of each row of ``geom.node_xyz``.
    channel_nodes : mapping channel -> (node id, direction)
        Where each imported channel measures (from the bag's channel map).
    """

    def __init__(self, geom: StructureGeometry, ids: list[str],
                 channel_nodes: Mapping[str, tuple[str, str]]) -> None:
        self.geom, self.ids, self.channel_nodes = geom, ids, dict(channel_nodes)


def geometry_from_uff(g: Mapping[str, Any], name: str,
                      sensor_nodes: Sequence[str] = ()) -> tuple[StructureGeometry, list[str]]:
    """Wireframe of an imported UFF geometry (``nodes``: id -> xyz, ``trace_lines``).

    Raises
    ------
    ConfigError
        A geometry without nodes.
    """
    nodes = {str(k): v for k, v in dict(g.get("nodes", {})).items()}
    if not nodes:
        msg = f"{name}: the geometry has no nodes (UFF 15 or 2411)"
        raise ConfigError(msg)
    ids = sorted(nodes, key=lambda s: (len(s), s))
    row = {n: i for i, n in enumerate(ids)}
    xyz = np.array([[float(v) for v in nodes[n][:3]] for n in ids])
    edges: set[tuple[int, int]] = set()
    for line in g.get("trace_lines", []):
        seq = [str(int(v)) for v in line.get("nodes", [])]
        for a, b in itertools.pairwise(seq):
            if a != "0" and b != "0" and a in row and b in row and a != b:
                edges.add((min(row[a], row[b]), max(row[a], row[b])))
    sensors = {n: xyz[row[n]] for n in sensor_nodes if n in row}
    return (StructureGeometry(name, xyz, np.array(sorted(edges), dtype=np.int64).reshape(-1, 2),
                              sensors), ids)


def modes_on_nodes(tg: MeasuredGeometry, f_hz: Any, zeta: Any, shapes: Any,
                   dofs: Sequence[Mapping[str, Any]]) -> SceneModes:
    """Draw identified modes on a test geometry: each shape entry at its node and direction.

    ``dofs`` are the identify JSON's entries (``channel``, ``node_label``, ``direction``);
    a channel the bag's map places is put there, otherwise its ``node_label``.

    Raises
    ------
    ConfigError
        No shape entry at a node of the geometry.
    """
    row = {n: i for i, n in enumerate(tg.ids)}
    s = real_shapes(np.asarray(shapes))
    out = np.zeros((s.shape[1], len(tg.ids), 3))
    # channels at one node and direction are averaged, per mode: an entry not measured
    # (NaN, a mode some roving setups lacked) is left out of its mode
    count = np.zeros((s.shape[1], len(tg.ids), 3))
    placed = 0
    for k, d in enumerate(dofs):
        node, axis = tg.channel_nodes.get(str(d.get("channel", "")),
                                          (str(d.get("node_label", "")),
                                           str(d.get("direction", ""))))
        sign = -1.0 if axis.startswith("-") else 1.0
        a = _AXIS.get(axis.lstrip("+-"))
        if node in row and a is not None:
            ok = np.isfinite(s[k])
            out[ok, row[node], a] += sign * s[k, ok]
            count[ok, row[node], a] += 1
            placed += 1
    if placed == 0:
        msg = (f"none of the {len(dofs)} shape entries is at a node of the geometry "
               f"(nodes {tg.ids[:6]} ...)")
        raise ConfigError(msg)
    out /= np.maximum(count, 1)
    f, z = np.asarray(f_hz, float), np.asarray(zeta, float)
    labels = tuple(f"mode {k + 1}: {f[k]:.3f} Hz, zeta {100 * z[k]:.2f} % ({placed} of "
                   f"{len(dofs)} channels at nodes)" for k in range(f.size))
    return SceneModes(f, z, out, "identified", labels)
