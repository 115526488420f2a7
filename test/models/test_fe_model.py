"""FEModel builder: springs, masses, rigid links and diaphragms, parametric matrices, errors."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse.linalg as spla

from modal_twin.errors import ModelError, OptionError, ShapeError
from modal_twin.models.fe import FEModel, solve_modes

E, G, RHO = 30e9, 12.5e9, 2400.0  # concrete
COL = {"E": E, "G": G, "A": 0.16, "Iy": 0.16**2 / 12 * 0.16, "Iz": 0.16**2 / 12 * 0.16,
       "J": 0.141 * 0.4**4 / 16, "rho": 0.0}
EI = E * COL["Iz"]


def _storey(kind: str, *, h=3.0, a=4.0, b=3.0, m=8000.0, jz=2e4):
    """One storey: four massless cantilever columns under a floor mass at the centroid."""
    fem = FEModel()
    corners = [(0, 0), (a, 0), (a, b), (0, b)]
    for j, (x, y) in enumerate(corners):
        fem.add_node(f"base{j}", (x, y, 0.0))
        fem.add_node(f"top{j}", (x, y, h))
        fem.add_member(f"base{j}", f"top{j}", 4, **COL)
        fem.fix(f"base{j}")
    fem.add_node("cm", (a / 2, b / 2, h))
    fem.add_mass("cm", m, inertia=(1.0, 1.0, jz))
    tops = [f"top{j}" for j in range(4)]
    if kind == "diaphragm":
        fem.add_rigid_diaphragm("cm", tops)
        fem.fix("cm", ["uz", "rx", "ry"])
    elif kind == "links":
        for t in tops:
            fem.add_rigid_link("cm", t)
        fem.fix("cm", ["uz", "rx", "ry"])
    else:  # stiff in-plane beams, nearly free out of plane
        for t in tops:
            fem.add_frame("cm", t, E=E * 1e4, G=G, A=1.0, Iy=1.0, Iz=1e-12, J=1e-12, rho=0.0)
        fem.fix("cm", ["uz", "rx", "ry"])
    return fem


def test_spring_mass_oscillators_are_exact():
    fem = FEModel()
    fem.add_node(1, (0, 0, 0))
    fem.add_node(2, (1, 0, 0))
    k, m = 4.0e6, 250.0
    fem.add_spring(1, k=[k] * 6)
    fem.add_spring(1, 2, k={"ux": k, "uy": k, "uz": k, "rx": k, "ry": k, "rz": k},
                   c={"ux": 10.0})
    fem.add_mass(1, m, inertia=(m, m, m))
    fem.add_mass(2, m, inertia=(m, m, m))
    asm = fem.assemble()
    sol = solve_modes(asm.K, asm.M, 12)
    w = np.sqrt(k / m) * np.array([(3 - np.sqrt(5)) / 2, (3 + np.sqrt(5)) / 2]) ** 0.5
    assert np.allclose(sol.omega, np.repeat(w, 6), rtol=1e-12, atol=0.0)
    c = asm.C.toarray()
    i1, i2 = asm.dof_index(1, "ux"), asm.dof_index(2, "ux")
    assert c[i1, i1] == 10.0
    assert c[i1, i2] == -10.0
    assert np.count_nonzero(c) == 4


def test_rigid_diaphragm_reduces_dofs_and_matches_closed_form_and_stiff_links():
    h, m, jz, a, b = 3.0, 8000.0, 2e4, 4.0, 3.0
    dia = _storey("diaphragm").assemble()
    stiff = _storey("stiff").assemble()
    assert dia.n_dof == stiff.n_dof - 12
    f_d = solve_modes(dia.K, dia.M, 3).f_hz
    f_s = solve_modes(stiff.K, stiff.M, 3).f_hz
    assert np.allclose(f_d, f_s, rtol=1e-4, atol=0.0)
    k1 = 3 * EI / h**3  # massless cantilever column, top rotation free
    r2 = 4 * ((a / 2) ** 2 + (b / 2) ** 2)
    k_t = k1 * r2 + 4 * G * COL["J"] / h
    exact = np.sort([np.sqrt(4 * k1 / m), np.sqrt(4 * k1 / m), np.sqrt(k_t / jz)]) / (2 * np.pi)
    assert np.allclose(f_d, exact, rtol=1e-10, atol=0.0)


def test_rigid_links_give_fixed_guided_columns_and_recover_slaves():
    h, m = 3.0, 8000.0
    asm = _storey("links").assemble()
    sol = solve_modes(asm.K, asm.M, 2)
    exact = np.sqrt(4 * 12 * EI / h**3 / m) / (2 * np.pi)
    assert np.allclose(sol.f_hz, exact, rtol=1e-10, atol=0.0)
    u = np.zeros(asm.n_dof)
    u[asm.dof_index("cm", "rz")] = 1e-3
    full = asm.expand(u)
    j = asm.full_dof_index("top2", "ux")  # top2 at (4, 3): dy = +1.5 from cm
    assert full[j] == pytest.approx(-1.5e-3, rel=1e-14)
    assert full[asm.full_dof_index("top2", "uy")] == pytest.approx(2e-3, rel=1e-14)
    with pytest.raises(ModelError, match="expected a free DOF"):
        asm.dof_index("top2", "ux")


def test_rigid_body_vectors_survive_constraints():
    fem = FEModel()
    fem.add_node("m", (1.0, 2.0, 3.0))
    fem.add_node("s", (2.0, 0.5, 3.0))
    fem.add_node("t", (0.0, 0.0, 3.0))
    fem.add_node("u", (4.0, 1.0, 7.0))
    fem.add_rigid_link("m", "s")
    fem.add_rigid_link("s", "u")  # chain resolves to "m"
    fem.add_rigid_diaphragm("m", ["t"])
    for n in ("m", "t"):
        fem.add_mass(n, 10.0, inertia=(1.0, 1.0, 1.0))
    asm = fem.assemble()
    rb = asm.rigid_body_modes((0.5, 0.5, 0.5))
    full = asm.rigid_body_modes((0.5, 0.5, 0.5), full=True)
    assert np.allclose(asm.expand(rb), full, rtol=0, atol=1e-14)
    assert asm.n_dof == 24 - 6 - 6 - 3


def test_parametric_stiffness_equals_fresh_assembly():
    def build(e_col, kx, ky, m_floor, rho_b):
        fem = FEModel()
        fem.add_node(0, (0, 0, 0))
        fem.add_node(1, (0, 0, 3.0))
        fem.add_node(2, (5.0, 0, 3.0))
        fem.add_node(3, (5.0, 0, 0))
        g_ratio = G / E
        col = {**COL, "E": e_col, "G": g_ratio * e_col, "rho": 2400.0, "Asy": 0.13,
               "Asz": 0.13}
        fem.add_member(0, 1, 3, **col, E_param="E_col")
        fem.add_member(3, 2, 3, **col, E_param="E_col")
        fem.add_member(1, 2, 4, **{**COL, "rho": rho_b}, rho_param="rho_beam")
        fem.add_spring(0, k={"ux": kx, "uy": ky, "uz": 1e9, "rx": 1e8, "ry": 1e8,
                             "rz": 1e8}, k_params={"ux": "k_x", "uy": "k_y"})
        fem.add_spring(3, k=[1e7, 1e7, 1e9, 1e8, 1e8, 1e8])
        fem.add_mass(2, m_floor, m_param="m_floor")
        return fem.assemble()

    nom = build(E, 2e6, 2e6, 5000.0, 2500.0)
    par = nom.parametric
    assert par.names == ("E_col", "rho_beam", "k_x", "k_y", "m_floor")
    assert par.kinds == ("K", "M", "K", "K", "M")
    theta = {"E_col": 1.37 * E, "k_x": 3.1e6, "k_y": 0.7e6, "m_floor": 6100.0,
             "rho_beam": 2100.0}
    new = build(1.37 * E, 3.1e6, 0.7e6, 6100.0, 2100.0)
    assert abs(par.K(theta) - new.K).max() <= 1e-12 * abs(new.K).max()
    assert abs(par.M(theta) - new.M).max() <= 1e-12 * abs(new.M).max()
    vec = par.theta_vector(theta)
    assert abs(par.K(vec) - new.K).max() <= 1e-12 * abs(new.K).max()
    assert abs(par.K() - nom.K).max() == 0.0
    i = par.index("k_y")
    d = par.dK("k_y")
    assert abs(par.K(par.theta0 + 1e5 * np.eye(5)[i]) - nom.K - 1e5 * d).max() <= (
        1e-12 * abs(nom.K).max())
    assert par.dK("m_floor").nnz == 0
    assert par.dM("m_floor").sum() == pytest.approx(3.0)
    assert par.dC(0).nnz == 0
    assert abs(par.C() - nom.C).max() == 0.0
    with pytest.raises(OptionError, match="parameter: expected one of"):
        par.K({"E_beam": 1.0})
    with pytest.raises(OptionError, match="parameter index: expected 0 <= i < 5"):
        par.dK(7)
    with pytest.raises(ShapeError, match=r"theta: expected shape \(5,\), got \(2,\)"):
        par.K([1.0, 2.0])


def test_static_solution_with_springs_in_series_is_exact():
    fem = FEModel()
    for i in range(3):
        fem.add_node(i, (float(i), 0.0, 0.0))
        fem.add_mass(i, 1.0, inertia=(1.0, 1.0, 1.0))
    fem.add_spring(0, 1, k=[1e5, 2e5, 3e5, 1.0, 1.0, 1.0])
    fem.add_spring(1, 2, k=[4e5, 5e5, 6e5, 1.0, 1.0, 1.0])
    fem.fix(0)
    fem.fix(1, "rx")
    fem.fix(2, ("rx", "ry", "rz"))
    fem.fix(1, ["ry", "rz"])
    asm = fem.assemble()
    f = np.zeros(asm.n_dof)
    f[asm.dof_index(2, "uy")] = 1000.0
    u = spla.spsolve(asm.K.tocsc(), f)
    assert u[asm.dof_index(2, "uy")] == pytest.approx(1000.0 / 2e5 + 1000.0 / 5e5, rel=1e-14)


def test_builder_errors_name_the_entry():
    fem = FEModel()
    fem.add_node(0, (0, 0, 0))
    fem.add_node(1, (1, 0, 0))
    fem.add_node(2, (1, 0, 1))
    fem.add_node(3, (0, 0, 0))
    with pytest.raises(ModelError, match="node: id 0 already exists"):
        fem.add_node(0, (1, 1, 1))
    with pytest.raises(ModelError, match="xyz of node 9: expected 3 finite"):
        fem.add_node(9, (1, np.nan, 1))
    with pytest.raises(ModelError, match="node: expected an int or str id"):
        fem.add_node(1.5, (0, 0, 0))  # type: ignore[arg-type]
    with pytest.raises(ModelError, match=r"frame 0 \(0-1\) rho: expected a finite value >= 0"):
        fem.add_frame(0, 1, **{**COL, "rho": -1.0})
    with pytest.raises(ModelError, match=r"frame 0 \(0-1\) A: expected a finite value > 0"):
        fem.add_frame(0, 1, **{**COL, "A": 0.0})
    with pytest.raises(ModelError, match=r"frame 0 \(0-3\): frame length: expected > 0"):
        fem.add_frame(0, 3, **COL)
    with pytest.raises(ModelError, match="length: expected two distinct nodes"):
        fem.add_frame(1, 1, **COL)
    with pytest.raises(ModelError, match="node: unknown node id 'x'"):
        fem.add_frame(0, "x", **COL)
    with pytest.raises(ModelError, match="E_param: expected a non-empty parameter name"):
        fem.add_frame(0, 1, **COL, E_param="")
    with pytest.raises(ModelError, match="n_elements: expected an int >= 1"):
        fem.add_member(0, 1, 0, **COL)
    with pytest.raises(ModelError, match="dof of node 0: expected one of"):
        fem.fix(0, ["uw"])
    with pytest.raises(ModelError, match="mass 0 at node 1 m: expected a finite value >= 0"):
        fem.add_mass(1, -2.0)
    with pytest.raises(ModelError, match="inertia: expected"):
        fem.add_mass(1, 2.0, inertia=(1.0, -5.0, 1.0))
    with pytest.raises(ModelError, match=r"spring 0 \(0-1\) k: expected DOF names"):
        fem.add_spring(0, 1, k={"uq": 1.0})
    with pytest.raises(ModelError, match=r"spring 0 \(0-None\) k: expected finite values"):
        fem.add_spring(0, k=[-1.0] * 6)
    with pytest.raises(ModelError, match=r"k: expected a DOF-name mapping, \(6,\)"):
        fem.add_spring(0, k=[1.0] * 5)
    with pytest.raises(ModelError, match="expected a symmetric"):
        fem.add_spring(0, k=np.triu(np.ones((6, 6))))
    with pytest.raises(ModelError, match="expected a positive semi-definite"):
        fem.add_spring(0, k=np.ones((6, 6)) - np.eye(6))
    with pytest.raises(ModelError, match="c_params: given without c"):
        fem.add_spring(0, k=[1.0] * 6, c_params={"ux": "c"})
    with pytest.raises(ModelError, match="k_params: expected DOF names"):
        fem.add_spring(0, k=[1.0] * 6, k_params={"ab": "k"})
    with pytest.raises(ModelError, match="expected two distinct nodes, got 0 twice"):
        fem.add_spring(0, 0, k=[1.0] * 6)
    with pytest.raises(ModelError, match=r"slave 2 expected in the plane z = 0\.0"):
        fem.add_rigid_diaphragm(0, [2])
    with pytest.raises(ModelError, match="normal: expected one of"):
        fem.add_rigid_diaphragm(0, [1], normal="w")  # type: ignore[arg-type]
    with pytest.raises(ModelError, match="rigid diaphragm: slave 0 is the master"):
        fem.add_rigid_diaphragm(0, [0])
    with pytest.raises(ModelError, match="rigid link: expected two distinct nodes"):
        fem.add_rigid_link(1, 1)
    fem.add_rigid_link(0, 1)
    with pytest.raises(ModelError, match=r"DOF 1:ux is already a slave"):
        fem.add_rigid_link(2, 1)


def test_assembly_errors_name_the_entry():
    fem = FEModel()
    with pytest.raises(ModelError, match="model: expected at least one node"):
        fem.assemble()
    fem.add_node(0, (0, 0, 0))
    fem.add_node(1, (1, 0, 0))
    fem.add_spring(0, 1, k={"ux": 1.0})
    with pytest.raises(ModelError, match=r"free DOF\(s\) have neither stiffness nor mass"):
        fem.assemble()
    fem2 = FEModel()
    fem2.add_node(0, (0, 0, 0))
    fem2.add_node(1, (1, 0, 0))
    fem2.add_rigid_link(0, 1)
    fem2.fix(1, "ux")
    with pytest.raises(ModelError, match="DOF 1:ux is both fixed and a slave"):
        fem2.assemble()
    fem3 = FEModel()
    fem3.add_node(0, (0, 0, 0))
    fem3.add_node(1, (1, 0, 0))
    fem3.add_rigid_link(0, 1)
    fem3.add_rigid_link(1, 0)
    with pytest.raises(ModelError, match="a cycle of rigid links"):
        fem3.assemble()
    fem4 = FEModel()
    fem4.add_node(0, (0, 0, 0))
    fem4.add_spring(0, k=[1.0] * 6, k_params={"ux": "k"})
    fem4.add_mass(0, 1.0, inertia=(1, 1, 1), m_param="k")
    with pytest.raises(ModelError, match="parameter 'k': enters both K and M"):
        fem4.assemble()
    fem5 = FEModel()
    fem5.add_node(0, (0, 0, 0))
    fem5.add_spring(0, k=[1.0] * 6, k_params={"ux": "k", "uy": "k"}.copy())
    fem5.add_spring(0, k=[2.0] * 6, k_params={"uz": "k"})
    with pytest.raises(ModelError, match="parameter 'k': nominal values differ"):
        fem5.assemble()
    asm = fem4_ok()
    with pytest.raises(ModelError, match="node: unknown node id 5"):
        asm.full_dof_index(5, "ux")
    with pytest.raises(ModelError, match="dof of node 0: expected one of"):
        asm.full_dof_index(0, "ww")
    with pytest.raises(ShapeError, match="u: expected first dimension 6"):
        asm.expand(np.zeros(5))


def fem4_ok():
    fem = FEModel()
    fem.add_node(0, (0, 0, 0))
    fem.add_spring(0, k=[1.0] * 6)
    return fem.assemble()
