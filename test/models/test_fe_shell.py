"""Flat 4-node shell (QM6 membrane + MITC4 plate + drilling): patch tests and closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from modal_twin.errors import ModelError
from modal_twin.models.fe import FEModel, solve_modes
from modal_twin.models.fe.shell import ShellModel, shell_global_units, shell_local_matrices

E, NU, RHO = 70e9, 0.3, 2700.0

# MacNeal-Harder patch: a 0.24 x 0.12 rectangle cut into five distorted quadrilaterals.
PATCH_XY = {0: (0.0, 0.0), 1: (0.24, 0.0), 2: (0.24, 0.12), 3: (0.0, 0.12),
            4: (0.04, 0.02), 5: (0.18, 0.03), 6: (0.16, 0.08), 7: (0.08, 0.08)}
PATCH_QUADS = [(0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7), (4, 5, 6, 7)]
INNER = (4, 5, 6, 7)


def _rotation() -> np.ndarray:
    q, _ = np.linalg.qr(np.random.default_rng(3).normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def _patch(R: np.ndarray, t: float = 0.01) -> tuple[ShellModel, dict[int, np.ndarray]]:
    fem = ShellModel()
    xyz = {}
    for n, (x, y) in PATCH_XY.items():
        xyz[n] = R @ np.array([x, y, 0.0]) + np.array([1.0, -2.0, 0.5])
        fem.add_node(n, xyz[n])
    fem.add_shells(PATCH_QUADS, E=E, nu=NU, rho=RHO, t=t)
    return fem, xyz


def _solve_patch(R: np.ndarray, local_field) -> tuple[np.ndarray, np.ndarray]:
    """Prescribe a local field (u, v, w, tx, ty, tz per node) on the boundary; solve."""
    fem, _ = _patch(R)
    asm = fem.assemble()
    K = asm.K.toarray()
    n = K.shape[0]
    u_exact = np.zeros(n)
    for node, (x, y) in PATCH_XY.items():
        loc = np.asarray(local_field(x, y), dtype=float)
        g = np.concatenate([R @ loc[:3], R @ loc[3:]])
        for j, name in enumerate(("ux", "uy", "uz", "rx", "ry", "rz")):
            u_exact[asm.dof_index(node, name)] = g[j]
    inner = np.array([asm.dof_index(nd, d) for nd in INNER
                      for d in ("ux", "uy", "uz", "rx", "ry", "rz")])
    outer = np.setdiff1d(np.arange(n), inner)
    u = u_exact.copy()
    u[inner] = np.linalg.solve(K[np.ix_(inner, inner)], -K[np.ix_(inner, outer)] @ u[outer])
    return u[inner], u_exact[inner]


def test_single_element_has_six_rigid_modes_in_any_orientation():
    xy = np.array([[0.0, 0.0], [1.2, 0.1], [1.0, 0.9], [-0.1, 0.8]])
    X = np.c_[xy, np.zeros(4)] @ _rotation().T + 3.0
    k, m = shell_global_units(X, nu=NU, t=0.01, t_b=0.03)
    ev = np.linalg.eigvalsh(k[0])
    assert np.all(np.abs(ev[:6]) < 1e-12 * ev[-1])
    assert ev[6] > 1e-8 * ev[-1]
    # translations and rotations about any point are exact null vectors
    rb = np.zeros((24, 6))
    for a in range(4):
        rb[6 * a:6 * a + 3, :3] = np.eye(3)
        for j in range(3):
            e = np.zeros(3)
            e[j] = 1.0
            rb[6 * a:6 * a + 3, 3 + j] = np.cross(e, X[a])
            rb[6 * a + 3 + j, 3 + j] = 1.0
    assert np.abs(k[0] @ rb).max() < 1e-12 * np.abs(k[0]).max()
    # mass of a flat element: rho t A on every translation
    area = 0.5 * abs(np.cross(np.r_[xy[2] - xy[0], 0], np.r_[xy[3] - xy[1], 0])[2])
    assert (rb[:, :3].T @ m[0] @ rb[:, :3]) == pytest.approx(0.01 * area * np.eye(3), rel=1e-12)


@pytest.mark.parametrize("strain", [(1e-3, 0.0, 0.0), (0.0, 2e-3, 0.0), (0.0, 0.0, 1.5e-3)])
def test_membrane_constant_strain_patch(strain):
    ex, ey, gxy = strain
    rot = 4e-4  # a rigid in-plane rotation on top, carried by the drilling DOF

    def field(x, y):
        u = ex * x + 0.5 * gxy * y - rot * y
        v = ey * y + 0.5 * gxy * x + rot * x
        return (u, v, 0.0, 0.0, 0.0, rot)

    got, want = _solve_patch(_rotation(), field)
    assert np.abs(got - want).max() < 1e-10 * np.abs(want).max()


@pytest.mark.parametrize("kappa", [(0.1, 0.0, 0.0), (0.0, 0.2, 0.0), (0.0, 0.0, 0.15)])
def test_plate_constant_curvature_patch(kappa):
    kx, ky, kxy = kappa

    def field(x, y):
        # w = (kx x^2 + ky y^2 + kxy x y) / 2 with zero shear: theta_y = -w,x, theta_x = w,y
        w = 0.5 * (kx * x**2 + ky * y**2 + kxy * x * y)
        wx, wy = kx * x + 0.5 * kxy * y, ky * y + 0.5 * kxy * x
        return (0.0, 0.0, w, wy, -wx, 0.0)

    got, want = _solve_patch(_rotation(), field)
    assert np.abs(got - want).max() < 1e-8 * np.abs(want).max()


def _plate_mesh(n: int, a: float, t: float) -> ShellModel:
    fem = ShellModel()
    h = a / n
    for i in range(n + 1):
        for j in range(n + 1):
            fem.add_node(f"{i},{j}", (i * h, j * h, 0.0))
    fem.add_shells([(f"{i},{j}", f"{i + 1},{j}", f"{i + 1},{j + 1}", f"{i},{j + 1}")
                    for i in range(n) for j in range(n)], E=E, nu=NU, rho=RHO, t=t)
    for i in range(n + 1):
        for j in range(n + 1):
            node = f"{i},{j}"
            fem.fix(node, ["ux", "uy", "rz"])
            if i in (0, n):  # edge x = const: w = 0 and no twist along the edge (theta_x)
                fem.fix(node, ["uz", "rx"])
            if j in (0, n):
                fem.fix(node, ["uz", "ry"])
    return fem


def test_simply_supported_square_plate_matches_closed_form():
    # Leissa (1969), Table 4.1: f_mn = (pi / 2) ((m/a)^2 + (n/a)^2) sqrt(D / (rho t))
    a, t = 1.0, 0.01
    D = E * t**3 / (12 * (1 - NU**2))
    closed = [np.pi / 2 * ((m / a) ** 2 + (k / a) ** 2) * np.sqrt(D / (RHO * t))
              for m, k in ((1, 1), (1, 2), (2, 1), (2, 2))]
    errs = []
    for n in (8, 16):
        asm = _plate_mesh(n, a, t).assemble()
        sol = solve_modes(asm.K, asm.M, 4)
        errs.append(np.abs(sol.f_hz / np.array(closed) - 1.0))
    assert np.all(errs[1] < 0.02)  # measured 0.4 %, 1.5 %, 1.5 %, 1.6 %
    assert np.all(errs[1] < errs[0])  # converges with the mesh


def _box_beam(b: float, L: float, t: float, n_side: int, n_len: int, nu: float) -> ShellModel:
    """Free-free square thin-walled tube along x, rigid diaphragm at every station."""
    s = np.linspace(-b / 2, b / 2, n_side + 1)
    ring = ([(y, -b / 2) for y in s[:-1]] + [(b / 2, z) for z in s[:-1]]
            + [(y, b / 2) for y in s[::-1][:-1]] + [(-b / 2, z) for z in s[::-1][:-1]])
    fem = ShellModel()
    xs = np.linspace(0.0, L, n_len + 1)
    for i, x in enumerate(xs):
        for k, (y, z) in enumerate(ring):
            fem.add_node(f"{i}_{k}", (x, y, z))
        fem.add_rigid_diaphragm(f"{i}_0", [f"{i}_{k}" for k in range(1, len(ring))],
                                normal="x")
    nr = len(ring)
    fem.add_shells([(f"{i}_{k}", f"{i + 1}_{k}", f"{i + 1}_{(k + 1) % nr}", f"{i}_{(k + 1) % nr}")
                    for i in range(n_len) for k in range(nr)], E=E, nu=nu, rho=RHO, t=t)
    return fem


def test_thin_walled_box_beam_bending_and_torsion_match_beam_theory():
    # nu = 0: the rigid diaphragms (beam theory's rigid section) would otherwise hold the
    # walls' Poisson contraction and stiffen them by 1 / (1 - nu^2)
    b, L, t, nu = 0.6, 12.0, 0.008, 0.0
    asm = _box_beam(b, L, t, 4, 48, nu).assemble()
    sol = solve_modes(asm.K, asm.M, 12)
    assert np.all(sol.f_hz[:6] < 1e-3)  # six rigid-body modes
    m = RHO * t * 4 * b * L
    assert asm.total_mass() == pytest.approx(m, rel=1e-12)
    rbm = asm.rigid_body_mass()
    assert np.diag(rbm)[:3] == pytest.approx([m] * 3, rel=1e-12)
    G = E / (2 * (1 + nu))
    I = 2 * t * b**3 / 3  # square tube, both axes
    A = 4 * b * t
    f_bend = 4.730041**2 / (2 * np.pi * L**2) * np.sqrt(E * I / (RHO * A))  # Euler-Bernoulli
    J = 4 * (b * b) ** 2 / (4 * b / t)  # Bredt-Batho: 4 A_enc^2 / oint ds / t
    Ip = 2 * I
    f_tors = 1 / (2 * L) * np.sqrt(G * J / (RHO * Ip))  # free-free torsion, first mode
    U = asm.expand(sol.Phi).reshape(len(asm.nodes), 6, -1)
    rx = (U[:, 3] ** 2).sum(axis=0)
    uyz = (U[:, 1] ** 2 + U[:, 2] ** 2).sum(axis=0)
    flex = np.arange(6, 12)
    torsion = [j for j in flex if rx[j] * b**2 > uyz[j] * 0.5]
    bending = [j for j in flex if j not in torsion]
    # the square tube bends alike in both planes: a pair just below Euler-Bernoulli (shear
    # deformation, measured -2.1 %), within 0.5 % of a Timoshenko beam (shear area A / 2,
    # the webs; measured 0.1 %), torsion at Bredt-Batho's J (measured 0.05 %)
    fb = sol.f_hz[bending[:2]]
    assert np.all((fb < f_bend) & (fb > 0.97 * f_bend))
    beam = FEModel()
    beam.add_node(0, (0.0, 0.0, 0.0))
    beam.add_node(1, (L, 0.0, 0.0))
    beam.add_member(0, 1, 96, E=E, G=G, A=A, Iy=I, Iz=I, J=J, rho=RHO, Asy=A / 2, Asz=A / 2)
    basm = beam.assemble()
    f_timo = solve_modes(basm.K, basm.M, 7).f_hz[6]
    assert fb == pytest.approx([f_timo] * 2, rel=0.005)
    assert sol.f_hz[torsion[0]] == pytest.approx(f_tors, rel=0.005)


def test_bad_shells_are_refused():
    fem = ShellModel()
    for n, p in enumerate([(0, 0, 0), (1, 0, 0), (1, 1, 0.2), (0, 1, 0)]):
        fem.add_node(n, p)
    with pytest.raises(ModelError, match="flat"):
        fem.add_shells([(0, 1, 2, 3)], E=E, nu=NU, rho=RHO, t=0.01)
    with pytest.raises(ModelError, match="convex"):
        shell_local_matrices(np.array([[0, 0], [1, 0], [0.2, 0.2], [0, 1]]), nu=NU, t=0.01)
    with pytest.raises(ModelError, match="nu"):
        shell_local_matrices(np.array([[0, 0], [1, 0], [1, 1], [0, 1]]), nu=0.5, t=0.01)
    with pytest.raises(ModelError, match="t:"):
        shell_local_matrices(np.array([[0, 0], [1, 0], [1, 1], [0, 1]]), nu=NU, t=0.0)
