"""Independent truth of the base-isolated building, written from the structure file alone.

Nothing here comes from the library: ``config/structures/building.yaml`` is read with
``yaml.safe_load`` and the structure assembled by this module's own code. What is modelled
is what the file states (and the library's building models, ``modal_twin.models.building``),
so that a hidden effect is the main difference between the two; the form is not:

* **Frames** (3D, Euler-Bernoulli, or Timoshenko where the section gives shear areas
  ``Asy`` / ``Asz``): no 12 x 12 closed-form matrix. The end-2 stiffness is the inverse of
  the FLEXIBILITY of a cantilever clamped at end 1 (local axes; loads ``N, V_2, V_3, T,
  M_2, M_3`` at the tip)::

      u_1 = N L / EA,   th_1 = T L / GJ,
      u_2 = V_2 (L^3 / 3EI_3 + L / G A_s2) + M_3 L^2 / 2EI_3,
      th_3 = V_2 L^2 / 2EI_3 + M_3 L / EI_3,
      u_3 = V_3 (L^3 / 3EI_2 + L / G A_s3) - M_2 L^2 / 2EI_2,
      th_2 = -V_3 L^2 / 2EI_2 + M_2 L / EI_2,

  (Timoshenko's shear deflection ``V L / G A_s``; Przemieniecki, *Theory of Matrix
  Structural Analysis*, Sec. 5.6, derives the stiffness the same way), rotated to global
  axes (``k_22 = T' F^-1 T``), and the element matrix follows from EQUILIBRIUM with the
  rigid-body transfer of end 1 to end 2 (``d = x_2 - x_1``)::

      delta = a_2 - R a_1,   R = [[I, -S(d)], [0, I]],   K_e = D' k_22 D,   D = [-R, I]

  (``a``: the six global displacements and rotations of a node; ``S(d) w = d x w``).
  Local axes as the file states: member axis ``e_1``; ``e_2`` = global X for a vertical
  member (column), global Z otherwise (beam); ``e_3 = e_1 x e_2``. ``I_3`` is the file's
  ``Iz`` (bending with deflection along ``e_2``, shear area ``Asy``), ``I_2`` its ``Iy``
  (deflection along ``e_3``, ``Asz``); ``G = E / 2 (1 + nu)``. The file's materials carry no
  density: the frames are massless (a density is refused, not modelled). A frame with
  ``via`` nodes is one element between consecutive nodes.
* **Rigid floors** (``diaphragms``): each floor moves in its plane as a rigid body with
  three coordinates ``(U_x, U_y, R_z)`` at the PLAN CENTROID of its nodes (not the file's
  master node); a node ``(x, y)`` of the floor then has ``u_x = U_x - R_z (y - y_c)``, ``u_y
  = U_y + R_z (x - x_c)``, ``r_z = R_z``; its ``u_z, r_x, r_y`` stay its own.
* **Masses**: the listed point masses act on the node's three translations (rotary inertia
  where ``inertia`` is given). Coordinates without mass (the nodes' ``r_x, r_y``) are
  condensed out STATICALLY (exact: they carry neither mass nor damping), the eigenproblem is
  solved densely on the rest (``scipy.linalg.eigh``), not as a shifted sparse eigenproblem.
* **Isolators**: each device a spring ``(k_x, k_y, k_z)`` and dashpot ``(c_x, c_y)`` from its
  node to the table (no rotational stiffness: the bearings act as pins), Eq. (1) of [004].
* **Base input**: the table's six accelerations at ``input.origin`` move every node
  rigidly (``a + alpha x (x - o)``, rotations ``alpha``); the structure is written in
  coordinates relative to that motion (Eq. (12) of [004]).
* **Damping** as the file states (Sec. 6 of [004]): the device dashpots projected on the
  modes (non-classical); modes from ``n_isolation_modes`` on get added modal damping
  ``max(0, zeta_target - zeta_dev)`` with the targets ``superstructure_zeta`` then
  ``default_zeta``.
* **Reduction**: the ``reduction.n_modes`` lowest modes of the condensed model (36), the
  file's modal superposition; integrated by the truths' sub-stepped RK4 (:mod:`.integrate`).

The device laws of :mod:`.laws` replace a device's linear spring and dashpot as in
:mod:`.building`; YAML edits (a weaker column line or storey, added masses) as there
(:func:`weaken_columns`, :func:`add_masses`, written here again on the document).

Channels, names and order as :mod:`.building`: the sensors' absolute accelerations
``<sensor>_<x|y|z>``, every device's drift ``<dev>_dx, _dy`` then its force ``<dev>_fx,
_fy`` (spring + dashpot, or the law's force).

Checked against the library's linear model in ``test/diagnosis/test_building_own_truth.py``
(natural frequencies, the response to a short table motion).
"""

