"""Structure format extensions: links, eccentric bodies, groups, damping parameters.

Known answers: the 2-DOF shear building, the one-storey eccentric system (lateral-torsional
quadratic), the kinetic energy of a rigid body at an offset, Rayleigh's zeta(w).
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
import yaml

from modal_twin.errors import ConfigError, ModelError, OptionError
from modal_twin.models.building import DEFAULT_BUILDING_YAML, build_building, modal_reduction
from modal_twin.models.building_factory import BuildingFactory
from modal_twin.models.building_parameters import vertical_shares
from modal_twin.models.fe import FEModel, rigid_body_mass_block
from modal_twin.models.structure_yaml import parse_structure

H = 3.0  # storey height, m
M1, M2 = 40e3, 30e3  # floor masses, kg
K1, K2 = 6e7, 4e7  # storey stiffness, N/m
J1, J2 = 5e5, 4e5  # floor rotary inertia, kg m^2
KT1, KT2 = 9e8, 7e8  # storey torsional stiffness, N m/rad
OUT_OF_PLANE = ["uz", "rx", "ry"]


def _shear_building() -> dict:
    """Two rigid floors (one node each) joined by storey links; floor 1 linked to ground."""
    return {
        "name": "shear2",
        "nodes": {"F1": [0.0, 0.0, H], "F2": [0.0, 0.0, 2 * H]},
        "links": [
            {"name": "S1", "n1": "F1", "k": [K1, K1, 0.0], "kr": [0.0, 0.0, KT1]},
            {"name": "S2", "n1": "F1", "n2": "F2", "k": [K2, K2, 0.0], "kr": [0.0, 0.0, KT2],
             "param": "k_s2"},
        ],
        "masses": [{"node": "F1", "m": M1, "inertia": [0.0, 0.0, J1]},
                   {"node": "F2", "m": M2, "inertia": [0.0, 0.0, J2]}],
        "supports": [{"node": "F1", "dofs": OUT_OF_PLANE}, {"node": "F2", "dofs": OUT_OF_PLANE}],
        "diaphragms": [{"name": "F1", "master": "F1", "nodes": ["F1"]},
                       {"name": "F2", "master": "F2", "nodes": ["F2"]}],
        "reduction": {"n_modes": 6},
    }


def _two_dof_omega2(m1: float, m2: float, k1: float, k2: float) -> np.ndarray:
    """Roots of m1 m2 w^4 - (m1 k2 + m2 (k1 + k2)) w^2 + k1 k2 = 0 (2-DOF shear building)."""
    a, b, c = m1 * m2, -(m1 * k2 + m2 * (k1 + k2)), k1 * k2
    d = np.sqrt(b * b - 4 * a * c)
    return np.array([(-b - d) / (2 * a), (-b + d) / (2 * a)])


def _omega2(doc: dict, theta: dict | None = None) -> np.ndarray:
    red = modal_reduction(build_building(spec=parse_structure(doc)), theta=theta)
    return np.sort(red.omega**2)


def test_storey_links_give_the_two_dof_closed_form() -> None:
    got = _omega2(_shear_building())
    lateral = _two_dof_omega2(M1, M2, K1, K2)
    torsion = _two_dof_omega2(J1, J2, KT1, KT2)
    want = np.sort(np.concatenate([lateral, lateral, torsion]))
    np.testing.assert_allclose(got, want, rtol=1e-10)


def test_link_factor_and_storey_group_scale_the_storey() -> None:
    doc = _shear_building()
    doc["groups"] = [{"name": "kst_2", "place": "storey 2", "between": ["F1", "F2"]}]
    spec = parse_structure(doc)
    assert spec.groups[0].links == ("S2",) and spec.groups[0].frames == ()
    for theta in ({"k_s2": 1.7}, {"kst_2": 1.7}):
        got = _omega2(doc, theta)
        lateral = _two_dof_omega2(M1, M2, K1, 1.7 * K2)
        torsion = _two_dof_omega2(J1, J2, KT1, 1.7 * KT2)
        np.testing.assert_allclose(got, np.sort(np.concatenate([lateral, lateral, torsion])),
                                   rtol=1e-10)


def test_link_dashpot_between_floors() -> None:
    doc = _shear_building()
    doc["links"].append({"name": "D", "n1": "F1", "n2": "F2", "c": [1e5, 0.0, 0.0],
                         "c_param": "c_d"})
    asm = parse_structure(doc).model.assemble()
    ux1, ux2 = asm.dof_index("F1", "ux"), asm.dof_index("F2", "ux")
    C = asm.parametric.C({"c_d": 2.0}).toarray()
    np.testing.assert_allclose(C[np.ix_([ux1, ux2], [ux1, ux2])],
                               2e5 * np.array([[1.0, -1.0], [-1.0, 1.0]]))
    assert np.count_nonzero(C) == 4


def test_point_mass_block_equals_rigid_body_kinetic_energy() -> None:
    rng = np.random.default_rng(3)
    r = np.array([1.5, -0.7, 0.4])
    J = np.array([[10.0, 1.0, 0.0], [1.0, 20.0, 2.0], [0.0, 2.0, 30.0]])
    m = 250.0
    fem = FEModel()
    fem.add_node("n", (2.0, 1.0, 3.0))
    fem.add_point_mass("n", m, offset=r, J=J, m_param="m_b")
    fem.add_spring("n", None, k=np.ones(6))
    asm = fem.assemble()
    Mb = asm.M.toarray()
    np.testing.assert_allclose(Mb, rigid_body_mass_block(r, J, m), rtol=1e-14)
    for _ in range(5):  # T = m |v + w x r|^2 / 2 + w' J w / 2, for any node motion (v, w)
        v, w = rng.standard_normal(3), rng.standard_normal(3)
        T = 0.5 * m * np.sum((v + np.cross(w, r)) ** 2) + 0.5 * w @ J @ w
        q = np.concatenate([v, w])
        assert 0.5 * q @ Mb @ q == pytest.approx(T, rel=1e-12)
    # one parameter scales translation, eccentricity and rotary inertia together
    np.testing.assert_allclose(asm.parametric.M({"m_b": 2 * m}).toarray(), 2 * Mb, rtol=1e-14)


def _one_storey(extra_mass: dict | None = None) -> dict:
    """A one-storey rigid floor (master at the stiffness centre C) on a ground link."""
    corners = {"N1": [-4.0, -3.0, H], "N2": [4.0, -3.0, H], "N3": [4.0, 3.0, H],
               "N4": [-4.0, 3.0, H]}
    doc = {
        "name": "one_storey",
        "nodes": {"C": [0.0, 0.0, H], **corners},
        "links": [{"name": "S", "n1": "C", "k": [K1, K2, 0.0], "kr": [0.0, 0.0, KT1]}],
        "masses": [{"node": "C", "m": M1, "inertia": [0.0, 0.0, J1]}],
        "supports": [{"node": n, "dofs": OUT_OF_PLANE} for n in ("C", *corners)],
        "diaphragms": [{"name": "F", "master": "C", "nodes": ["C", *corners]}],
        "reduction": {"n_modes": 3},
    }
    if extra_mass:
        doc["masses"].append(extra_mass)
    return doc


def _eccentric_closed_form(m: float, e: float, jc: float) -> np.ndarray:
    """w^2 of a floor (M1, J1) plus a body (m, jc) at (e, 0) on springs (K1, K2, KT1).

    x: K1 / (M1 + m); (y, rz): det([K2, 0; 0, KT1] - w^2 [mt, m e; m e, J]) = 0 with
    mt = M1 + m, J = J1 + jc + m e^2.
    """
    mt, jt = M1 + m, J1 + jc + m * e * e
    a, b, c = mt * jt - (m * e) ** 2, -(K2 * jt + KT1 * mt), K2 * KT1
    d = np.sqrt(b * b - 4 * a * c)
    return np.sort([K1 / mt, (-b - d) / (2 * a), (-b + d) / (2 * a)])


def test_eccentric_mass_moves_torsion_as_the_closed_form() -> None:
    m, e, jc = 8e3, 3.0, 2e4
    body = {"m": m, "at": "C", "offset": [e, 0.0, 0.0], "J": [0.0, 0.0, jc], "param": "m_body"}
    got = _omega2(_one_storey(body))
    np.testing.assert_allclose(got, _eccentric_closed_form(m, e, jc), rtol=1e-10)
    # the same body given by its position, on the floor: attached to the nearest node N2
    body2 = {"m": m, "at": [e, 0.0, H], "floor": "F", "J": [0.0, 0.0, jc]}
    np.testing.assert_allclose(_omega2(_one_storey(body2)), got, rtol=1e-10)
    # the torsion frequency falls with the eccentricity
    assert _eccentric_closed_form(m, e, jc)[2] < _eccentric_closed_form(m, 0.0, jc)[2]


def test_added_mass_family_of_the_factory(tmp_path) -> None:
    path = tmp_path / "one.yaml"
    path.write_text(yaml.safe_dump(_one_storey()))
    fac = BuildingFactory(path)
    p = fac.parameters()
    assert (p["madd_F"], p["madd_F_x"], p["madd_F_y"]) == (0.0, 0.0, 0.0)  # plan centre
    info = fac.parameter_info("madd_F")
    assert (info.kind, info.place, info.nominal, info.unit) == ("mass", "floor F", 0.0, "kg")
    assert fac.parameter_info("madd_F_x").lower == -4.0
    m, e = 8e3, 3.0
    new = fac.with_theta({"madd_F": m, "madd_F_x": e})
    np.testing.assert_allclose(np.sort(new.mb.omega**2), _eccentric_closed_form(m, e, 0.0),
                               rtol=1e-10)
    np.testing.assert_allclose(np.sort(fac.mb.omega**2), _eccentric_closed_form(0.0, 0.0, 0.0),
                               rtol=1e-10)
    with pytest.raises(OptionError, match="madd_F: expected an added mass >= 0 kg"):
        fac.with_theta({"madd_F": -1.0})
    # a body spread over the plan: its rotary inertia m rg^2 about its own centre (the
    # parallel-axis theorem on top of the eccentricity), the same closed form with J = m rg^2
    rg = 1.7
    spread = fac.with_theta({"madd_F": m, "madd_F_x": e, "madd_F_r": rg})
    np.testing.assert_allclose(np.sort(spread.mb.omega**2),
                               _eccentric_closed_form(m, e, m * rg * rg), rtol=1e-10)
    r_info = fac.parameter_info("madd_F_r")
    assert (r_info.nominal, r_info.lower, r_info.unit) == (0.0, 0.0, "m")
    assert r_info.upper == pytest.approx(5.0)  # half the 8 m x 6 m plan's diagonal
    with pytest.raises(OptionError, match="madd_F_r: expected a radius of gyration >= 0 m"):
        fac.with_theta({"madd_F": m, "madd_F_r": -1.0})


@pytest.mark.parametrize("at", [(6.857, 11.143), (4.0, 6.0), (8.0, 12.0), (0.5, 0.3)])
def test_vertical_shares_keep_the_load_and_its_moments(at) -> None:
    # a 2 x 3 bay plan (the shipped building's grid with its mid-span nodes)
    xy = np.array([[0, 0], [8, 0], [0, 12], [8, 12], [4, 12], [8, 9], [4, 0], [0, 6],
                   [8, 6], [0, 3], [4, 6]], dtype=float)
    w = vertical_shares(xy, np.asarray(at))
    assert np.all(w >= 0.0)
    assert w.sum() == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(w @ xy, at, atol=1e-3)  # the centroid where the mass is
    if tuple(at) == (8.0, 12.0):  # a mass on a node stays on it
        assert w[3] == pytest.approx(1.0, abs=1e-6)


def test_rayleigh_damping_gives_alpha_over_2w_plus_beta_w_over_2() -> None:
    doc = _shear_building()
    bld = build_building(spec=parse_structure(doc))
    f = np.sort(modal_reduction(bld, 6).f_hz)
    doc["damping"] = {"rayleigh": {"f_hz": [float(f[0]), float(f[-1])], "zeta": [0.02, 0.03],
                                   "alpha_param": "rayleigh_alpha",
                                   "beta_param": "rayleigh_beta"}}
    spec = parse_structure(doc)
    a, b = spec.damping.rayleigh_alpha, spec.damping.rayleigh_beta
    red = modal_reduction(build_building(spec=spec), 6)
    np.testing.assert_allclose(red.zeta, a / (2 * red.omega) + b * red.omega / 2, rtol=1e-12)
    order = np.argsort(red.omega)
    np.testing.assert_allclose(red.zeta[order][[0, -1]], [0.02, 0.03], rtol=1e-9)
    red2 = modal_reduction(build_building(spec=spec), 6, theta={"rayleigh_alpha": 2 * a,
                                                                  "rayleigh_beta": 0.0})
    np.testing.assert_allclose(red2.zeta, a / red2.omega, rtol=1e-12)


def test_modal_damping_factor_and_mode_groups() -> None:
    doc = _shear_building()
    doc["damping"] = {"default_zeta": 0.02, "param": "zeta_sup",
                      "mode_groups": [{"name": "zeta_hi", "modes": [5, 6]}]}
    bld = build_building(spec=parse_structure(doc))
    red = modal_reduction(bld, 6, theta={"zeta_sup": 1.5, "zeta_hi": 2.0})
    np.testing.assert_allclose(red.zeta, [0.03] * 4 + [0.06] * 2, rtol=1e-12)


@pytest.fixture(scope="module")
def building_doc() -> dict:
    return yaml.safe_load(DEFAULT_BUILDING_YAML.read_text())


def test_groups_and_damping_factor_leave_the_nominal_building_unchanged(building_doc) -> None:
    plain = copy.deepcopy(building_doc)
    del plain["groups"]
    del plain["damping"]["param"]
    a = build_building(spec=parse_structure(building_doc))
    b = build_building(spec=parse_structure(plain))
    for X, Y in ((a.assembly.K, b.assembly.K), (a.assembly.M, b.assembly.M),
                 (a.assembly.C, b.assembly.C)):
        assert abs(X - Y).max() <= 1e-10 * abs(Y).max()
    ra, rb = modal_reduction(a, 12), modal_reduction(b, 12)
    np.testing.assert_allclose(ra.f_hz, rb.f_hz, rtol=1e-10)
    np.testing.assert_allclose(np.abs(ra.Phi), np.abs(rb.Phi), atol=1e-10 * np.abs(rb.Phi).max())
    np.testing.assert_allclose(ra.C, rb.C, atol=1e-10 * np.abs(rb.C).max())
    par = a.assembly.parametric
    K1 = par.K({"kcol_1A": 1.0, "kst_2": 1.0})
    assert abs(K1 - a.assembly.K).max() == 0.0


def _frame_doc() -> dict:
    """A doubly symmetric one-storey frame: 4 columns, rigid floor, symmetric masses."""
    pos = {"1A": (0.0, 0.0), "1B": (6.0, 0.0), "2A": (0.0, 4.0), "2B": (6.0, 4.0)}
    nodes = {f"B_{k}": [x, y, 0.0] for k, (x, y) in pos.items()}
    nodes |= {f"T_{k}": [x, y, H] for k, (x, y) in pos.items()}
    return {
        "name": "frame",
        "materials": {"c": {"E": 3e10, "nu": 0.2}},
        "sections": {"COL": {"A": 0.25, "Iy": 8e-3, "Iz": 5e-3, "J": 8e-3}},
        "nodes": nodes,
        "frames": [{"n1": f"B_{k}", "n2": f"T_{k}", "material": "c", "section": "COL"}
                   for k in pos],
        "masses": [{"nodes": [f"T_{k}" for k in pos], "m": 10e3}],
        "diaphragms": [{"name": "T", "master": "T_1A", "nodes": [f"T_{k}" for k in pos]}],
        "supports": [{"node": f"B_{k}"} for k in pos],
        "groups": [{"name": f"kcol_{k}", "place": f"column line {k}", "nodes": [f"*_{k}"]}
                   for k in pos],
        "reduction": {"n_modes": 3},
    }


def test_column_line_factor_couples_sway_and_torsion() -> None:
    bld = build_building(spec=parse_structure(_frame_doc()))
    par = bld.assembly.parametric
    assert abs(par.K({"kcol_1A": 1.0}) - bld.assembly.K).max() == 0.0
    # linear in the factor: K(1.3) - K0 = 0.3 / 0.6 (K(1.6) - K0)
    d13 = (par.K({"kcol_1A": 1.3}) - bld.assembly.K).toarray()
    d16 = (par.K({"kcol_1A": 1.6}) - bld.assembly.K).toarray()
    np.testing.assert_allclose(d13, 0.5 * d16, atol=1e-9 * np.abs(d16).max())
    centre = np.array([3.0, 2.0, 0.0])

    def torsion_share(theta):  # rotation about z (plan centre) of each mode, mass-normalised
        red = modal_reduction(bld, 3, theta=theta)
        R = bld.assembly.rigid_body_modes(centre)
        G = red.Phi.T @ (bld.assembly.M @ R)  # participation in the 6 rigid-body motions
        return G, red

    G0, r0 = torsion_share(None)
    G1, r1 = torsion_share({"kcol_1A": 1.3})
    # symmetric: the sway modes carry no torsion; one stiffer corner column couples them
    assert np.abs(G0[:, 5]).min() < 1e-8 * np.abs(G0[:, 5]).max()
    sway = [j for j in range(3) if abs(G0[j, 5]) < 1e-6 * np.abs(G0[:, 5]).max()]
    assert len(sway) == 2
    tors = np.abs(G1[:, 5]) / np.abs(G1[:, 5]).max()
    assert tors.min() > 1e-3
    mac = (r0.Phi.T @ (bld.assembly.M @ r1.Phi)) ** 2  # mass-normalised shapes
    assert np.diag(mac).min() < 0.99
    assert np.all(r1.f_hz > r0.f_hz)  # a stiffer column raises every mode


def _err_cases() -> list:
    def mod(fn):
        doc = _shear_building()
        fn(doc)
        return doc

    return [
        (mod(lambda d: d["links"][0].update(n1="ghost")), ModelError,
         r"links\[0\] \(S1: 'ghost'-None\): .*unknown node id 'ghost'"),
        (mod(lambda d: d["links"][1].update(k=[K2, -1.0, 0.0])), ModelError,
         r"links\[1\] \(S2: 'F1'-'F2'\)\.k: expected values >= 0"),
        (mod(lambda d: d["links"][1].update(n2="F1")), ModelError,
         r"links\[1\] \(S2: 'F1'-'F1'\): expected two distinct nodes, got 'F1' twice"),
        (mod(lambda d: d["links"].append({"n1": "F1", "n2": "F2"})), ModelError,
         r"links\[2\] .*expected some stiffness"),
        (mod(lambda d: d["links"][1].update(spring=3)), ConfigError,
         r"links\[1\] .*unknown keys \['spring'\]"),
        (mod(lambda d: d["links"][1].update(c_param="c_x")), ConfigError,
         r"links\[1\] .*\.c_param: expected a name on a link with c > 0"),
        (mod(lambda d: d["masses"].append({"at": "F2", "offset": [1.0, 0.0, 0.0]})),
         ConfigError, r"masses\[2\]: missing key 'm'"),
        (mod(lambda d: d["masses"].append({"at": "F9", "m": 1.0})), ModelError,
         r"masses\[2\] \(at 'F9'\): .*unknown node id 'F9'"),
        (mod(lambda d: d["masses"].append({"at": [0, 0, H], "m": 1.0, "floor": "X"})),
         ConfigError, r"masses\[2\]\.floor: unknown floor 'X'; floors: \['F1', 'F2'\]"),
        (mod(lambda d: d["masses"].append({"at": "F2", "m": 1.0, "J": [0, -1, 0]})),
         ModelError, r"masses\[2\]\.J: expected values >= 0"),
        (mod(lambda d: d["masses"].append({"at": "F2", "node": "F2", "m": 1.0})),
         ConfigError, r"masses\[2\]: 'at' excludes \['node'\]"),
        (mod(lambda d: d.update(groups=[{"name": "g", "nodes": ["nothing*"]}])), ModelError,
         r"groups\[0\] \(g\): expected at least one frame or link"),
        (mod(lambda d: d.update(groups=[{"name": "g", "between": ["F1", "F7"]}])),
         ConfigError, r"groups\[0\] \(g\)\.between: expected two floor names"),
        (mod(lambda d: d.update(groups=[{"name": "g", "links": ["S9"]}])), ConfigError,
         r"groups\[0\] \(g\)\.links: unknown entries \['S9'\]"),
        (mod(lambda d: d.update(groups=[{"name": "g", "select": 1}])), ConfigError,
         r"groups\[0\] \(g\): unknown keys \['select'\]"),
        (mod(lambda d: d.update(damping={"rayleigh": {"alpha": 1.0, "f_hz": [1, 2]}})),
         ConfigError, r"damping\.rayleigh: expected \{alpha, beta\} or"),
        (mod(lambda d: d.update(damping={"rayleigh": {"f_hz": [1, 10], "zeta": [0.2, 0.01]}})),
         ModelError, r"damping\.rayleigh: these ratios need a negative coefficient"),
        (mod(lambda d: d.update(damping={"mode_groups": [{"name": "z", "modes": [3, 1]}]})),
         ConfigError, r"damping\.mode_groups\[0\]\.modes: expected \[first, last\]"),
        (mod(lambda d: d.update(damping={"zeta": 0.02})), ConfigError,
         r"damping: unknown keys \['zeta'\]"),
    ]


@pytest.mark.parametrize(("doc", "err", "match"), _err_cases())
def test_bad_entries_give_one_clear_error(doc, err, match) -> None:
    with pytest.raises(err, match=match):
        parse_structure(doc, source="s.yaml")


def test_errors_name_the_file() -> None:
    doc = _shear_building()
    doc["links"][0]["n1"] = "ghost"
    with pytest.raises(ModelError, match=r"^s\.yaml: links\[0\]"):
        parse_structure(doc, source="s.yaml")


def test_factory_lists_the_new_candidates() -> None:
    fac = BuildingFactory(DEFAULT_BUILDING_YAML)
    p = fac.parameters()
    for name in ("kcol_1A", "kcol_3B", "kst_1", "kst_4", "zeta_sup", "madd_R", "madd_R_x"):
        assert name in p
        assert name.startswith(fac.parameter_prefixes)
    # the isolators' linear k and c are candidates too (a stiffness or damping change there)
    assert all(n.startswith(fac.parameter_prefixes) for n in p if n.startswith(("k_", "c_")))
    cases = {"kcol_1A": ("stiffness", "column line 1A"),
             "kst_2": ("stiffness", "storey 2 (F1-F2)"),
             "zeta_sup": ("damping", "superstructure modes"), "madd_R": ("mass", "floor R"),
             "m_F2": ("mass", "floor F2"), "k_ESB1_x": ("stiffness", "device ESB1 x")}
    for name, (kind, place) in cases.items():
        info = fac.parameter_info(name)
        assert (info.kind, info.place) == (kind, place)
        assert info.lower <= info.nominal <= info.upper
    assert fac.parameter_info("madd_R").upper == pytest.approx(0.5 * 111e3, rel=1e-9)
    with pytest.raises(OptionError, match="parameter: expected one of"):
        fac.parameter_info("kcol_9Z")
    # with_theta accepts every kind at once; 1.0 factors give the nominal modes exactly
    same = fac.with_theta({"kcol_1A": 1.0, "zeta_sup": 1.0, "madd_R_x": 7.0})
    np.testing.assert_array_equal(same.mb.f_hz, fac.mb.f_hz)
    np.testing.assert_array_equal(same.mb.C, fac.mb.C)
    heavier = fac.with_theta({"madd_R": 5e3, "madd_R_x": 8.0, "madd_R_y": 12.0})
    assert np.all(heavier.mb.f_hz[3:8] < fac.mb.f_hz[3:8])
    with pytest.raises(OptionError, match=r"theta: unknown parameters \['kcol_9Z'\]"):
        fac.with_theta({"kcol_9Z": 1.2})


def test_vehicle_parameter_info() -> None:
    from modal_twin.models.vehicle_factory import VehicleFactory

    path = DEFAULT_BUILDING_YAML.parents[1] / "vehicles"
    files = sorted(path.glob("*.yaml"))
    if not files:
        pytest.skip("no vehicle file")
    fac = VehicleFactory(files[0])
    kinds = {n: fac.parameter_info(n).kind for n in fac.parameters()}
    assert kinds["k_primary"] == "stiffness" and kinds["c_secondary"] == "damping"
    assert kinds["zeta_carbody"] == "damping"
    assert all(k == "mass" for n, k in kinds.items() if n.startswith("m_"))
    info = fac.with_theta({"k_primary": 3e6}).parameter_info("k_primary")
    assert info.nominal == fac.parameters()["k_primary"]  # the file's value
    with pytest.raises(OptionError, match="parameter: expected one of"):
        fac.parameter_info("k_tertiary")
