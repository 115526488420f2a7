"""meshcat 3D scene of a structure: wireframe, sensors, devices, animated mode shapes.

The scene is a list of meshcat commands (``meshcat.commands``) built without a server, so
that it can be

* written as one static HTML page (:func:`static_html`: meshcat's viewer script inline and
  the commands as base64 msgpack, the same page meshcat's own server writes for
  ``Visualizer.static_html()``, here without starting any server), or
* sent to a running server (:mod:`modal_twin.viz.meshcat_server`).

Layout: copy 0 is the structure with its sensors (blue) and devices (green; blamed places
red); copies 1..n to its right (towards -y) are the model's lowest modes, each animated as
``x(t) = x0 + a phi sin(2 pi t / T)`` with ``a`` a fraction of the structure's size, and
labelled above it with its number, f and zeta (a text texture of the viewer,
:func:`label_object`). meshcat
animates transforms, not vertices, so every element is a unit segment whose position,
rotation and length follow its two end nodes. Frequency and damping of each mode (and the
blamed places with their family) are listed in an overlay of the HTML page. Instead of
modes, the copies can move through given node displacements (:class:`SceneMotion`: a
record's measured motion beside the twin's, with the sensors coloured by the residual).

Only ``meshcat.commands`` / ``meshcat.geometry`` / ``meshcat.animation`` are used (no
``meshcat.Visualizer``: it imports IPython and PIL), and never meshcat's ngrok tunnel.
"""

from __future__ import annotations

import base64
import html
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin._types import FloatArray, IntArray
from modal_twin.errors import ShapeError

__all__ = [
    "SceneModes",
    "StructureGeometry",
    "VertexAnimation",
    "building_geometry",
    "building_modes",
    "label_object",
    "lines_object",
    "mode_label",
    "scene_commands",
    "static_html",
]

ROOT_PATH = "/modal_twin"


@dataclass(frozen=True, slots=True)
class StructureGeometry:
    """Wireframe of a structure.

    Attributes
    ----------
    name : str
    node_xyz : (n_nodes, 3) float array
        Node coordinates, m.
    edges : (n_edges, 2) int array
        Node index pairs joined by an element.
    sensors : mapping name -> (3,) float array
        Sensor positions, m.
    devices : mapping name -> (3,) float array
        Device (isolator, damper) positions, m.
    """

    name: str
    node_xyz: FloatArray
    edges: IntArray
    sensors: Mapping[str, FloatArray] = field(default_factory=dict)
    devices: Mapping[str, FloatArray] = field(default_factory=dict)

    @property
    def size_m(self) -> float:
        """Largest extent of the structure, m."""
        return float(np.ptp(self.node_xyz, axis=0).max()) or 1.0


@dataclass(frozen=True, slots=True)
class SceneModes:
    """Mode shapes on the nodes of a :class:`StructureGeometry`.

    Attributes
    ----------
    f_hz, zeta : (n_modes,) float arrays
        Frequency (Hz) and damping ratio (fraction).
    shapes : (n_modes, n_nodes, 3) float array
        Node translations of each mode (any scale).
    source : str
        ``"model"`` or ``"identified"``.
    labels, colors : tuple
        Per mode, the caption line and the RGB colour of the moving copy (optional).
    """

    f_hz: FloatArray
    zeta: FloatArray
    shapes: FloatArray
    source: str = "model"
    labels: tuple[str, ...] = ()  # per mode, for the caption (default "mode k: f, zeta")
    colors: tuple[int, ...] = ()  # per mode, RGB (default orange)