from __future__ import annotations

import copy
import itertools
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml
from scipy.linalg import cho_factor, cho_solve, eigh

from .integrate import Attached, RunResult, run_rk4
from .laws import Law

FloatArray = np.ndarray
ROOT = Path(__file__).resolve().parents[3]
BUILDING_YAML = ROOT / "config" / "structures" / "building.yaml"
INPUTS = ("ax", "ay", "az", "arx", "ary", "arz")

Edit = Callable[[dict], dict]


# ----------------------------------------------------------------------------- edits
def _grid(node: str) -> str:
    """Grid point of a node id ``<floor>_<grid>``."""
    return node.partition("_")[2]


def weaken_columns(which: Callable[[str, str], bool], factor: float) -> Edit:
    """Document edit: the columns (members joining two floors at one grid point, no ``via``)
    for which ``which(n1, n2)`` holds get their modulus times ``factor`` (the shear modulus
    follows through the fixed Poisson ratio)."""

    def edit(doc: dict) -> dict:
        out = copy.deepcopy(doc)
        mats = out["materials"]
        for member in out["frames"]:
            a, b = member["n1"], member["n2"]
            if member.get("via") or _grid(a) != _grid(b) or not which(a, b):
                continue
            weak = f"{member['material']}*{factor!r}"
            mats.setdefault(weak, dict(mats[member["material"]],
                                       E=mats[member["material"]]["E"] * factor))
            mats[weak].pop("param", None)
            member["material"] = weak
        return out

    return edit


def add_masses(items: list[tuple[str, float]]) -> Edit:
    """Document edit: point masses ``(node, kg)`` added to the file's masses."""

    def edit(doc: dict) -> dict:
        out = copy.deepcopy(doc)
        out["masses"] = [*out["masses"], *({"m": float(m), "nodes": [n]} for n, m in items)]
        return out

    return edit


# ----------------------------------------------------------------------------- frames
def _skew(d: FloatArray) -> FloatArray:
    """``S(d)`` with ``S(d) w = d x w``."""
    return np.array([[0.0, -d[2], d[1]], [d[2], 0.0, -d[0]], [-d[1], d[0], 0.0]])


def member_axes(x1: FloatArray, x2: FloatArray) -> tuple[FloatArray, float]:
    """Rows ``e_1, e_2, e_3`` of the member's local axes (module docstring) and its length."""
    d = x2 - x1
    length = float(np.sqrt(d @ d))
    e1 = d / length
    ref = np.array([1.0, 0.0, 0.0]) if abs(e1[2]) > 0.999999 else np.array([0.0, 0.0, 1.0])
    e3 = np.cross(e1, ref)
    e3 /= np.sqrt(e3 @ e3)
    return np.vstack([e1, np.cross(e3, e1), e3]), length


def cantilever_flexibility(*, E: float, G: float, A: float, I2: float, I3: float, J: float,
                           L: float, As2: float | None, As3: float | None) -> FloatArray:
    """6 x 6 tip flexibility of a cantilever in local axes (module docstring), order
    ``(u_1, u_2, u_3, th_1, th_2, th_3)`` against ``(N, V_2, V_3, T, M_2, M_3)``."""
    F = np.zeros((6, 6))
    F[0, 0] = L / (E * A)
    F[3, 3] = L / (G * J)
    shear2 = 0.0 if As2 is None else L / (G * As2)
    shear3 = 0.0 if As3 is None else L / (G * As3)
    F[1, 1] = L**3 / (3.0 * E * I3) + shear2
    F[1, 5] = F[5, 1] = L**2 / (2.0 * E * I3)
    F[5, 5] = L / (E * I3)
    F[2, 2] = L**3 / (3.0 * E * I2) + shear3
    F[2, 4] = F[4, 2] = -(L**2) / (2.0 * E * I2)
    F[4, 4] = L / (E * I2)
    return F


