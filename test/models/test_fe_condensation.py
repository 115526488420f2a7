"""Exact condensation of massless DOFs: same eigenvalues, still affine in theta."""

from __future__ import annotations

import itertools
from pathlib import Path

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


# --- modal-twin model info FILE --condense (a matrix model from the user's FE tool) -------


def _spring_chain_npz(path, n_mass: int = 8, n_between: int = 2, m: float = 50.0,
                      k_a: float = 3e6, k_b: float = 1.5e6):
    """Masses joined by chains of ``n_between + 1`` springs through massless DOFs.

    The first half of the links is substructure ``a`` (k_a), the rest ``b`` (k_b); the
    first link ties mass 0 to the ground. Returns the DOFs of the masses and the stiffness
    of each mass-to-mass link (``n_between + 1`` springs in series: k / (n_between + 1)).
    """
    n = n_mass * (n_between + 1)
    mass_dofs = np.arange(n_mass) * (n_between + 1) + n_between  # ground, 2 massless, mass ...
    K = {"a": np.zeros((n, n)), "b": np.zeros((n, n))}
    links = []
    prev = -1  # ground
    for j, dm in enumerate(mass_dofs):
        name, k = ("a", k_a) if j < n_mass // 2 else ("b", k_b)
        chain = [prev, *range(dm - n_between, dm + 1)]
        for p, q in itertools.pairwise(chain):
            for i1, i2, s in ((p, p, k), (q, q, k), (p, q, -k), (q, p, -k)):
                if i1 >= 0 and i2 >= 0:
                    K[name][i1, i2] += s
        links.append(k / (n_between + 1))
        prev = dm
    M = np.zeros((n, n))
    M[mass_dofs, mass_dofs] = m
    meas = [int(mass_dofs[-1]), 1]  # a sensor on a massless DOF stays a master
    np.savez(path, M=M, K_a=K["a"], K_b=K["b"], measured_dofs=np.array(meas))
    return mass_dofs, np.array(links), m


def test_model_info_condense_prints_the_full_models_frequencies(tmp_path, capsys):
    import json

    from modal_twin.cli import main

    npz = tmp_path / "chain.npz"
    _, links, m = _spring_chain_npz(npz)
    # known answer: the equivalent chain of the masses alone, springs in series summed
    n = links.size
    Ke = np.zeros((n, n))
    for j, k in enumerate(links):
        Ke[j, j] += k
        if j:
            Ke[j - 1, j - 1] += k
            Ke[j - 1, j] -= k
            Ke[j, j - 1] -= k
    f_true = np.sqrt(np.linalg.eigvalsh(Ke / m)) / (2 * np.pi)
    assert main(["model", "info", str(npz), "--condense", "--show", "5", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    c = d["condensed"]
    assert (c["n_dof_before"], c["n_dof_after"]) == (24, 9)  # 8 masses + the massless sensor
    assert c["n_condensed"] == 15 and c["n_kept_mixed"] == 0
    np.testing.assert_allclose(c["f_hz"], d["f_hz"], rtol=1e-8)
    np.testing.assert_allclose(d["f_hz"], f_true[:5], rtol=1e-8)
    assert main(["model", "info", str(npz), "--condense", "--show", "3"]) == 0
    out = capsys.readouterr().out
    assert "condensed: 24 -> 9 DOFs (15 massless DOFs in" in out
    assert f"{f_true[0]:12.6f} {f_true[0]:17.6f}" in out
    # without the flag: the table as before
    assert main(["model", "info", str(npz), "--show", "3"]) == 0
    assert "condensed" not in capsys.readouterr().out


def test_model_info_condense_refuses_a_yaml_model(capsys):
    from modal_twin.cli import main

    yaml_model = Path(__file__).resolve().parents[2] / "config/structures/building.yaml"
    assert main(["model", "info", str(yaml_model), "--condense"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--condense: only for matrix models" in err[0]