@dataclass(frozen=True, slots=True)
class SceneMotion:
    """Copies of the structure moving through measured (or simulated) node displacements.

    Attributes
    ----------
    frames : (n_copies, n_frames, n_nodes, 3) float array
        Node displacements of each copy, m (drawn with one scale for all copies, so that
        their amplitudes compare).
    fps : float
        Frames per second of the animation.
    colors : tuple of int
        RGB colour of each moving copy.
    sensor_colors : mapping sensor -> RGB, optional
        Colour of each sensor of the structure at rest (e.g. by the residual there).
    """

    frames: FloatArray
    fps: float
    colors: tuple[int, ...] = ()
    sensor_colors: Mapping[str, int] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class VertexAnimation:
    """Moving copies animated by their node positions in the page's own script.

    meshcat animates transforms, so :func:`scene_commands` by default draws every element
    of a moving copy as its own segment with a clip of position, rotation and length per
    frame (about 80 bytes per element and frame in the page). With ``vertex_frames`` each
    moving copy is instead one line set, drawn once, whose vertices a small script of the
    static page (:func:`static_html`) moves through the copy's node positions, frame by
    frame: 12 bytes per node and frame. Not a meshcat command: a server
    (:func:`~modal_twin.viz.meshcat_server.send_commands`) shows such copies at rest.

    Attributes
    ----------
    paths : tuple of str
        meshcat path of each copy's line set.
    edges : (n_edges, 2) int array
        The structure's lines (node index pairs), the vertex order of every line set.
    positions : tuple of (n_frames, n_nodes, 3) float32 arrays
        Node positions of each copy per frame (rest + drawn displacement), m, in the
        copy's own frame.
    fps : float
        Frames per second.
    scale : float
        Drawn displacement per metre of the copies' displacement (NaN: modes, each scaled
        on its own).
    t0_s, dt_s : float
        Record time of the first frame and between frames, s (0 for modes).
    """

    paths: tuple[str, ...]
    edges: IntArray
    positions: tuple[FloatArray, ...]
    fps: float
    scale: float = float("nan")
    t0_s: float = 0.0
    dt_s: float = 0.0


def _edges_from_stiffness(K_full: Any) -> IntArray:
    """Node pairs coupled by the stiffness matrix (6 DOFs per node): the elements."""
    coo = K_full.tocoo()
    a, b = coo.row // 6, coo.col // 6
    keep = (a < b) & (coo.data != 0.0)
    pairs = np.unique(np.stack([a[keep], b[keep]], axis=1), axis=0)
    return pairs.astype(np.int64)


@lru_cache(maxsize=2)
def _building(resolved: str) -> Any:
    from modal_twin.models.building import build_building

    return build_building(resolved)


def building_geometry(structure_file: str | Path) -> StructureGeometry:
    """Wireframe, sensors and devices of a structure file (``config/structures/...``)."""
    bld = _building(str(Path(structure_file).resolve()))
    asm = bld.assembly
    idx = {n: i for i, n in enumerate(asm.nodes)}
    sensors = {s.name: asm.xyz[idx[s.node]] for s in bld.spec.sensors}
    devices = {d.name: asm.xyz[idx[d.node]] for d in bld.spec.devices}
    return StructureGeometry(bld.spec.name, asm.xyz.copy(), _edges_from_stiffness(asm.K_full),
                             sensors, devices)


def building_modes(structure_file: str | Path, n_modes: int = 6) -> SceneModes:
    """Return the lowest ``n_modes`` model modes of a structure file, on all its nodes."""
    from modal_twin.models.building import modal_reduction

    bld = _building(str(Path(structure_file).resolve()))
    red = modal_reduction(bld, max(n_modes, 1))
    full = bld.assembly.T @ red.Phi[:, :n_modes]  # every node, slaves included
    n_nodes = len(bld.assembly.nodes)
    shapes = np.asarray(full).reshape(n_nodes, 6, -1)[:, :3, :].transpose(2, 0, 1)
    return SceneModes(red.f_hz[:n_modes].copy(), red.zeta[:n_modes].copy(), shapes)


# -- meshcat commands ---------------------------------------------------------------------
def _quaternion_x_to(d: FloatArray) -> list[float]:
    """Quaternion ``[x, y, z, w]`` (three.js order) turning the x axis onto unit ``d``."""
    c = float(np.clip(d[0], -1.0, 1.0))
    axis = np.array([0.0, -d[2], d[1]])  # e_x cross d
    s = float(np.linalg.norm(axis))
    if s < 1e-12:
        return [0.0, 0.0, 0.0, 1.0] if c > 0 else [0.0, 0.0, 1.0, 0.0]
    half = 0.5 * np.arctan2(s, c)
    v = axis / s * np.sin(half)
    return [float(v[0]), float(v[1]), float(v[2]), float(np.cos(half))]


def _segment_pose(p1: FloatArray, p2: FloatArray) -> tuple[list[float], list[float], list[float]]:
    d = p2 - p1
    length = float(np.linalg.norm(d)) or 1e-9
    return [float(x) for x in p1], _quaternion_x_to(d / length), [length, 1.0, 1.0]


