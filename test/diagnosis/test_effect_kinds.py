"""The registry of effect kinds: one owner per law, one family vocabulary, roles not names."""

from __future__ import annotations

import numpy as np
import pytest

from modal_twin.channels import ChannelSpec, device_channels
from modal_twin.diagnosis.device_kind import FAMILY_LAWS, family_of
from modal_twin.diagnosis.effect_kind import Facts
from modal_twin.diagnosis.evidence import FAMILY_GROUPS
from modal_twin.diagnosis.kinds import FAMILIES, KINDS, NOTHING, effect_laws, kind_of
from modal_twin.diagnosis.pipeline import diagnose
from modal_twin.diagnosis.record import Record
from modal_twin.errors import ConfigError, OptionError
from modal_twin.models.devices.registry import FAMILIES as DEVICE_FAMILIES
from modal_twin.models.devices.registry import LAWS, law_entry
from modal_twin.models.effects import MOUNT_LAW, SENSOR_LAWS, EffectSpec


def test_every_kind_is_registered_under_its_name_and_reports_in_the_vocabulary() -> None:
    assert list(KINDS) == ["device", "parameter", "mount", "sensor"]
    for name, kind in KINDS.items():
        assert kind.name == name
        assert set(kind.families) <= set(FAMILIES), name
    assert len(FAMILIES) == len(set(FAMILIES))
    assert FAMILIES[-1] == NOTHING
    # the device laws' families come first, in the registry's order
    assert FAMILIES[:len(DEVICE_FAMILIES)] == DEVICE_FAMILIES
    assert set(FAMILIES) == {*DEVICE_FAMILIES, "mass", "elastic_attachment", "sensor", NOTHING}


def test_every_law_has_exactly_one_kind() -> None:
    laws = effect_laws()
    assert len(laws) == len(set(laws))
    assert set(LAWS) | {"added_mass", "stiffness", "damping", MOUNT_LAW, *SENSOR_LAWS} == set(laws)
    for law in laws:
        assert [k.name for k in KINDS.values() if k.owns(law)] == [kind_of(law).name], law
    assert kind_of("bilinear_elastic").name == "device"  # an alias of the registry
    with pytest.raises(OptionError, match=r"unknown effect law 'magic'; valid: \['linear'"):
        kind_of("magic")


# parameters that make each device law show each family its registry entry lists
_SHOWS = {
    "linear": [({"k": 2.0, "c": 1.0}, "stiffness"), ({"k": 1.0, "c": 3.0}, "damping")],
    "bilinear": [({"ratio": 0.5}, "softening"), ({"ratio": 1.5}, "hardening")],
    "smooth_bilinear": [({"ratio": 0.5}, "softening"), ({"ratio": 1.5}, "hardening")],
    "cubic": [({"k3": -1.0}, "softening"), ({"k3": 1.0}, "hardening")],
    "bilinear_hysteretic": [({"ub": 0.03}, "hysteresis"), ({"ub": 1e-4}, "friction")],
}


def test_device_families_are_those_of_the_device_registry() -> None:
    facts = Facts(nominal_k=1.0, nominal_c=1.0, drift_scale=0.1)
    for law, entry in LAWS.items():
        shown = {family_of(EffectSpec("A", law, p), facts) for p, _ in _SHOWS.get(law, [({}, "")])}
        assert shown == set(entry.families) if law in _SHOWS else shown == {entry.families[0]}
        for p, fam in _SHOWS.get(law, []):
            assert family_of(EffectSpec("A", law, p), facts) == fam, (law, p)
    # the evidence at the place decides a law that can be either
    assert family_of(EffectSpec("A", "bilinear_hysteretic", {"ub": 0.03}),
                     Facts(drift_scale=0.1, evidence_family="friction")) == "friction"
    # the laws tried for a family are registry laws, under families of the vocabulary
    for fam, laws in FAMILY_LAWS.items():
        assert fam in DEVICE_FAMILIES
        assert all(law_entry(x).name == x for x in laws)
    # the evidence's regression groups are families (elastic: softening or hardening)
    assert set(FAMILY_GROUPS) - {"elastic"} <= set(FAMILIES)
    assert {"softening", "hardening"} <= set(FAMILIES)


def test_kinds_report_family_place_and_version_entry() -> None:
    mass = EffectSpec("m_F2", "added_mass", {"m_F2": 2000.0})
    assert kind_of(mass.law).family(mass, Facts()) == "mass"
    assert kind_of(mass.law).place(mass) == "F2"
    assert kind_of("stiffness").place(EffectSpec("k_RB2_x", "stiffness", {})) == "RB2"
    theta, effects = kind_of(mass.law).into_version({"E_1": 3e10}, (), mass)
    assert theta == {"E_1": 3e10, "m_F2": 2000.0} and effects == ()
    slip = EffectSpec("ESB1", "stick_slip", {"Fs": 1.0, "Fk": 1.0})
    old = EffectSpec("ESB1", "cubic", {"k3": 1.0})
    mount = EffectSpec("box", MOUNT_LAW, {"f_hz": 8.0, "zeta": 0.05})
    theta, effects = kind_of(slip.law).into_version({}, (old, mount), slip)
    assert theta == {} and effects == (mount, slip)  # one law per site: the new one wins
    gain = EffectSpec("F1_C1_x", "sensor_gain", {"gain": 1.1})
    assert kind_of(gain.law).family(gain, Facts()) == "sensor"
    assert kind_of(mount.law).family(mount, Facts()) == "elastic_attachment"
    with pytest.raises(OptionError, match="sensor effect is found by the diagnosis"):
        kind_of(gain.law).start(None, "F1_C1_x", gain.law, None)  # type: ignore[arg-type]


def test_device_channels_are_found_by_role_and_place_not_by_name() -> None:
    chans = [ChannelSpec("iso_force_N", "force", "ESB1", "y", role="device_force"),
             ChannelSpec("lvdt_2", "displacement", "ESB1", "y", role="device_drift"),
             ChannelSpec("lvdt_1", "displacement", "ESB1", "x", role="device_drift"),
             ChannelSpec("ESB2_dx", "displacement", "ESB2", "x"),  # role from the name
             ChannelSpec("roof_x", "acceleration", "ESB1", "x")]
    assert device_channels(chans, "ESB1", "device_drift") == ["lvdt_1", "lvdt_2"]
    assert device_channels(chans, "ESB1", "device_force") == ["iso_force_N"]
    assert device_channels(chans, "ESB2", "device_drift") == ["ESB2_dx"]
    with pytest.raises(ConfigError, match="got 'output'"):
        device_channels(chans, "ESB1", "output")


def test_diagnose_refuses_an_unknown_option() -> None:
    rec = Record(100.0, ("ax",), np.zeros((1, 50)), ("F0_C1_x",), np.zeros((1, 50)))
    with pytest.raises(TypeError, match="n_fits"):
        diagnose(None, rec, rec, n_fits=2)  # type: ignore[arg-type, call-arg]
