"""Live view: the structure with each sensor coloured by the twin's residual there.

From the display samples (:mod:`modal_twin.viz.display`) of the measurement and of the twin,
each sensor's colour says how far the twin is from the measurement at it: the RMS of
(measured - twin) over the last ``window`` display samples against the RMS of the measured
signal, per sensor the worst of its axes (green: agrees, yellow: 10 %, red: 30 % or more).
The colours are meshcat commands (:class:`LiveResidual`); the node sends them to a server
it started on 127.0.0.1. Over the structure at rest, the latest measured (blue) and twin
(orange) deflected shapes are drawn overlaid (:meth:`LiveResidual.deflections`): each
display sample of the sensors expanded onto every node with the model's modes (SEREP), the
two scaled alike so that the largest measured deflection of the window is 8 % of the
structure's size. The display samples are window means of the sensors' accelerations, so
the shapes are acceleration-weighted (higher modes show more than in displacements).
"""

from __future__ import annotations

import itertools
from collections import deque
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.viz.display import DisplaySamples

__all__ = ["LiveResidual", "LiveView", "residual_colour"]

_SHAPE_COLOURS = {"measured": 0x1F77B4, "twin": 0xE4572E}

_STOPS = ((0.0, (0x2C, 0xA0, 0x2C)), (0.1, (0xF0, 0xC0, 0x20)), (0.3, (0xD6, 0x27, 0x28)))


def residual_colour(relative: float) -> int:
    """RGB colour of a relative residual: green at 0, yellow at 0.1, red from 0.3 on."""
    r = float(relative) if np.isfinite(relative) else _STOPS[-1][0]
    for (x0, c0), (x1, c1) in itertools.pairwise(_STOPS):
        if r <= x1:
            w = max(0.0, (r - x0) / (x1 - x0))
            rgb = [round(a + w * (b - a)) for a, b in zip(c0, c1, strict=True)]
            return (rgb[0] << 16) | (rgb[1] << 8) | rgb[2]
    c = _STOPS[-1][1]
    return (c[0] << 16) | (c[1] << 8) | c[2]