def lines_object(xyz: FloatArray, edges: IntArray, color: int, path: Any) -> Any:
    """Return the meshcat command drawing the ``edges`` between points ``xyz`` at ``path``."""
    import meshcat.commands as mc
    import meshcat.geometry as mg

    pts = xyz[edges.reshape(-1)].T.astype(np.float32)  # 3 x 2 m
    return mc.SetObject(mg.LineSegments(mg.PointsGeometry(pts), mg.LineBasicMaterial(
        color=color)), path=path)


def _dots(points: Mapping[str, FloatArray], radius: float, color: int, base: Any,
          ) -> list[Any]:
    import meshcat.commands as mc
    import meshcat.geometry as mg

    out = []
    for name, p in points.items():
        path = base.append(name)
        out.append(mc.SetObject(mg.Sphere(radius), mg.MeshLambertMaterial(color=color),
                                path=path))
        T = np.eye(4)
        T[:3, 3] = p
        out.append(mc.SetTransform(T, path=path))
    return out


def _moving_copy(geom: StructureGeometry, frames: FloatArray, base: Any, anim: Any,
                 color: int = 0xE4572E) -> list[Any]:
    """Draw a grey copy at rest and a coloured one moving through ``frames`` (k, nodes, 3)."""
    import meshcat.commands as mc
    import meshcat.geometry as mg
    from meshcat.animation import AnimationFrameVisualizer

    cmds: list[Any] = [lines_object(geom.node_xyz, geom.edges, 0xBBBBBB, base.append("rest"))]
    unit = mg.PointsGeometry(np.array([[0.0, 1.0], [0.0, 0.0], [0.0, 0.0]], np.float32))
    for e, (i, j) in enumerate(geom.edges):
        path = base.append("edges").append(f"e{e}")
        cmds.append(mc.SetObject(mg.LineSegments(unit, mg.LineBasicMaterial(color=color)),
                                 path=path))
        clip = AnimationFrameVisualizer(anim, path, 0).get_clip()
        for k, u in enumerate(frames):
            pos, quat, scale = _segment_pose(geom.node_xyz[i] + u[i], geom.node_xyz[j] + u[j])
            clip.set_property(k, "position", "vector3", pos)
            clip.set_property(k, "quaternion", "quaternion", quat)
            clip.set_property(k, "scale", "vector3", scale)
    return cmds


def _vertex_copy(geom: StructureGeometry, frames: FloatArray, base: Any, color: int
                 ) -> tuple[list[Any], str, Any]:
    """Draw a grey copy at rest and a coloured line set at frame 0 (:class:`VertexAnimation`).

    Returns the commands, the line set's path and its node positions per frame.
    """
    path = base.append("moving")
    pos = (geom.node_xyz[None] + frames).astype(np.float32)
    cmds = [lines_object(geom.node_xyz, geom.edges, 0xBBBBBB, base.append("rest")),
            lines_object(pos[0], geom.edges, color, path)]
    return cmds, str(path.lower()), pos


def mode_label(k: int, f_hz: float, zeta: float) -> str:
    """Return the label drawn above a mode's copy: ``mode 2: 3.46 Hz, zeta 1.2 %``."""
    return f"mode {k + 1}: {f_hz:.3g} Hz, \u03b6 {100 * zeta:.2g} %"


def label_object(text: str, width: float, center: FloatArray, path: Any) -> list[Any]:
    """Return the meshcat commands of a text label facing the default camera (+x).

    The viewer draws ``text`` on a 256 x 256 canvas texture (its ``_text`` texture, the font
    shrunk until the line fits) mapped on a thin square of side ``width`` centred at
    ``center``; the canvas is transparent around the letters.
    """
    import meshcat.commands as mc
    import meshcat.geometry as mg

    tex = mg.GenericTexture({"type": "_text", "text": text, "font_size": 48,
                             "font_face": "sans-serif"})
    board = mg.Box([1e-3 * width, width, width])
    cmds = [mc.SetObject(board, mg.MeshBasicMaterial(map=tex, transparent=True, side=0,
                                                     color=0xFFFFFF), path=path)]  # front
    # faces only: the far face would show the text mirrored through the transparent canvas
    T = np.eye(4)
    T[:3, :3] = [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]  # its v axis up (+z)
    T[:3, 3] = center
    cmds.append(mc.SetTransform(T, path=path))
    return cmds