def member_stiffness(x1: FloatArray, x2: FloatArray, mat: Mapping, sec: Mapping) -> FloatArray:
    """12 x 12 global stiffness of a member from its cantilever flexibility and the
    rigid-body transfer of end 1 to end 2 (module docstring)."""
    r, L = member_axes(x1, x2)
    E = float(mat["E"])
    G = float(mat["G"]) if "G" in mat else E / (2.0 * (1.0 + float(mat["nu"])))
    F = cantilever_flexibility(E=E, G=G, A=sec["A"], I2=sec["Iy"], I3=sec["Iz"], J=sec["J"],
                               L=L, As2=sec.get("Asy"), As3=sec.get("Asz"))
    T = np.kron(np.eye(2), r)
    k22 = T.T @ np.linalg.inv(F) @ T
    R = np.eye(6)
    R[:3, 3:] = -_skew(x2 - x1)
    D = np.hstack([-R, np.eye(6)])
    k = D.T @ k22 @ D
    return 0.5 * (k + k.T)


# ----------------------------------------------------------------------------- model
@dataclass
class _Structure:
    """The assembled, condensed linear structure (massed coordinates only)."""

    K: FloatArray  # condensed stiffness
    M: FloatArray
    C: FloatArray  # device dashpots
    P: FloatArray  # (n, 6) rigid motion for unit table accelerations
    node_rows: dict[str, FloatArray]  # node -> (6, n) its global DOFs from the coordinates
    devices: list[dict]
    damping: dict
    n_modes: int
    sensors: list[tuple[str, str, str]]  # (channel, node, direction)
    gravity: float


def _coordinates(doc: dict) -> tuple[dict[str, FloatArray], int]:
    """Map every node's six global DOFs onto the generalised coordinates (floors first:
    ``U_x, U_y, R_z`` at each floor's plan centroid; then each node's own DOFs)."""
    xyz = {n: np.asarray(v, dtype=float) for n, v in doc["nodes"].items()}
    floor_of: dict[str, int] = {}
    centroids = []
    for f, fl in enumerate(doc.get("diaphragms") or []):
        members = list(dict.fromkeys([fl["master"], *fl["nodes"]]))
        centroids.append(np.mean([xyz[n][:2] for n in members], axis=0))
        for n in members:
            floor_of[n] = f
    n = 3 * len(centroids)
    own: dict[str, list[int]] = {}
    for node in xyz:
        k = 3 if node in floor_of else 6
        own[node] = list(range(n, n + k))
        n += k
    rows = {}
    for node, x in xyz.items():
        A = np.zeros((6, n))
        if node in floor_of:
            f = floor_of[node]
            dx, dy = x[:2] - centroids[f]
            ux, uy, rz = 3 * f, 3 * f + 1, 3 * f + 2
            A[0, ux], A[0, rz] = 1.0, -dy
            A[1, uy], A[1, rz] = 1.0, dx
            A[5, rz] = 1.0
            for j, c in zip((2, 3, 4), own[node], strict=True):
                A[j, c] = 1.0
        else:
            A[np.arange(6), own[node]] = 1.0
        rows[node] = A
    return rows, n


