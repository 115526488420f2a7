"""Exact condensation of massless DOFs: same eigenvalues, still affine in theta."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import yaml

from modal_twin.errors import ShapeError
from modal_twin.models.building import DEFAULT_BUILDING_YAML, build_building
from modal_twin.models.fe import FEModel, solve_modes
from modal_twin.models.fe.condensation import condense_massless, expand_shapes
from modal_twin.models.structure_yaml import parse_structure


def portal(n_split: int):
    """Two columns (E_col) and a beam (E_beam) meshed into massless elements; joint masses."""
    m = FEModel()
    for name, xyz in {"a": (0, 0, 0), "b": (0, 0, 3), "c": (4, 0, 3), "d": (4, 0, 0)}.items():
        m.add_node(name, xyz)
    sec = {"G": 1e10, "A": 0.1, "Iy": 1e-3, "Iz": 1e-3, "J": 2e-3, "rho": 0.0}
    m.add_member("a", "b", n_split, E=3e10, E_param="E_col", orientation=(1, 0, 0), **sec)
    m.add_member("d", "c", n_split, E=3e10, E_param="E_col", orientation=(1, 0, 0), **sec)
    m.add_member("b", "c", n_split, E=2e10, E_param="E_beam", orientation=(0, 0, 1), **sec)
    m.add_mass("b", 1000.0, inertia=(10.0, 10.0, 10.0))
    m.add_mass("c", 1000.0, inertia=(10.0, 10.0, 10.0))
    m.fix("a")
    m.fix("d")
    return m.assemble()


@pytest.mark.parametrize("theta", [None, {"E_col": 2.4e10, "E_beam": 2.6e10}])
def test_same_eigenvalues_as_the_full_model_at_any_theta(theta):
    asm = portal(12)
    c = condense_massless(asm.parametric)
    assert c.masters.size == 12  # the two joints with mass; 3 x 11 interior nodes condensed
    full = solve_modes(asm.parametric.K(theta), asm.parametric.M(theta), 6)
    red = solve_modes(c.par.K(theta), c.par.M(theta), 6)
    np.testing.assert_allclose(red.f_hz, full.f_hz, rtol=1e-9)
    Phi = expand_shapes(c, asm.parametric, red.Phi, asm.parametric.theta_vector(theta))
    mac = (Phi.T @ full.Phi) ** 2 / np.outer((Phi**2).sum(0), (full.Phi**2).sum(0))
    np.testing.assert_allclose(np.abs(np.diag(mac)), 1.0, atol=1e-8)


def test_finer_mesh_condenses_to_the_coarse_model():
    # frames with no distributed mass are exact with one element: any split, same modes
    coarse = solve_modes(portal(1).parametric.K(), portal(1).parametric.M(), 6).f_hz
    c = condense_massless(portal(40).parametric)
    np.testing.assert_allclose(solve_modes(c.par.K(), c.par.M(), 6).f_hz, coarse, rtol=1e-8)


def test_kept_dofs_and_bad_keep():
    asm = portal(4)
    n = asm.n_dof
    c = condense_massless(asm.parametric, keep=[0, 1])
    assert {0, 1} <= set(c.masters.tolist())
    with pytest.raises(ShapeError, match=f"keep: expected DOF indices in \\[0, {n}\\)"):
        condense_massless(asm.parametric, keep=[n])
    with pytest.raises(ShapeError, match="keep: expected a mask of shape"):
        condense_massless(asm.parametric, keep=np.ones(3, dtype=bool))


def test_meshed_building_condenses_to_its_joints():
    doc = yaml.safe_load(DEFAULT_BUILDING_YAML.read_text(encoding="utf-8"))
    frames = []
    for f in doc["frames"]:
        chain = [f["n1"], *f.get("via", []), f["n2"]]
        for a, b in itertools.pairwise(chain):
            g = {k: v for k, v in f.items() if k not in ("n1", "n2", "via")}
            frames.append({**g, "n1": a, "n2": b, "n_elements": 4})
    doc["frames"] = frames
    # element-group factors overlap the moduli on every column DOF: a condensation that stays
    # affine in theta needs one parameter per massless group, so the meshed variant updates
    # the moduli only
    doc.pop("groups", None)
    big = build_building(spec=parse_structure(doc, source="building split 4"))
    par = big.assembly.parametric
    c = condense_massless(par, np.flatnonzero(np.abs(big.S).sum(axis=0) > 0))
    assert c.masters.size < 0.1 * big.n_dof
    th = par.theta0 * np.linspace(0.8, 1.2, par.n_theta)
    full = solve_modes(par.K(th), par.M(th), 12).f_hz
    np.testing.assert_allclose(solve_modes(c.par.K(th), c.par.M(th), 12).f_hz, full, rtol=1e-8)
