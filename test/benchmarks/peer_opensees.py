"""OpenSeesPy peer of bench_twin: the same base-isolated building and record in both codes.

Why a shear building and not bench_twin's modal model: bench_twin's building is a reduced
modal model (36 modes, dense drift matrices of the six isolators); OpenSees has no element
for a dense reduced M, K, so the same model cannot be written as OpenSees elements. The
closest equivalent that both codes can hold exactly is a physical-coordinate model of the
same size: a 12-level shear building (base slab + 11 floors, rigid diaphragms, 3 DOF per
level: x, y, rotation about z = 36 DOF, 686 t, 10 m x 12 m plan) on six bidirectional
isolators at the plan positions of bench_twin. In OpenSees: one node per level with
lumped mass and inertia, ``zeroLength`` story springs (x, y, torsion, Rayleigh damping),
``zeroLength`` isolators on fixed ground nodes, tied to the base slab by ``rigidLink``
beams; ``UniformExcitation`` in x, y and rz; Newmark average acceleration, Newton. In the
twin: the same M, C, K as a :class:`ReducedSystem` (the physical coordinates are its
"reduced" coordinates), the isolators as devices with drift rows
``[x_b - p_y theta_b, y_b + p_x theta_b]``.

Two cases: linear isolators (``Elastic`` with damping; the twin's ``LinearDevice``), the
gate on which the two codes must agree before their speeds are compared, and bilinear
hysteretic isolators (OpenSees ``Steel01`` in parallel with ``Viscous`` per direction; the
twin's :class:`BilinearHysteretic`, the same uncoupled kinematic-hardening law).

OpenSeesPy is a benchmark-only dependency (requirements/bench.txt); :func:`available`
says whether it can be imported.
"""

from __future__ import annotations

import ctypes
import importlib.util
import os
import tempfile
import time

import numpy as np

from modal_twin.models.devices.bilinear import BilinearHysteretic
from modal_twin.models.devices.linear import LinearDevice
from modal_twin.models.reduced import DeviceAttachment, ReducedSystem

N_LEVEL = 12  # base slab + 11 floors: 36 DOF
M_TOTAL = 686e3  # kg
LX, LY = 10.0, 12.0  # plan, m
POS = ((-5.0, -6.0), (5.0, 6.0), (5.0, -6.0), (-5.0, 6.0), (0.0, -6.0), (0.0, 6.0))
K_STORY = 4.85e8  # N/m in x (first fixed-base mode ~2 Hz); y stiffer by 20 %
K_ISO = 1.13e6  # N/m per isolator (isolation mode ~0.5 Hz)
C_ISO = 7.2e4  # N s/m per isolator and direction
UB_ISO = 0.01  # m, yield drift of the bilinear isolator
KB_RATIO = 0.3  # post-yield / initial stiffness
ZETA, F_A, F_B = 0.02, 2.0, 25.0  # Rayleigh damping of the superstructure
INPUT_ROWS = (0, 1, 5)  # x, y, rz of bench_twin's 6-DOF table record


def _ops():
    """Import openseespy.opensees (its wheel's LAPACK needs the wheel's BLAS loaded first)."""
    spec = importlib.util.find_spec("openseespylinux")
    if spec is not None and spec.origin is not None:
        blas = os.path.join(os.path.dirname(spec.origin), "lib", "libblas.so.3")
        if os.path.exists(blas):
            ctypes.CDLL(blas, mode=ctypes.RTLD_GLOBAL)
    import openseespy.opensees as ops

    return ops


def available() -> tuple[bool, str]:
    """Return (True, version) if OpenSeesPy can be imported, else (False, reason)."""
    try:
        ops = _ops()
    except Exception as exc:
        return False, f"{type(exc).__name__}: {exc}"
    return True, str(ops.version())


def _properties() -> dict[str, np.ndarray | float]:
    m = M_TOTAL / N_LEVEL
    J = m * (LX**2 + LY**2) / 12.0
    kx = K_STORY
    ky = 1.2 * K_STORY
    kt = K_STORY * (LX**2 + LY**2) / 6.0
    w_a, w_b = 2 * np.pi * F_A, 2 * np.pi * F_B
    b_k = 2 * ZETA / (w_a + w_b)
    a_m = b_k * w_a * w_b
    return {"m": m, "J": J, "k": np.array([kx, ky, kt]), "a_m": a_m, "b_k": b_k}


def twin_system(nonlinear: bool) -> ReducedSystem:
    """The shear building as the twin's ReducedSystem (outputs: absolute base / roof x, y)."""
    p = _properties()
    n = 3 * N_LEVEL
    M = np.diag(np.tile([p["m"], p["m"], p["J"]], N_LEVEL))
    K = np.zeros((n, n))
    for lev in range(1, N_LEVEL):  # story springs between level lev - 1 and lev
        for a in range(3):
            i, j = 3 * (lev - 1) + a, 3 * lev + a
            k = p["k"][a]
            K[i, i] += k
            K[j, j] += k
            K[i, j] -= k
            K[j, i] -= k
    C = p["a_m"] * M + p["b_k"] * K
    r = np.zeros((n, 3))
    for a in range(3):
        r[a::3, a] = 1.0
    att = []
    for d, (px, py) in enumerate(POS):
        B = np.zeros((2, n))
        B[0, 0], B[0, 2] = 1.0, -py
        B[1, 1], B[1, 2] = 1.0, px
        if nonlinear:
            dev = BilinearHysteretic(K_ISO, KB_RATIO * K_ISO, UB_ISO, [C_ISO, C_ISO],
                                     name=f"iso{d}")
        else:
            dev = LinearDevice([K_ISO, K_ISO], [C_ISO, C_ISO], name=f"iso{d}")
        att.append(DeviceAttachment(dev, B))
    out = [0, 1, n - 3, n - 2]  # base x, y; roof x, y
    C_out = np.zeros((4, 3 * n))
    D_out = np.zeros((4, 3))
    for o, i in enumerate(out):
        C_out[o, 2 * n + i] = 1.0
        D_out[o, i % 3] = 1.0
    return ReducedSystem(M, C, K, M @ r, tuple(att), C_out, D_out,
                         ("base_x", "base_y", "roof_x", "roof_y"))