def mode_frames(shape: FloatArray, amplitude: float, n_frames: int) -> FloatArray:
    """One period of ``a phi sin(2 pi k / n)``, k = 0..n, with ``max |a phi| = amplitude``."""
    peak = float(np.abs(shape).max()) or 1.0
    s = np.sin(2.0 * np.pi * np.arange(n_frames + 1) / n_frames)
    return s[:, None, None] * (shape * (amplitude / peak))[None]


def scene_commands(geom: StructureGeometry, modes: SceneModes | None = None, *,
                   blamed: Mapping[str, str] | None = None, n_frames: int = 24,
                   amplitude_fraction: float = 0.08, fps: int = 24,
                   motion: SceneMotion | None = None, vertex_frames: bool = False,
                   motion_times: tuple[float, float] = (0.0, 0.0)) -> list[Any]:
    """meshcat commands drawing the structure and (optionally) its animated modes.

    Parameters
    ----------
    geom : StructureGeometry
    modes : SceneModes, optional
        Each mode is drawn as its own animated copy to the right of the structure.
    blamed : mapping place -> family, optional
        Devices (or sensors) the diagnosis blames: drawn larger, in red.
    n_frames : int
        Frames per period of the animation (one period = ``n_frames / fps`` s).
    amplitude_fraction : float
        Largest displacement drawn, as a fraction of the structure's size.
    fps : int
        Frame rate of the animation.
    motion : SceneMotion, optional
        Instead of modes: copies moving through given displacements (scaled together so
        that the largest is ``amplitude_fraction`` of the size), sensors coloured.
    vertex_frames : bool
        Moving copies as line sets moved by the static page's script
        (:class:`VertexAnimation`, the last item) instead of meshcat's animation of
        one segment per element: a page a fraction of the size, for :func:`static_html`
        only.
    motion_times : (float, float)
        Record time of the motion's first frame and between frames, s (kept in the
        :class:`VertexAnimation`).

    Returns
    -------
    list of meshcat commands
        The last one is the ``SetAnimation`` (or the :class:`VertexAnimation`) when
        copies move.

    Raises
    ------
    ShapeError
        Mode shapes that do not have one row per node.
    """
    import meshcat.animation as ma
    import meshcat.commands as mc
    from meshcat.path import Path as MPath

    blamed = dict(blamed or {})
    root = MPath(tuple(p for p in ROOT_PATH.split("/") if p))
    size = geom.size_m
    copies = _copies(geom, modes, motion, amplitude_fraction * size, n_frames)
    n_modes = len(copies)
    lo, hi = geom.node_xyz.min(axis=0), geom.node_xyz.max(axis=0)
    # copies in rows of up to four, side by side along -y, rows downwards (-z); the default
    # camera looks along -x from +x, y to the left: scale the whole scene into a few metres
    step = 1.4 * float(hi[1] - lo[1]) + 0.3 * size
    zstep = 1.3 * float(hi[2] - lo[2]) + 0.3 * size

    def layout(cols: int) -> tuple[float, int]:  # scale, rows
        rows = -(-(n_modes + 1) // cols)
        w = step * (cols - 1) + float(hi[1] - lo[1])
        h = zstep * (rows - 1) + float(hi[2] - lo[2])
        return min(5.5 / max(w, 2.0 * h), 2.5 / max(float(hi[0] - lo[0]), 1e-9)), rows

    cols = max(range(1, min(n_modes + 1, 4) + 1), key=lambda c: layout(c)[0])
    s, rows = layout(cols)
    T = np.diag([s, s, s, 1.0])
    T[:3, 3] = -s * np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1] - step * (cols - 1)) / 2,
                              (lo[2] + hi[2] - zstep * (rows - 1)) / 2])
    T[2, 3] -= 0.35  # below the caption
    cam = mc.SetProperty("position", [3.2, 0.6, 0.0],
                         MPath(("Cameras", "default", "rotated", "<object>")))
    cmds: list[Any] = [mc.Delete(root), mc.SetTransform(T, path=root), cam]
    base = root.append("structure")
    cmds.append(lines_object(geom.node_xyz, geom.edges, 0x333333, base.append("frame")))
    r = 0.012 * size
    tint = {} if motion is None else dict(motion.sensor_colors)
    plain = {k: v for k, v in geom.sensors.items() if k not in blamed and k not in tint}
    cmds += _dots(plain, r, 0x1F77B4, base.append("sensors"))
    for k, c in tint.items():
        if k in geom.sensors and k not in blamed:
            cmds += _dots({k: geom.sensors[k]}, 1.5 * r, c, base.append("sensors"))
    cmds += _dots({k: v for k, v in geom.devices.items() if k not in blamed}, 1.5 * r,
                  0x2CA02C if motion is None else 0x666666,  # green means "agrees" there
                  base.append("devices"))
    places = {**geom.sensors, **geom.devices}
    cmds += _dots({k: places[k] for k in blamed if k in places}, 3.0 * r, 0xD62728,
                  base.append("blamed"))
    if not copies:
        return cmds
    anim = ma.Animation(default_framerate=round(motion.fps) if motion is not None else fps)
    paths, positions = [], []
    for m, (frames, color) in enumerate(copies):
        mbase = root.append(f"mode_{m + 1}")
        shift = np.eye(4)
        shift[1, 3], shift[2, 3] = -step * ((m + 1) % cols), -zstep * ((m + 1) // cols)
        cmds.append(mc.SetTransform(shift, path=mbase))
        if vertex_frames:
            more, path, pos = _vertex_copy(geom, frames, mbase, color)
            cmds += more
            paths.append(path)
            positions.append(pos)
        else:
            cmds += _moving_copy(geom, frames, mbase, anim, color)
        if modes is not None and motion is None:
            w = max(1.2 * float(hi[1] - lo[1]), 0.4 * size)
            top = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, hi[2] + 0.18 * w])
            cmds += label_object(mode_label(m, float(modes.f_hz[m]), float(modes.zeta[m])),
                                 w, top, mbase.append("label"))
    if vertex_frames:
        peak = float(np.abs(motion.frames).max()) if motion is not None else 0.0
        cmds.append(VertexAnimation(
            tuple(paths), np.asarray(geom.edges, dtype=np.int64), tuple(positions),
            float(motion.fps if motion is not None else fps),
            amplitude_fraction * size / peak if peak > 0 else float("nan"), *motion_times))
        return cmds
    cmds.append(mc.SetAnimation(anim, play=True, repetitions=100000))
    return cmds


