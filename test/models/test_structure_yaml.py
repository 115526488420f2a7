"""Structure YAML loader: the shipped file, a one-floor block with a closed form, errors."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from modal_twin.errors import ConfigError, ModelError
from modal_twin.models.building import DEFAULT_BUILDING_YAML, build_building, modal_reduction
from modal_twin.models.devices import BilinearElastic, BoucWenESB, BoucWenSDP, CubicSpring
from modal_twin.models.structure_yaml import (
    DEVICE_TYPES,
    DeviceSpec,
    load_structure,
    make_device,
    parse_structure,
)

A, B, Z = 6.0, 4.0, 0.5  # block plan (x, y) and height, m
M_NODE = 5000.0  # kg at each of the 4 corners
KX, KY, KZ = 2.0e6, 3.0e6, 5.0e9  # N/m per device


def _block() -> dict:
    """One rigid floor (4 corner nodes, stiff edge beams) on four linear devices."""
    corners = {"n1": [0.0, 0.0, Z], "n2": [A, 0.0, Z], "n3": [A, B, Z], "n4": [0.0, B, Z]}
    edges = [("n1", "n2"), ("n2", "n3"), ("n3", "n4"), ("n4", "n1")]
    return {
        "name": "block",
        "materials": {"steel": {"E": 210e9, "nu": 0.3, "param": "E_steel"}},
        "sections": {"S": {"A": 0.01, "Iy": 1e-4, "Iz": 1e-4, "J": 1e-4}},
        "nodes": corners,
        "frames": [{"n1": a, "n2": b, "material": "steel", "section": "S"} for a, b in edges],
        "masses": [{"nodes": list(corners), "m": M_NODE}],
        "diaphragms": [{"name": "F", "master": "n1", "nodes": list(corners)}],
        "devices": [{"name": f"D{i}", "node": n, "type": "linear", "k": [KX, KY], "c": [0, 0],
                     "kz": KZ} for i, n in enumerate(corners, 1)],
        "sensors": [{"name": "S1", "node": "n1"}],
        "input": {"origin": [A / 2, B / 2, 0.0]},
        "damping": {"n_isolation_modes": 3, "default_zeta": 0.02},
        "reduction": {"n_modes": 6},
    }


def test_shipped_building_file_contents():
    spec = load_structure(DEFAULT_BUILDING_YAML)
    assert spec.name == "edefense_2013_base_isolated"
    assert len(spec.model.nodes) == 65
    assert [d.name for d in spec.devices] == ["ESB1", "RB1", "SDP1", "SDP2", "RB2", "ESB2"]
    assert [f.name for f in spec.floors] == ["F0", "F1", "F2", "F3", "R"]
    assert len(spec.sensors) == 14
    assert spec.yaml_mass == pytest.approx(686e3, rel=1e-12)
    assert spec.n_modes == 36
    assert spec.damping.superstructure_zeta == (0.0321, 0.0341, 0.0317, 0.0414)
    # Table 6 of [004], updated k of RB1 (kN/m) and c of SDP2 (Mg/s)
    assert spec.devices[1].k.tolist() == [1173e3, 1044e3]
    assert spec.devices[3].c.tolist() == [182.22e3, 180.45e3]


def test_block_frequencies_match_closed_form():
    """Rigid block on 4 springs: x, y and torsion frequencies are closed-form."""
    spec = parse_structure(_block())
    red = modal_reduction(build_building(spec=spec), 3)
    m = 4 * M_NODE
    jz = M_NODE * 4 * ((A / 2) ** 2 + (B / 2) ** 2)
    kt = 4 * (KX * (B / 2) ** 2 + KY * (A / 2) ** 2)
    want = np.sort([np.sqrt(4 * KX / m), np.sqrt(4 * KY / m), np.sqrt(kt / jz)]) / (2 * np.pi)
    np.testing.assert_allclose(red.f_hz, want, rtol=1e-9)


def test_numeric_strings_and_members_are_accepted():
    doc = _block()
    doc["materials"]["steel"]["E"] = "2.1e11"  # YAML 1.1 reads 2.1e11 as a string
    doc["frames"][0] = {"n1": "n1", "n2": "n2", "material": "steel", "section": "S",
                        "n_elements": 3}
    spec = parse_structure(doc)
    assert len(spec.model.nodes) == 6  # two nodes added inside the meshed member
    asm = spec.model.assemble()
    assert asm.parametric.theta0[asm.parametric.index("E_steel")] == 2.1e11


def _mutate(path: str, value: object) -> dict:
    doc = copy.deepcopy(_block())
    keys = path.split("/")
    tgt = doc
    for k in keys[:-1]:
        tgt = tgt[int(k)] if isinstance(tgt, list) else tgt[k]
    last = keys[-1]
    if value is _DELETE:
        del tgt[last]
    elif isinstance(tgt, list):
        tgt[int(last)] = value
    else:
        tgt[last] = value
    return doc


class _Delete:
    """The key is removed (its id is the same in every process: pytest-xdist compares them)."""

    def __repr__(self) -> str:
        return "<deleted>"


_DELETE = _Delete()

CASES = [
    ("masses/0/m", _DELETE, ConfigError, r"masses\[0\]: missing key 'm'"),
    ("masses/0/m", -1.0, ModelError, r"masses\[0\]\.m \(nodes .*\): expected >= 0, got -1"),
    ("masses/0/m", "heavy", ConfigError, r"masses\[0\]\.m .*expected a number, got 'heavy'"),
    ("masses/0/nodes", [], ConfigError, r"masses\[0\]\.nodes: expected a non-empty list"),
    ("masses/0/inertia", [1.0, -2.0, 3.0], ModelError, r"masses\[0\]\.inertia: expected"),
    ("masses/0/nodes", ["n1", "ghost"], ModelError,
     r"masses\[0\] \(node 'ghost'\): .*unknown node id 'ghost'"),
    ("devices/1/k", [KX, -5.0], ModelError, r"devices\[1\] \(D2\)\.k: expected values >= 0"),
    ("devices/1/k", [KX], ConfigError, r"devices\[1\] \(D2\)\.k: expected a list of 2"),
    ("devices/0/kz", -1.0, ModelError, r"devices\[0\] \(D1\)\.kz: expected >= 0"),
    ("devices/0/type", "magic", ConfigError,
     r"unknown device type 'magic'; valid: \['linear', 'stick_slip', 'regularised_friction', "
     r"'bilinear'"),
    ("devices/0/node", "ghost", ModelError, r"devices\[0\] \(D1\): .*unknown node id 'ghost'"),
    ("devices/0/params", [1, 2], ConfigError, r"devices\[0\] \(D1\)\.params: expected a mapping"),
    ("devices/1/name", "D1", ConfigError, r"duplicate device name 'D1'"),
    ("frames/0/n2", "ghost", ModelError, r"frames\[0\] \('n1'-'ghost'\): .*unknown node id"),
    ("frames/0/material", "gold", ConfigError, r"unknown material 'gold'; defined: \['steel'\]"),
    ("frames/0/section", "X", ConfigError, r"unknown section 'X'; defined: \['S'\]"),
    ("frames/0/via", ["n1"], ModelError, r"frames\[0\] \('n1'-'n2'\): .*distinct nodes"),
    ("frames", _DELETE, ConfigError, r"frames: missing section"),
    ("frames", {"a": 1}, ConfigError, r"frames: expected a list, got dict"),
    ("frames/0", "n1-n2", ConfigError, r"frames\[0\]: expected a mapping, got str"),
    ("materials/steel/E", -1.0, ModelError, r"materials\['steel'\]\.E: expected > 0"),
    ("materials/steel/nu", 0.7, ModelError, r"materials\['steel'\]\.nu: expected -1 < nu < 0.5"),
    ("materials", [1], ConfigError, r"materials: expected a mapping"),
    ("sections", None, ConfigError, r"sections: expected a mapping"),
    ("sections/S/Iy", 0.0, ModelError, r"sections\['S'\]\.Iy: expected > 0, got 0"),
    ("nodes", {}, ConfigError, r"nodes: expected a non-empty mapping"),
    ("nodes/n1", [0.0, 0.0], ConfigError, r"nodes\['n1'\]: expected a list of 3 numbers"),
    ("diaphragms/0/master", "ghost", ModelError, r"diaphragms\[0\] \(F\): .*ghost"),
    ("sensors/0/directions", ["x", "w"], ConfigError, r"sensors\[0\]\.directions: .*\['w'\]"),
    ("sensors/0/node", "ghost", ModelError, r"sensors\[0\] \(S1\): .*unknown node id"),
    ("damping/default_zeta", 1.5, ModelError, r"damping: expected damping ratios < 1"),
    ("damping/n_isolation_modes", -1, ConfigError, r"damping\.n_isolation_modes: expected"),
    ("damping/superstructure_zeta", 0.02, ConfigError, r"superstructure_zeta: expected a list"),
    ("damping", [0.02], ConfigError, r"damping: expected a mapping"),
    ("reduction/n_modes", 0, ConfigError, r"reduction\.n_modes: expected an int >= 1"),
    ("gravity", 0.0, ModelError, r"gravity: expected > 0"),
    ("materials/steel/E", float("inf"), ModelError, r"E: expected a finite value"),
    ("flavour", "sweet", ConfigError, r"unknown keys \['flavour'\]"),
]


@pytest.mark.parametrize(("path", "value", "exc", "match"), CASES,
                         ids=[f"{c[0]}={c[1]!r}"[:40] for c in CASES])
def test_bad_documents_name_the_entry(path, value, exc, match):
    with pytest.raises(exc, match=match):
        parse_structure(_mutate(path, value), source="block.yaml")


def test_frame_with_via_and_n_elements_is_refused():
    doc = _block()
    doc["frames"][0].update(via=["n3"], n_elements=2)
    with pytest.raises(ConfigError, match=r"give either 'via' or 'n_elements'"):
        parse_structure(doc)


def test_document_must_be_a_mapping():
    with pytest.raises(ConfigError, match=r"<dict>: document: expected a mapping at top level"):
        parse_structure([1, 2])


@pytest.mark.parametrize(("params", "exc", "match"), [
    ({"k": 1e6, "ub": 0.02}, ConfigError, r"missing law parameter 'kb'"),
    ({"k": 1e6, "kb": 2e6, "ub": 0.02}, ModelError, r"params: .*0 <= kb <= k"),
    ({"k": 1e6, "kb": 5e5, "ub": 0.02, "colour": 1}, ConfigError,
     r"unexpected law parameter"),
])
def test_device_law_parameters_are_checked(params, exc, match):
    doc = _block()
    doc["devices"][0].update(type="bilinear", params=params)
    with pytest.raises(exc, match=match):
        parse_structure(doc)


def test_load_structure_file_errors(tmp_path):
    with pytest.raises(ConfigError, match=r"missing.yaml: no such structure file"):
        load_structure(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("nodes: [1, 2\n", encoding="utf-8")
    with pytest.raises(ConfigError, match=r"bad.yaml: malformed YAML at line 2"):
        load_structure(bad)


def test_make_device_builds_every_law():
    base = {"name": "D", "node": "n1", "k": np.array([1e6, 1e6]), "c": np.array([1e3, 2e3]),
            "kz": 0.0}
    rb = make_device(DeviceSpec(**base, type="bilinear",
                                params={"k": 1e6, "kb": 5e5, "ub": 0.02}))
    assert isinstance(rb, BilinearElastic)
    assert rb.reference_damping().diagonal().tolist() == [1e3, 2e3]  # c defaults to nominal
    esb = make_device(DeviceSpec(**base, type="bouc_wen_esb",
                                 params={"A": 47.13, "beta": 10.41, "gamma": 36.72}),
                      weight=1.5e6)
    assert isinstance(esb, BoucWenESB)
    assert esb.params[9] == 1.5e6  # W
    sdp = make_device(DeviceSpec(**base, type="bouc_wen", params={
        "A": 1.0, "beta": 635.0, "gamma": 1102.0, "K": [[4e6, 0], [0, 4e6]], "alpha": 0.12}))
    assert isinstance(sdp, BoucWenSDP)
    cub = make_device(DeviceSpec(**base, type="cubic", params={"k1": 1e6, "k3": 1e9}))
    assert isinstance(cub, CubicSpring)
    lin = make_device(DeviceSpec(**base, type="linear"))
    assert lin.reference_stiffness().diagonal().tolist() == [1e6, 1e6]
    with pytest.raises(ConfigError, match=r"params.W is 'auto' and no weight was given"):
        make_device(DeviceSpec(**base, type="bouc_wen_esb",
                               params={"A": 1.0, "beta": 0.5, "gamma": 0.5}))
    with pytest.raises(ConfigError, match=r"unknown type 'spring'; valid: \["):
        make_device(DeviceSpec(**base, type="spring"))
    assert "bouc_wen" in DEVICE_TYPES  # one name per law; "bouc_wen_sdp" is an alias
    assert "bouc_wen_sdp" not in DEVICE_TYPES


def test_mass_parameter_needs_one_node_and_a_name():
    doc = _block()
    doc["masses"][0]["param"] = "m_all"  # several nodes share the entry
    with pytest.raises(ConfigError, match=r"masses\[0\]\.param.*one node"):
        parse_structure(doc)
    doc = _block()
    node = doc["masses"][0]["nodes"][0]
    doc["masses"].append({"node": node, "m": 500.0, "param": "m_extra"})
    par = parse_structure(doc).model.assemble().parametric
    assert "m_extra" in par.names