class LiveResidual:
    """Relative residual per sensor over the last ``window`` display samples.

    Parameters
    ----------
    sensors : mapping name -> (3,) position, m
        The structure's sensors (:class:`~modal_twin.viz.scene.StructureGeometry`).
    window : int
        Display samples the RMS values are taken over.
    """

    def __init__(self, sensors: Mapping[str, FloatArray], window: int = 40) -> None:
        self.sensors = dict(sensors)
        self._meas: deque[dict[str, float]] = deque(maxlen=window)
        self._twin: deque[dict[str, float]] = deque(maxlen=window)

    def push(self, measured: DisplaySamples | None, twin: DisplaySamples | None) -> None:
        """Add the display samples of either stream (the latest of each is paired)."""
        for samples, buf in ((measured, self._meas), (twin, self._twin)):
            if samples is None or samples.values.shape[1] == 0:
                continue
            for k in range(samples.values.shape[1]):
                buf.append(dict(zip(samples.channel_names, samples.values[:, k],
                                    strict=True)))

    def _paired(self) -> tuple[list[str], FloatArray, FloatArray] | None:
        """Sensor channels both streams carry, measured and twin (n_ch, n) paired samples."""
        n = min(len(self._meas), len(self._twin))
        if n == 0:
            return None
        meas, twin = list(self._meas)[-n:], list(self._twin)[-n:]
        chans = [c for c in meas[0] if c in twin[0] and c.rpartition("_")[0] in self.sensors
                 and c.rpartition("_")[2] in ("x", "y", "z")]
        if not chans:
            return None
        return (chans, np.array([[s[c] for c in chans] for s in meas]).T,
                np.array([[s[c] for c in chans] for s in twin]).T)

    def relative(self) -> dict[str, float]:
        """Sensor -> RMS(measured - twin) / RMS(measured), worst axis (paired samples)."""
        from modal_twin.viz.motion import nrmse_per_sensor

        paired = self._paired()
        return {} if paired is None else nrmse_per_sensor(*paired)

    def deflections(self, node_xyz: FloatArray, basis_shapes: FloatArray
                    ) -> tuple[FloatArray, FloatArray] | None:
        """Latest measured and twin node deflections (n_nodes, 3), scaled alike.

        The paired display samples of every sensor channel both streams carry are expanded
        with the model's modes ``basis_shapes`` (k, n_nodes, 3) (SEREP); the scale makes
        the largest measured deflection of the window 1. None before both streams have a
        sample at a sensor.
        """
        from modal_twin.viz.mode_pairs import channel_nodes, expand_shapes, sampled_shapes

        paired = self._paired()
        if paired is None:
            return None
        chans, m, t = paired
        at_ch = sampled_shapes(basis_shapes, channel_nodes(chans, node_xyz, self.sensors))
        um = expand_shapes(m, at_ch, basis_shapes)  # (n, n_nodes, 3)
        ut = expand_shapes(t[:, -1:], at_ch, basis_shapes)[0]
        peak = float(np.abs(um).max()) or 1.0
        return um[-1] / peak, ut / peak

    def shape_commands(self, node_xyz: FloatArray, edges: Any, basis_shapes: FloatArray,
                       amplitude: float) -> Sequence[Any]:
        """meshcat commands drawing the latest measured and twin deflections overlaid."""
        from meshcat.path import Path as MPath

        from modal_twin.viz.scene import lines_object

        shapes = self.deflections(node_xyz, basis_shapes)
        if shapes is None:
            return []
        return [lines_object(node_xyz + amplitude * u, np.asarray(edges), colour,
                             MPath(("modal_twin", "live", f"{name}_shape")))
                for (name, colour), u in zip(_SHAPE_COLOURS.items(), shapes, strict=True)]

    def commands(self, radius: float) -> Sequence[Any]:
        """meshcat commands colouring each compared sensor (spheres at its position)."""
        import meshcat.commands as mc
        import meshcat.geometry as mg
        from meshcat.path import Path as MPath

        cmds: list[Any] = []
        for sensor, rel in self.relative().items():
            path = MPath(("modal_twin", "live", sensor))  # under the scene's root
            cmds.append(mc.SetObject(mg.Sphere(radius), mg.MeshLambertMaterial(
                color=residual_colour(rel)), path=path))
            T = np.eye(4)
            T[:3, 3] = self.sensors[sensor]
            cmds.append(mc.SetTransform(T, path=path))
        return cmds


class LiveView:
    """A meshcat server (127.0.0.1, by PID) showing the structure and :class:`LiveResidual`.

    Raises
    ------
    ModalTwinError
        The port is in use, or the structure does not load.
    """

    def __init__(self, model_file: str, web_port: int = 7000) -> None:
        from modal_twin.models.versions import read_version
        from modal_twin.paths import resolve_config
        from modal_twin.viz.meshcat_server import MeshcatServer, send_commands
        from modal_twin.viz.scene import building_geometry, building_modes, scene_commands

        structure = read_version(resolve_config(model_file)).structure
        geom = building_geometry(structure)
        self.residual = LiveResidual(geom.sensors)
        self._geom, self._basis = geom, building_modes(structure, 12).shapes
        self._radius = 0.02 * geom.size_m
        self._server = MeshcatServer(zmq_port=web_port - 1000, web_port=web_port).start()
        self._send = send_commands
        self.url = self._server.web_url
        send_commands(self._server.zmq_url, scene_commands(geom))

    def push(self, samples: DisplaySamples, *, twin: bool) -> None:
        """Add display samples of the measurement or of the twin."""
        self.residual.push(None if twin else samples, samples if twin else None)

    def refresh(self) -> None:
        """Send the current colours."""
        g = self._geom
        cmds = [*self.residual.commands(self._radius),
                *self.residual.shape_commands(g.node_xyz, g.edges, self._basis, 0.08 * g.size_m)]
        if cmds:
            self._send(self._server.zmq_url, cmds)

    def close(self) -> None:
        """Stop the server."""
        self._server.stop()