def _assemble(doc: dict) -> _Structure:
    rows, n = _coordinates(doc)
    xyz = {k: np.asarray(v, dtype=float) for k, v in doc["nodes"].items()}
    K, M, C = np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))
    mats, secs = doc.get("materials", {}), doc.get("sections", {})
    for fr in doc.get("frames", []):
        mat, sec = mats[fr["material"]], secs[fr["section"]]
        if float(mat.get("rho", 0.0)) != 0.0:
            msg = f"material {fr['material']}: a density is not modelled here"
            raise ValueError(msg)
        chain = [fr["n1"], *fr.get("via", []), fr["n2"]]
        for a, b in itertools.pairwise(chain):
            Ae = np.vstack([rows[a], rows[b]])
            K += Ae.T @ member_stiffness(xyz[a], xyz[b], mat, sec) @ Ae
    for entry in doc["masses"]:
        targets = entry["nodes"] if "nodes" in entry else [entry["node"]]
        m6 = np.diag([float(entry["m"])] * 3 + list(entry.get("inertia", [0.0] * 3)))
        for node in targets:
            M += rows[node].T @ m6 @ rows[node]
    for dev in doc["devices"]:
        A = rows[dev["node"]]
        K += A.T @ np.diag([*dev["k"], dev.get("kz", 0.0), 0.0, 0.0, 0.0]) @ A
        C += A.T @ np.diag([*dev["c"], 0.0, 0.0, 0.0, 0.0]) @ A
    o = np.asarray(doc["input"]["origin"], dtype=float)
    # the rigid motion of a unit table acceleration in the coordinates: every node's six
    # DOFs at a + alpha x (x - o), alpha (exactly representable: floors move rigidly)
    A_all = np.vstack([rows[k] for k in xyz])
    g_all = np.vstack([np.vstack([np.concatenate([np.eye(6)[j, :3] + np.cross(
        np.eye(6)[j, 3:], x - o), np.eye(6)[j, 3:]]) for j in range(6)]).T for x in xyz.values()])
    P = np.linalg.lstsq(A_all, g_all, rcond=None)[0]
    if not np.allclose(A_all @ P, g_all, atol=1e-9 * max(1.0, float(np.abs(g_all).max()))):
        msg = "the table's rigid motion is not a motion of the coordinates"
        raise ValueError(msg)
    massed = np.flatnonzero(np.diag(M) > 0.0)
    free = np.flatnonzero(np.diag(M) <= 0.0)
    if np.any(C[np.ix_(free, free)] != 0.0) or np.any(C[np.ix_(massed, free)] != 0.0):
        msg = "damping on a massless coordinate: static condensation not exact"
        raise ValueError(msg)
    # static condensation of the massless coordinates: x_s = -K_ss^-1 K_sm x_m
    cho = cho_factor(K[np.ix_(free, free)])
    back = -cho_solve(cho, K[np.ix_(free, massed)])
    expand = np.zeros((n, massed.size))
    expand[massed, np.arange(massed.size)] = 1.0
    expand[free] = back
    Kc = K[np.ix_(massed, massed)] + K[np.ix_(massed, free)] @ back
    sensors = [(f"{s['name']}_{d}", s["node"], d) for s in doc["sensors"]
               for d in s.get("directions", ["x", "y", "z"])]
    return _Structure(
        K=0.5 * (Kc + Kc.T), M=M[np.ix_(massed, massed)], C=C[np.ix_(massed, massed)],
        P=P[massed], node_rows={k: A @ expand for k, A in rows.items()},
        devices=list(doc["devices"]), damping=dict(doc.get("damping") or {}),
        n_modes=int((doc.get("reduction") or {}).get("n_modes", massed.size)),
        sensors=sensors, gravity=float(doc.get("gravity", 9.80665)))


