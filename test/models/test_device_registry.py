"""The one device registry: every law builds from a structure file and from effect params,
aliases build the same device with a one-time deprecation note, kind codes match the
jitted dispatch, the README's table is the registry's."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest

from modal_twin.errors import ConfigError, OptionError
from modal_twin.models.devices import registry
from modal_twin.models.devices._dispatch import evaluate_law
from modal_twin.models.devices.base import N_STATE
from modal_twin.models.devices.registry import (
    ALIASES,
    FAMILIES,
    LAWS,
    Site,
    build_device,
    build_effect_device,
    law_entry,
    law_names,
    markdown_table,
)
from modal_twin.models.effects import EFFECT_LAWS, EffectSpec, effect_device
from modal_twin.models.structure_yaml import DeviceSpec, make_device, parse_structure

ROOT = Path(__file__).resolve().parents[2]
K_NOM = np.array([2.0e6, 3.0e6])  # nominal k (x, y), N/m
C_NOM = np.array([1.0e4, 2.0e4])  # nominal c (x, y), N s/m
W = 1.5e6  # carried weight, N

# absolute parameters of every law (a structure file's params); a law added to the
# registry without an entry here fails test_every_law_is_covered
ABSOLUTE = {
    "linear": {},
    "stick_slip": {"Fs": 0.09 * W, "Fk": 0.06 * W, "kt": 2.5e6},
    "regularised_friction": {"Fs": 0.09 * W, "Fk": 0.06 * W, "kt": 2.5e6, "v_s": 0.05,
                             "v_reg": 0.005},
    # the relative forms keep the nominal anisotropy (k_y / k_x = 1.5) about the mean k
    "bilinear": {"k": 2e6, "kb": 0.75 * 2e6, "ub": 0.03, "y_scale": 1.5},
    "bilinear_hysteretic": {"k": 2e6, "kb": 0.75 * 2e6, "ub": 0.03, "y_scale": 1.5},
    "smooth_bilinear": {"k": 2e6, "kb": 0.75 * 2e6, "ub": 0.03, "n": 2.0, "y_scale": 1.5},
    "bouc_wen": {"A": 1.0, "beta": 0.5 / 0.03**2, "gamma": 0.5 / 0.03**2,
                 "K": [[2.0e6, 0.0], [0.0, 3.0e6]], "alpha": 0.3},
    "bouc_wen_esb": {"A": 47.13, "beta": 10.41, "gamma": 36.72},
    # the relative default: 0.2 of the nominal k per direction stays at full slip
    "iwan": {"k": list(0.8 * K_NOM), "kr": list(0.2 * K_NOM), "uy": 0.03},
    "cubic": {"k1": 2e6, "k1y": 3e6, "k3": 0.0},  # the mean k kept per direction
    "gap": {"k": 2.5e6, "g": 0.01},
    "prandtl": {"Fs": 1.0e4, "Kb": 5.0e5},
    "maxwell": {"kb": list(C_NOM / 0.02)},  # relaxing in 0.02 s, the effect default
}


def _site() -> Site:
    return Site("D1", K_NOM, C_NOM, W)


def _spec(law: str = "linear", params: dict | None = None) -> DeviceSpec:
    return DeviceSpec(name="D1", node="n1", k=K_NOM, c=C_NOM, kz=0.0, type=law,
                      params=dict(params or {}))


def _doc(law: str, params: dict) -> dict:
    """A two-node structure file with one device of law ``law``."""
    return {
        "materials": {"steel": {"E": 210e9, "nu": 0.3}},
        "sections": {"S": {"A": 0.01, "Iy": 1e-4, "Iz": 1e-4, "J": 1e-4}},
        "nodes": {"n1": [0.0, 0.0, 0.0], "n2": [0.0, 0.0, 3.0]},
        "frames": [{"n1": "n1", "n2": "n2", "material": "steel", "section": "S"}],
        "masses": [{"nodes": ["n2"], "m": 1000.0}],
        "devices": [{"name": "D1", "node": "n1", "type": law, "k": K_NOM.tolist(),
                     "c": C_NOM.tolist(), "kz": 1e9, "params": params}],
    }


@pytest.fixture
def fresh_notes(monkeypatch: pytest.MonkeyPatch) -> None:
    """Forget which aliases already logged their note (it is logged once per process)."""
    monkeypatch.setattr(registry, "_warned", set())


def test_every_law_is_covered() -> None:
    assert set(ABSOLUTE) == set(LAWS)
    assert set(EFFECT_LAWS) <= set(LAWS)
    for e in LAWS.values():
        assert set(e.families) <= set(FAMILIES), e.name
        assert set(e.defaults) <= set(e.parameters), e.name
        assert set(e.effect_defaults) <= set(e.effect_parameters), e.name


@pytest.mark.parametrize("law", list(LAWS))
def test_every_law_builds_from_a_structure_file(law: str) -> None:
    spec = parse_structure(_doc(law, ABSOLUTE[law]))
    dev = make_device(spec.devices[0], weight=W)
    entry = LAWS[law]
    assert type(dev) is entry.cls
    assert (dev.kind, dev.name) == (entry.kind, "D1")
    # a missing required parameter is named by the parser (laws with all-default params
    # have none to miss)
    required = set(entry.parameters) - set(entry.defaults)
    if required:
        missing = {k: v for k, v in ABSOLUTE[law].items() if k != sorted(required)[0]}
        with pytest.raises(ConfigError, match=r"devices\[0\] \(D1\)\.params: missing law"):
            parse_structure(_doc(law, missing))


@pytest.mark.parametrize("law", list(LAWS))
def test_every_law_builds_from_effect_params(law: str) -> None:
    entry = LAWS[law]
    params: dict = {} if entry.build_relative is not None else ABSOLUTE[law]
    dev = effect_device(_spec(), law, params, weight=W)
    assert type(dev) is entry.cls
    assert (dev.kind, dev.name) == (entry.kind, "D1")
    # the absolute form is accepted as effect params too, and gives the same device
    same = effect_device(_spec(), law, ABSOLUTE[law], weight=W)
    np.testing.assert_array_equal(same.params, build_device(law, ABSOLUTE[law], _site()).params)


@pytest.mark.parametrize(("law", "relative"), [
    ("linear", {}),
    ("stick_slip", {"kt_factor": 2.5e6 / 2.5e6}),
    ("regularised_friction", {}),
    ("bilinear", {"k": 2.5e6}),
    ("bilinear_hysteretic", {"k": 2.5e6}),
    ("bouc_wen", {}),
    ("iwan", {}),
    ("cubic", {"k": 2.5e6}),
    ("gap", {"k": 2.5e6}),
    ("maxwell", {}),
])
def test_relative_defaults_are_the_documented_absolute_values(law: str, relative: dict) -> None:
    """Effect defaults (table of the README) = the absolute law with those numbers."""
    rel = build_effect_device(law, relative, _site())
    absolute = build_device(law, ABSOLUTE[law], _site())
    np.testing.assert_array_equal(rel.params, absolute.params)
    assert rel.n_dir == absolute.n_dir


@pytest.mark.parametrize(("alias", "canonical", "params"), [
    ("bilinear_elastic", "bilinear", ABSOLUTE["bilinear"]),
    ("bouc_wen_sdp", "bouc_wen", ABSOLUTE["bouc_wen"]),
])
@pytest.mark.usefixtures("fresh_notes")
def test_alias_builds_the_same_device_with_one_deprecation_note(
        alias: str, canonical: str, params: dict, caplog: pytest.LogCaptureFixture) -> None:
    assert ALIASES[alias] == canonical
    with caplog.at_level(logging.WARNING, logger=registry.__name__):
        old = make_device(_spec(alias, params), weight=W)
        again = effect_device(_spec(), alias, params, weight=W)
        rel = effect_device(_spec(), alias, {}, weight=W)
    new = make_device(_spec(canonical, params), weight=W)
    assert type(old) is type(new) is type(again)
    np.testing.assert_array_equal(old.params, new.params)
    np.testing.assert_array_equal(again.params, new.params)
    np.testing.assert_array_equal(rel.params, effect_device(_spec(), canonical, {}).params)
    notes = [r.getMessage() for r in caplog.records if "deprecated" in r.getMessage()]
    assert notes == [f"device law {alias!r} is deprecated: use {canonical!r} (same law)"]
    assert law_entry(alias) is LAWS[canonical]
    # a structure file and an effect may still name it; downstream sees the canonical name
    assert parse_structure(_doc(alias, params)).devices[0].type == canonical
    assert EffectSpec("D1", alias, {}).law == canonical
    assert EffectSpec("D1", "elastic_mount", {}).law == "elastic_mount"  # not a device law


def test_kind_codes_equal_the_dispatch() -> None:
    """The dispatch called with a law's registry kind runs that law's jitted function."""
    # one code per law class, no gap (regularised_friction is a mode of CoulombFriction,
    # v_reg > 0, and shares its code and jitted function)
    by_class = {e.cls: e.kind for e in LAWS.values()}
    assert sorted(by_class.values()) == list(range(len(by_class)))
    assert all(by_class[e.cls] == e.kind for e in LAWS.values())
    rng = np.random.default_rng(7)
    for law, e in LAWS.items():
        dev = build_device(law, ABSOLUTE[law], _site())
        s = dev.initial_state()
        s[:2] = rng.normal(scale=0.01, size=2)
        u, v = rng.normal(scale=0.02, size=2), rng.normal(scale=0.1, size=2)
        out_d = [np.zeros(2), np.zeros((2, 2)), np.zeros((2, 2)), np.zeros(N_STATE)]
        out_l = [np.zeros(2), np.zeros((2, 2)), np.zeros((2, 2)), np.zeros(N_STATE)]
        evaluate_law(e.kind, dev.params, s, u, v, *out_d)
        e.law(dev.params, s, u, v, *out_l)
        # to the last bit but one: the dispatch compiles each law inside one function, where
        # LLVM may fuse a multiply-add the law's own compilation does not (smooth_bilinear's
        # force moved by one ulp once the iwan branch was added)
        for a, b in zip(out_d, out_l, strict=True):
            np.testing.assert_allclose(a, b, rtol=1e-14, atol=0.0, err_msg=law)
        assert np.any(out_d[0] != 0.0), law  # the law did run


def test_law_names_by_family_and_form() -> None:
    assert law_names(relative=True) == EFFECT_LAWS == (
        "linear", "stick_slip", "regularised_friction", "bilinear", "smooth_bilinear",
        "bilinear_hysteretic", "bouc_wen", "iwan", "cubic", "gap", "maxwell")
    assert law_names(family="friction") == ("stick_slip", "regularised_friction",
                                            "bilinear_hysteretic", "bouc_wen_esb", "prandtl")
    assert law_names(family="hardening") == ("bilinear", "smooth_bilinear", "cubic")
    assert law_names(family="damping") == ("linear", "maxwell")
    assert set(law_names(family="hysteresis")) == {
        "bilinear_hysteretic", "bouc_wen", "iwan", "bouc_wen_esb", "prandtl"}


def test_errors_name_the_value() -> None:
    with pytest.raises(OptionError, match=r"unknown device law 'magic'; valid: \['linear'"):
        law_entry("magic")
    with pytest.raises(OptionError, match=r"family: expected one of .*got 'colour'"):
        law_names(family="colour")
    with pytest.raises(OptionError, match=r"effect bouc_wen at D1: unknown parameters \['q'\]"):
        build_effect_device("bouc_wen", {"q": 1.0}, _site())
    with pytest.raises(OptionError, match="stick_slip at D1: mu_s / mu_k need the carried"):
        build_effect_device("stick_slip", {}, Site("D1", K_NOM, C_NOM))
    with pytest.raises(ConfigError, match=r"device D1: params\.W is 'auto' and no weight"):
        build_device("bouc_wen_esb", ABSOLUTE["bouc_wen_esb"], Site("D1", K_NOM, C_NOM))
    with pytest.raises(OptionError, match="unknown effect law 'magic'"):
        effect_device(_spec(), "magic", {})


def test_readme_table_is_the_registry() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert markdown_table() in readme


def test_regularised_friction_keeps_a_share_of_each_direction_dashpot() -> None:
    # c_factor is a share of the component's dashpot per direction, as kp of its spring
    d = build_effect_device("regularised_friction", {"c_factor": 0.3, "kp": 0.2}, _site())
    np.testing.assert_allclose(d.reference_damping(), np.diag(0.3 * C_NOM), rtol=1e-12)
    np.testing.assert_allclose(d.reference_stiffness(), np.diag(0.2 * K_NOM), rtol=1e-12)
    # the absolute form takes one value for both directions, or a pair
    one = build_device("regularised_friction", {**ABSOLUTE["regularised_friction"], "c": 5e3},
                       _site())
    np.testing.assert_allclose(one.reference_damping(), np.diag([5e3, 5e3]), rtol=1e-12)
    pair = build_device("regularised_friction",
                        {**ABSOLUTE["regularised_friction"], "c": [5e3, 7e3]}, _site())
    np.testing.assert_allclose(pair.reference_damping(), np.diag([5e3, 7e3]), rtol=1e-12)