def _copies(geom: StructureGeometry, modes: SceneModes | None, motion: SceneMotion | None,
            amplitude: float, n_frames: int) -> list[tuple[FloatArray, int]]:
    """(frames, colour) of every moving copy, scaled for drawing."""
    n_nodes = geom.node_xyz.shape[0]
    if motion is not None:
        f = np.asarray(motion.frames, float)
        if f.ndim != 4 or f.shape[2:] != (n_nodes, 3):
            msg = (f"motion.frames: expected (copy, frame, {n_nodes}, 3), got {f.shape}")
            raise ShapeError(msg)
        f = f * (amplitude / (float(np.abs(f).max()) or 1.0))
        return [(f[c], motion.colors[c] if c < len(motion.colors) else 0xE4572E)
                for c in range(f.shape[0])]
    if modes is None:
        return []
    n_modes = int(modes.f_hz.size)
    if modes.shapes.shape != (n_modes, n_nodes, 3):
        msg = (f"modes.shapes: expected ({n_modes}, {n_nodes}, 3) "
               f"(mode, node, xyz), got {modes.shapes.shape}")
        raise ShapeError(msg)
    return [(mode_frames(modes.shapes[m], amplitude, n_frames),
             modes.colors[m] if m < len(modes.colors) else 0xE4572E) for m in range(n_modes)]


# -- static HTML --------------------------------------------------------------------------
def _viewer_js() -> str:
    import meshcat

    return (Path(meshcat.__file__).parent / "viewer" / "dist" / "main.min.js").read_text()


def _command_js(cmd: Any) -> str:
    import umsgpack

    data = base64.b64encode(umsgpack.packb(cmd.lower())).decode()
    return (f'fetch("data:application/octet-binary;base64,{data}")'
            ".then(r => r.arrayBuffer())"
            ".then(b => viewer.handle_command_bytearray(new Uint8Array(b)));\n")


def overlay_html(geom: StructureGeometry, modes: SceneModes | None,
                 blamed: Mapping[str, str] | None = None) -> str:
    """Return the caption of the scene: modes with f and zeta, blamed places with their family."""
    items = [f"<b>{html.escape(geom.name)}</b>: structure at the right (sensors blue, "
             "devices green), modes from right to left"]
    if modes is not None and modes.labels:
        items += [html.escape(x) for x in modes.labels]
    elif modes is not None:
        items += [f"mode {k + 1}: {f:.3f} Hz, &zeta; {100 * z:.2f} %"
                  for k, (f, z) in enumerate(zip(modes.f_hz, modes.zeta, strict=True))]
    for place, family in (blamed or {}).items():
        items.append(f'<span style="color:#d62728">blamed: {html.escape(place)} '
                     f"({html.escape(family)})</span>")
    return caption_html(items)


