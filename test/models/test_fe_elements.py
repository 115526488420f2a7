"""Known answers for the 3D frame element: beam theory closed forms, exact statics."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.optimize as so
import scipy.sparse.linalg as spla

from modal_twin.errors import ModelError
from modal_twin.models.fe import FEModel, frame_local_matrices, frame_rotation, solve_modes
from modal_twin.models.fe.elements import _bending_mass, _bending_stiffness

# Steel rectangular bar 50 x 80 mm
E, G, RHO = 210e9, 81e9, 7850.0
B, H = 0.05, 0.08
A = B * H
IZ = B * H**3 / 12.0  # about local z: default local y is global Z for a horizontal beam
IY = H * B**3 / 12.0  # about local y: deflection along global Y for a beam along X
J = 0.229 * B**3 * H
SEC = {"E": E, "G": G, "A": A, "Iy": IY, "Iz": IZ, "J": J, "rho": RHO}


def _line(L, n, direction=(1.0, 0.0, 0.0), **kw):
    d = np.asarray(direction, dtype=float)
    d /= np.linalg.norm(d)
    fem = FEModel()
    fem.add_node("a", (0.0, 0.0, 0.0))
    fem.add_node("b", tuple(L * d))
    chain = fem.add_member("a", "b", n, **{**SEC, **kw})
    return fem, chain


def test_cantilever_bending_frequencies_match_closed_form():
    L = 2.0
    fem, _ = _line(L, 40)
    fem.fix("a")
    asm = fem.assemble()
    sol = solve_modes(asm.K, asm.M, 12)
    f_strong = [f for f, p in zip(sol.f_hz, sol.Phi.T, strict=True)
                if np.abs(p[2::6]).max() > np.abs(p[1::6]).max()
                and np.abs(p[2::6]).max() > np.abs(p[0::6]).max()]
    beta_l = np.array([1.8751040687, 4.6940911330, 7.8547574382])
    exact = beta_l**2 / (2 * np.pi) * np.sqrt(E * IZ / (RHO * A * L**4))
    rel = np.abs(np.array(f_strong[:3]) - exact) / exact
    assert np.all(rel < 5e-3)
    assert rel.max() < 1e-5  # converged mesh: measured 2e-7 for 40 elements
    assert sol.max_rel_residual < 1e-12


def test_simply_supported_frequencies_are_n_pi_squared():
    L = 3.0
    fem, _chain = _line(L, 30)
    fem.fix("a", ["ux", "uy", "uz", "rx"])
    fem.fix("b", ["uy", "uz"])
    sol = solve_modes(fem.assemble().K, fem.assemble().M, 8, method="sparse")
    k = np.arange(1, 4)
    f_y = (k * np.pi) ** 2 / (2 * np.pi * L**2) * np.sqrt(E * IY / (RHO * A))
    f_z = (k * np.pi) ** 2 / (2 * np.pi * L**2) * np.sqrt(E * IZ / (RHO * A))
    exact = np.sort(np.concatenate([f_y, f_z]))[:4]
    assert np.allclose(np.sort(sol.f_hz)[:4], exact, rtol=1e-5, atol=0.0)


@pytest.mark.parametrize("direction", [(1.0, 0.0, 0.0), (0.3, -0.5, 0.8), (0.0, 0.0, 1.0)])
def test_static_tip_deflection_is_exact(direction):
    L, P = 1.7, 1234.0
    fem, _ = _line(L, 3, direction)
    fem.fix("a")
    asm = fem.assemble()
    r, _ = frame_rotation(np.zeros(3), np.asarray(direction), None)
    for axis, inertia in ((1, IZ), (2, IY)):  # load along local y then local z
        f = np.zeros(asm.n_dof)
        dofs = [asm.dof_index("b", n) for n in ("ux", "uy", "uz")]
        f[dofs] = P * r[axis]
        u = spla.spsolve(asm.K.tocsc(), f)
        tip = r[axis] @ u[dofs]
        exact = P * L**3 / (3 * E * inertia)
        assert abs(tip - exact) <= 1e-9 * exact


def test_timoshenko_tip_deflection_adds_shear_term():
    L, P, kappa = 0.6, 5e3, 5.0 / 6.0
    fem, _ = _line(L, 4, Asy=kappa * A, Asz=kappa * A)
    fem.fix("a")
    asm = fem.assemble()
    f = np.zeros(asm.n_dof)
    f[asm.dof_index("b", "uz")] = P
    u = spla.spsolve(asm.K.tocsc(), f)
    exact = P * L**3 / (3 * E * IZ) + P * L / (kappa * G * A)
    assert abs(u[asm.dof_index("b", "uz")] - exact) <= 1e-9 * exact


def test_timoshenko_matrices_equal_shape_function_integrals():
    EI, kGA, rhoA, rhoI, L = 2.0, 3.0, 1.3, 0.7, 1.7
    phi = 12 * EI / (kGA * L**2)

    def v_row(x):
        return np.array([1.0, x, x**2, x**3])

    def psi_row(x):  # static Timoshenko solution: psi = v' + 6 EI a3 / kGA
        return np.array([0.0, 1.0, 2 * x, 3 * x**2 + 6 * EI / kGA])

    C = np.linalg.inv(np.vstack([v_row(0), psi_row(0), v_row(L), psi_row(L)]))
    xg, wg = np.polynomial.legendre.leggauss(8)
    K = np.zeros((4, 4))
    M = np.zeros((4, 4))
    for xi, wi in zip((xg + 1) * L / 2, wg * L / 2, strict=True):
        nv, npsi = v_row(xi) @ C, psi_row(xi) @ C
        dnv = np.array([0.0, 1.0, 2 * xi, 3 * xi**2]) @ C
        dnpsi = np.array([0.0, 0.0, 2.0, 6 * xi]) @ C
        K += wi * (EI * np.outer(dnpsi, dnpsi) + kGA * np.outer(dnv - npsi, dnv - npsi))
        M += wi * (rhoA * np.outer(nv, nv) + rhoI * np.outer(npsi, npsi))
    assert np.allclose(_bending_stiffness(EI, L, phi), K, rtol=1e-13, atol=1e-13 * abs(K).max())
    assert np.allclose(_bending_mass(rhoA, rhoI, L, phi), M, rtol=1e-13, atol=1e-13 * abs(M).max())


def test_timoshenko_simply_supported_thick_beam_frequency():
    L, kappa = 0.8, 5.0 / 6.0  # L / H = 10: shear and rotary inertia matter (~2 %)
    fem, _ = _line(L, 40, Asy=kappa * A, Asz=kappa * A)
    fem.fix("a", ["ux", "uy", "uz", "rx"])
    fem.fix("b", ["uy", "uz"])
    asm = fem.assemble()
    sol = solve_modes(asm.K, asm.M, 6)
    f_fe = next(f for f, p in zip(sol.f_hz, sol.Phi.T, strict=True)
            if np.abs(p[2::6]).max() > np.abs(p[1::6]).max())

    def det(w, alpha=np.pi / L):  # Timoshenko equations with w = sin, psi = cos
        return ((kappa * G * A * alpha**2 - RHO * A * w**2)
                * (E * IZ * alpha**2 + kappa * G * A - RHO * IZ * w**2)
                - (kappa * G * A * alpha) ** 2)

    w_eb = (np.pi / L) ** 2 * np.sqrt(E * IZ / (RHO * A))
    w_t = so.brentq(det, 0.5 * w_eb, w_eb)
    assert w_t < 0.99 * w_eb
    assert abs(f_fe - w_t / (2 * np.pi)) <= 1e-5 * w_t / (2 * np.pi)


def test_torsion_frequency_of_a_shaft():
    L, R = 1.5, 0.03
    Ip = np.pi * R**4 / 2
    fem = FEModel()
    fem.add_node(0, (0, 0, 0))
    fem.add_node(1, (L, 0, 0))
    fem.add_member(0, 1, 40, E=E, G=G, A=np.pi * R**2, Iy=Ip / 2, Iz=Ip / 2, J=Ip, rho=RHO)
    fem.fix(0)
    asm = fem.assemble()
    sol = solve_modes(asm.K, asm.M, 30)
    f_t = [f for f, p in zip(sol.f_hz, sol.Phi.T, strict=True)
           if np.abs(p[3::6]).max() > 0.5 * np.abs(p).max()]
    exact = (2 * np.arange(1, 3) - 1) / (4 * L) * np.sqrt(G / RHO)
    assert np.allclose(f_t[:2], exact, rtol=1e-3, atol=0.0)


def test_free_free_structure_has_six_rigid_body_modes():
    fem = FEModel()
    for i, p in enumerate([(0, 0, 0), (2, 0, 0), (2, 1.5, 0), (2, 1.5, 1.0)]):
        fem.add_node(i, p)
    for a, b in [(0, 1), (1, 2), (2, 3)]:
        fem.add_member(a, b, 4, **SEC)
    sol = solve_modes(fem.assemble().K, fem.assemble().M, 9, method="sparse")
    scale = sol.f_hz[6]
    assert np.all(sol.f_hz[:6] < 1e-4 * scale)
    assert sol.f_hz[6] > 1.0
    assert sol.max_orthogonality_error < 1e-10


def test_total_mass_is_exact_and_lumped_mass_converges_from_below():
    L = 2.5
    fem, chain = _line(L, 10, (1.0, 2.0, 2.0))
    fem.add_mass(chain[4], 12.5, inertia=(1.0, 2.0, 3.0))
    asm = fem.assemble()
    assert abs(asm.total_mass() - (RHO * A * L + 12.5)) <= 1e-13 * asm.total_mass()
    rbm = asm.rigid_body_mass()
    assert np.allclose(rbm, rbm.T, rtol=0, atol=1e-12 * abs(rbm).max())
    fem_l, _ = _line(L, 40, mass="lumped")
    fem_l.fix("a")
    fem_c, _ = _line(L, 40)
    fem_c.fix("a")
    f_l = solve_modes(fem_l.assemble().K, fem_l.assemble().M, 1).f_hz[0]
    f_c = solve_modes(fem_c.assemble().K, fem_c.assemble().M, 1).f_hz[0]
    exact = 1.8751040687**2 / (2 * np.pi) * np.sqrt(E * IY / (RHO * A * L**4))
    assert f_l < exact < f_c
    assert abs(f_l - exact) < 1e-3 * exact
    assert abs(fem_l.assemble().total_mass() - RHO * A * L) <= 1e-13 * RHO * A * L


def test_element_bad_input_is_refused():
    with pytest.raises(ModelError, match="frame length: expected > 0"):
        frame_rotation(np.ones(3), np.ones(3), None)
    with pytest.raises(ModelError, match="orientation: expected a vector not parallel"):
        frame_rotation(np.zeros(3), np.array([1.0, 0, 0]), np.array([2.0, 0, 0]))
    with pytest.raises(ModelError, match=r"orientation: expected a finite \(3,\) vector"):
        frame_rotation(np.zeros(3), np.array([1.0, 0, 0]), np.array([0.0, 1.0]))
    with pytest.raises(ModelError, match="mass: expected one of"):
        frame_local_matrices(E=1.0, G=1.0, A=1.0, Iy=1.0, Iz=1.0, J=1.0, rho=1.0,
                             length=1.0, mass="diagonal")  # type: ignore[arg-type]