def _build_opensees(ops, nonlinear: bool) -> tuple[int, int]:
    """Build the model; return the base and roof node tags."""
    p = _properties()
    ops.wipe()
    ops.model("basic", "-ndm", 3, "-ndf", 6)
    for lev in range(N_LEVEL):  # level nodes (coincident: springs only, no lengths)
        tag = 100 + lev
        ops.node(tag, 0.0, 0.0, 0.0)
        ops.fix(tag, 0, 0, 1, 1, 1, 0)
        ops.mass(tag, p["m"], p["m"], 0.0, 0.0, 0.0, p["J"])
    for a, k in enumerate(p["k"]):
        ops.uniaxialMaterial("Elastic", 1 + a, float(k))
    for lev in range(1, N_LEVEL):
        ops.element("zeroLength", 100 + lev, 100 + lev - 1, 100 + lev, "-mat", 1, 2, 3,
                    "-dir", 1, 2, 6, "-doRayleigh", 1)
    if nonlinear:
        ops.uniaxialMaterial("Steel01", 11, K_ISO * UB_ISO, K_ISO, KB_RATIO)
        ops.uniaxialMaterial("Viscous", 12, C_ISO, 1.0)
        ops.uniaxialMaterial("Parallel", 10, 11, 12)
    else:
        ops.uniaxialMaterial("Elastic", 10, K_ISO, C_ISO)
    for d, (px, py) in enumerate(POS):
        ops.node(200 + d, px, py, 0.0)  # ground
        ops.fix(200 + d, 1, 1, 1, 1, 1, 1)
        ops.node(300 + d, px, py, 0.0)  # top of the isolator, on the base slab
        ops.rigidLink("beam", 100, 300 + d)
        ops.element("zeroLength", 200 + d, 200 + d, 300 + d, "-mat", 10, 10, "-dir", 1, 2)
    ops.rayleigh(p["a_m"], 0.0, p["b_k"], 0.0)
    return 100, 100 + N_LEVEL - 1


def run_opensees(ag: np.ndarray, dt: float, nonlinear: bool) -> tuple[np.ndarray, float]:
    """Simulate the record (rows x, y, rz; sample 0 at rest); return y (4, nt) and CPU s.

    y rows: absolute acceleration of the base slab x, y and of the roof x, y (m/s^2), as
    the twin's :func:`twin_system` outputs. The time is the process CPU time of
    ``ops.analyze`` alone (one thread; less inflated than wall time on a loaded machine).
    """
    ops = _ops()
    base, roof = _build_opensees(ops, nonlinear)
    nt = ag.shape[1]
    for a, direction in enumerate((1, 2, 6)):
        # one extrapolated sample past the end: the accumulated analysis time of the last
        # step may land a hair past the record, where a Path series returns 0
        vals = [*ag[a].tolist(), float(2.0 * ag[a, -1] - ag[a, -2])]
        ops.timeSeries("Path", 1 + a, "-dt", dt, "-values", *vals)
        ops.pattern("UniformExcitation", 1 + a, direction, "-accel", 1 + a)
    fd, path = tempfile.mkstemp(suffix=".out", prefix="peer_opensees_")
    os.close(fd)
    ops.recorder("Node", "-file", path, "-node", base, roof, "-dof", 1, 2, "accel")
    # penalty for the rigid links: with the Transformation handler the isolator tops did
    # not follow the base slab in this build's transient analysis, and with Lagrange
    # multipliers the Newton displacement test did not converge; a penalty of 1e14 keeps
    # the link drift below 1e-9 of the slab's displacement
    ops.constraints("Penalty", 1e14, 1e14)
    ops.numberer("RCM")
    ops.system("BandGeneral")
    ops.test("NormDispIncr", 1e-10, 25)
    ops.algorithm("Newton")
    ops.integrator("Newmark", 0.5, 0.25)
    ops.analysis("Transient")
    t0 = time.process_time()
    status = ops.analyze(nt - 1, dt)
    cpu = time.process_time() - t0
    ops.wipe()  # closes the recorder
    rel = np.loadtxt(path, ndmin=2)
    os.remove(path)
    if status != 0 or rel.shape[0] != nt - 1:
        msg = f"OpenSees analysis failed (status {status}, {rel.shape[0]} of {nt - 1} steps)"
        raise RuntimeError(msg)
    y = np.zeros((4, nt))
    y[:, 1:] = rel.T[[0, 1, 2, 3]]
    y[[0, 2]] += ag[0]  # relative -> absolute
    y[[1, 3]] += ag[1]
    y[:, 0] = 0.0  # rest: the relative acceleration is -a_g
    return y, cpu


def nrmse_pct(y: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """RMS of the difference over the RMS of ``ref``, per row, in %."""
    return 100.0 * np.sqrt(np.mean((y - ref) ** 2, axis=1) / np.mean(ref**2, axis=1))