def caption_html(items: Sequence[str]) -> str:
    """Return the caption box of a scene: one line per item (HTML, escaped by the caller)."""
    return ('<div id="caption" style="position:absolute;top:8px;left:8px;font:13px sans-serif;'
            'background:rgba(255,255,255,0.85);padding:6px 8px;border-radius:4px">'
            + "<br>".join(items) + "</div>")


def static_html(commands: Sequence[Any], *, caption: str = "", title: str = "modal_twin scene"
                ) -> str:
    """One self-contained HTML page showing the scene (no server, no network).

    The page sets ``document.body.dataset.sceneCommands`` to the number of commands it
    handled (a marker for headless checks).
    """
    cmds = "".join(_command_js(c) for c in commands if not isinstance(c, VertexAnimation))
    vertex = [c for c in commands if isinstance(c, VertexAnimation)][-1:]  # one at most
    data = "".join('<script type="application/json" id="modal-twin-frames">'
                   + vertex_frames_json(v).replace("</", "<\\/") + "</script>" for v in vertex)
    cmds += _VERTEX_JS if vertex else ""
    return f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>body {{margin: 0;}} #meshcat-pane {{width: 100vw; height: 100vh; overflow: hidden;}}
</style></head>
<body><div id="meshcat-pane"></div>{caption}{data}
<script>{_viewer_js()}</script>
<script>
var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
{cmds}
document.body.dataset.sceneCommands = "{len(commands)}";
</script></body></html>
"""


def _b64(a: Any, dtype: Any) -> str:
    return base64.b64encode(np.ascontiguousarray(a, dtype=dtype).tobytes()).decode()


def vertex_frames_json(anim: VertexAnimation) -> str:
    """Return the frame data a static page carries for ``anim`` (JSON).

    ``{"fps", "scale", "t0_s", "dt_s", "n_frames", "n_nodes", "edges": base64 int32
    (n_edges, 2), "copies": [{"path", "positions": base64 float32 (n_frames, n_nodes,
    3)}]}`` (little-endian, row-major).
    """
    import json

    first = anim.positions[0] if anim.positions else np.zeros((0, 0, 3))
    doc = {"fps": anim.fps, "scale": None if np.isnan(anim.scale) else anim.scale,
           "t0_s": anim.t0_s, "dt_s": anim.dt_s, "n_frames": int(first.shape[0]),
           "n_nodes": int(first.shape[1]), "edges": _b64(anim.edges, "<i4"),
           "copies": [{"path": p, "positions": _b64(x, "<f4")}
                      for p, x in zip(anim.paths, anim.positions, strict=True)]}
    return json.dumps(doc)


_VERTEX_JS = """
(function () {
  const doc = JSON.parse(document.getElementById("modal-twin-frames").textContent);
  const raw = (s) => Uint8Array.from(atob(s), (c) => c.charCodeAt(0)).buffer;
  const edges = new Int32Array(raw(doc.edges));
  const copies = doc.copies.map((c) => ({path: c.path.split("/").filter((p) => p.length),
                                         pos: new Float32Array(raw(c.positions))}));
  const per = 3 * doc.n_nodes;
  let start = null, shown = -1;
  function tick(now) {
    if (start === null) start = now;
    const k = Math.floor((now - start) / 1000 * doc.fps) % doc.n_frames;
    if (k !== shown) {
      let found = 0;
      for (const c of copies) {
        const obj = viewer.scene_tree.find(c.path.concat(["<object>"])).object;
        const attr = obj && obj.geometry && obj.geometry.attributes.position;
        if (!attr) continue;
        const a = attr.array, off = k * per;
        for (let e = 0; e < edges.length; e++) {
          const n = off + 3 * edges[e];
          a[3 * e] = c.pos[n]; a[3 * e + 1] = c.pos[n + 1]; a[3 * e + 2] = c.pos[n + 2];
        }
        attr.needsUpdate = true;
        found++;
      }
      if (found === copies.length) {
        shown = k;
        document.body.dataset.vertexCopies = String(found);
        viewer.set_dirty();
      }
    }
    requestAnimationFrame(tick);
  }
  requestAnimationFrame(tick);
})();
"""