@dataclass
class BuildingOwn:
    """The building with truth laws at some devices and optional document edits.

    Parameters
    ----------
    laws : mapping device -> Law
        Devices whose nominal linear spring-dashpot the law replaces.
    edits : list of document edits (:func:`weaken_columns`, :func:`add_masses`)
    structure_file : Path
    n_modes : int, optional
        Modes kept (default: the file's ``reduction.n_modes``).
    """

    laws: Mapping[str, Law] = field(default_factory=dict)
    edits: list[Edit] = field(default_factory=list)
    structure_file: Path = BUILDING_YAML
    n_modes: int | None = None

    def __post_init__(self) -> None:
        doc = yaml.safe_load(self.structure_file.read_text(encoding="utf-8"))
        for e in self.edits:
            doc = e(doc)
        unknown = set(doc.get("damping") or {}) - {
            "n_isolation_modes", "superstructure_zeta", "default_zeta", "param"}
        if unknown:
            msg = f"damping keys not modelled here: {sorted(unknown)}"
            raise ValueError(msg)
        s = self.structure = _assemble(doc)
        self.device_names = tuple(d["name"] for d in s.devices)
        self.k_dev = np.array([d["k"] for d in s.devices], dtype=float)
        self.c_dev = np.array([d["c"] for d in s.devices], dtype=float)
        r = s.n_modes if self.n_modes is None else self.n_modes
        lam, V = eigh(s.K, s.M, subset_by_index=[0, r - 1])
        self.omega = np.sqrt(lam)
        self.f_hz = self.omega / (2.0 * np.pi)
        self.Phi = V  # V' M V = I
        self.Gamma = V.T @ s.M @ s.P
        Cdev = V.T @ s.C @ V
        dmp = s.damping
        lo = int(dmp.get("n_isolation_modes", 0))
        target = np.zeros(r)
        given = list(dmp.get("superstructure_zeta", []))
        for j in range(lo, r):
            target[j] = given[j - lo] if j - lo < len(given) else dmp.get("default_zeta", 0.0)
        zeta_dev = np.diag(Cdev) / (2.0 * self.omega)
        added = np.where(np.arange(r) >= lo, np.maximum(target - zeta_dev, 0.0), 0.0)
        self.C_modal = Cdev + np.diag(2.0 * added * self.omega)
        self.C_modal = 0.5 * (self.C_modal + self.C_modal.T)
        self.K_modal = np.diag(lam)
        self.B = np.array([s.node_rows[d["node"]][:2] @ V for d in s.devices])
        axis = {"x": 0, "y": 1, "z": 2}
        S = np.array([s.node_rows[node][axis[d]] for _, node, d in s.sensors])
        self.S_Phi, self.S_P = S @ V, S @ s.P
        self._S = S

    def weight(self, device: str) -> float:
        """Static vertical load of a device under gravity, N (>= 0 down)."""
        s = self.structure
        x = np.linalg.solve(s.K, -s.gravity * (s.M @ s.P[:, 2]))
        d = s.devices[self.device_names.index(device)]
        return float(-d.get("kz", 0.0) * (s.node_rows[d["node"]][2] @ x))

    def device_kc(self, device: str) -> tuple[FloatArray, FloatArray]:
        """Nominal (k, c) per direction of a device (the file's)."""
        i = self.device_names.index(device)
        return self.k_dev[i].copy(), self.c_dev[i].copy()

    def channel_names(self) -> tuple[str, ...]:
        """Channels in the order of :mod:`.building`."""
        devs = self.device_names
        return (tuple(c for c, _, _ in self.structure.sensors)
                + tuple(f"{d}_d{a}" for d in devs for a in "xy")
                + tuple(f"{d}_f{a}" for d in devs for a in "xy"))

    def simulate(self, ag: FloatArray, fs_hz: float, n_sub: int = 2) -> FloatArray:
        """Clean channels (n_ch, nt) for table accelerations ``ag`` (6, nt)."""
        r = self.omega.size
        K, C = self.K_modal.copy(), self.C_modal.copy()
        att = []
        for name, law in self.laws.items():
            d = self.device_names.index(name)
            b = self.B[d]
            K -= b.T @ (self.k_dev[d][:, None] * b)  # the law replaces the nominal spring
            C -= b.T @ (self.c_dev[d][:, None] * b)
            att.append(Attached(name, law, b))
        res = run_rk4(np.eye(r), C, K, self.Gamma, att, ag, fs_hz, n_sub)
        acc = self.S_Phi @ res.xdd + self.S_P @ ag
        return np.vstack([acc, device_channels(self.B, self.k_dev, self.c_dev,
                                               self.device_names, self.laws, res)])


def device_channels(B: FloatArray, k_dev: FloatArray, c_dev: FloatArray,
                    names: tuple[str, ...], laws: Mapping[str, Law], res: RunResult
                    ) -> FloatArray:
    """Drift rows ``<dev>_dx, _dy`` of every device, then its force rows (spring + dashpot,
    or the law's force) from a run in modal coordinates (drift ``B_d q``)."""
    u = np.einsum("dir,rt->dit", B, res.x)
    v = np.einsum("dir,rt->dit", B, res.xd)
    f = k_dev[:, :, None] * u + c_dev[:, :, None] * v
    for i, name in enumerate(laws):
        f[names.index(name)] = res.f[i]
    nd = len(names)
    return np.vstack([u.reshape(2 * nd, -1), f.reshape(2 * nd, -1)])
