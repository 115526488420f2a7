"""The car's secondary suspensions as device sites, with stroke and force channels (issue 20).

Known answers: the nominal plant's force channel is the closed form ``k_s d + c_s d'`` of
its stroke channel; the registry's ``linear`` law at a site with the element's own k and c
reproduces the nominal plant to round-off; a friction law there adds the friction force
to the force channel (channel force minus ``k d + c d'`` bounded by the slip force); the
device kind finds the stroke and force of a site by role and place and screens friction
there first on a record of a car with friction in its front secondary damper.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from modal_twin.diagnosis.device_kind import measured_device
from modal_twin.diagnosis.evidence import device_evidence
from modal_twin.diagnosis.fitting import simulate_record
from modal_twin.diagnosis.record import Record
from modal_twin.diagnosis.restoring_force import state_derivatives
from modal_twin.diagnosis.screening import screen_components
from modal_twin.errors import OptionError
from modal_twin.models.effects import EffectSpec
from modal_twin.models.track import random_profile, wheelset_inputs
from modal_twin.models.vehicle import PRIMARY_SITES, SUSPENSION_SITES, build_vehicle
from modal_twin.models.vehicle_factory import VehicleFactory
from modal_twin.models.vehicle_spec import equipment_mounted

ROOT = Path(__file__).resolve().parents[2]
VEHICLE = ROOT / "config" / "vehicles" / "trailer_car.yaml"
FS = 200.0
T = 8.0
FRICTION = EffectSpec("secondary_front", "regularised_friction",
                      {"Fs": 800.0, "Fk": 800.0, "kp": 1.0, "v_s": 0.0})


@pytest.fixture(scope="module")
def factory() -> VehicleFactory:
    return VehicleFactory(VEHICLE)


def _empty_record(factory: VehicleFactory, seed: int = 3, plant=None) -> Record:
    p = factory.plant() if plant is None else plant
    v = 300.0 / 3.6
    u = wheelset_inputs(random_profile(v * T + 40.0, rng=seed), factory.spec.axle_x, v, FS, T)
    return Record(FS, p.input_names, u, p.channel_names,
                  np.zeros((len(p.channel_names), u.shape[1])), "track")


def _rate(d: np.ndarray) -> np.ndarray:
    return state_derivatives(d, FS, f_max_hz=40.0)[1]


def test_channels_by_role_and_the_nominal_force_closed_form(factory: VehicleFactory) -> None:
    p = factory.plant()
    assert set(factory.sites) == {*SUSPENSION_SITES, *PRIMARY_SITES}
    rec = _empty_record(factory)
    y = simulate_record(p, rec)
    for b, site in enumerate(SUSPENSION_SITES):
        drift, force = measured_device(p.channels, rec, site)
        assert (drift, force) == ([f"{site}_dz"], [f"{site}_fz"])
        d = y[p.channel_names.index(drift[0])]
        f = y[p.channel_names.index(force[0])]
        ks = factory.spec.suspension("k_secondary", b)
        cs = factory.spec.suspension("c_secondary", b)
        inner = slice(50, -50)  # the spectral rate is exact away from the ends
        err = f - (ks * d + cs * _rate(d))
        assert np.max(np.abs(err[inner])) < 0.01 * np.max(np.abs(f))
    # a plant without device channels (the default of build_vehicle) keeps the floor only
    assert all(n.startswith("floor_") for n in build_vehicle(factory.spec).channel_names)


def test_linear_law_at_a_site_is_the_nominal_element(factory: VehicleFactory) -> None:
    rec = _empty_record(factory)
    y0 = simulate_record(factory.plant(), rec)
    y1 = simulate_record(factory.plant([EffectSpec("secondary_rear", "linear", {})]), rec)
    scale = np.max(np.abs(y0), axis=1, keepdims=True)
    assert np.max(np.abs(y1 - y0) / scale) < 1e-9


def test_friction_at_a_site_adds_a_bounded_slip_force(factory: VehicleFactory) -> None:
    p = factory.plant([FRICTION])
    y = simulate_record(p, _empty_record(factory))
    d = y[p.channel_names.index("secondary_front_dz")]
    f = y[p.channel_names.index("secondary_front_fz")]
    ks = factory.spec.suspension("k_secondary", 0)
    cs = factory.spec.suspension("c_secondary", 0)
    extra = (f - ks * d - cs * _rate(d))[50:-50]
    assert np.quantile(np.abs(extra), 0.9) == pytest.approx(800.0, rel=0.15)
    assert np.max(np.abs(extra)) < 800.0 * 1.3


def test_unknown_site_is_refused(factory: VehicleFactory) -> None:
    with pytest.raises(OptionError, match="device laws at"):
        factory.plant([EffectSpec("primary_front", "stick_slip", {"Fs": 1.0})])


def test_screening_names_friction_at_the_front_secondary(factory: VehicleFactory) -> None:
    p = factory.plant([FRICTION])
    y = simulate_record(p, _empty_record(factory))
    cols = {n: y[p.channel_names.index(n)][None, :] for n in p.channel_names}
    site = factory.sites["secondary_front"]
    u, f = cols["secondary_front_dz"], cols["secondary_front_fz"]
    ev = device_evidence("secondary_front", u, f, site.k, site.c, FS)
    scores = ev.family_scores()
    assert max(scores, key=scores.__getitem__) == "friction", scores
    scr = screen_components({"secondary_front": u}, {"secondary_front": f},
                            {"secondary_front": site}, {"secondary_front": 1.0}, FS,
                            laws=("regularised_friction", "bouc_wen"))
    assert scr[0].law == "regularised_friction", [(c.law, round(c.score, 3)) for c in scr]


@pytest.fixture(scope="module")
def hung(tmp_path_factory: pytest.TempPathFactory) -> VehicleFactory:
    """The car with EQ1 on elastic hangers in its file (10 Hz, 5 %)."""
    text = VEHICLE.read_text()
    assert text.count("mount: rigid") == 1
    path = tmp_path_factory.mktemp("car") / "hung_car.yaml"
    path.write_text(text.replace("mount: rigid", "mount: elastic"))
    return VehicleFactory(path)


def test_an_elastic_hanger_is_a_site_with_its_stroke_and_force(hung: VehicleFactory) -> None:
    assert list(hung.sites) == [*SUSPENSION_SITES, "EQ1", *PRIMARY_SITES]
    p = hung.plant()
    rec = _empty_record(hung)
    assert measured_device(p.channels, rec, "EQ1") == (["EQ1_dz"], ["EQ1_fz"])
    y = simulate_record(p, rec)
    d, f = y[p.channel_names.index("EQ1_dz")], y[p.channel_names.index("EQ1_fz")]
    e = hung.spec.equipment_named("EQ1")
    err = (f - (e.k_mount * d + e.c_mount * _rate(d)))[50:-50]
    assert np.max(np.abs(err)) < 0.01 * np.max(np.abs(f))
    y1 = simulate_record(hung.plant([EffectSpec("EQ1", "linear", {})]), rec)
    assert np.max(np.abs(y1 - y) / np.max(np.abs(y), axis=1, keepdims=True)) < 1e-9


def test_a_softening_hanger_reports_the_law_force(factory: VehicleFactory) -> None:
    mount = EffectSpec("EQ1", "elastic_mount", {"f_hz": 10.0, "zeta": 0.0, "u_s": 4e-5,
                                                "r": 0.35})
    # bolted in the file: a mount candidate, not a site, and no channels of its own
    assert "EQ1" not in factory.sites
    assert "EQ1_dz" not in factory.plant([mount]).channel_names
    spec = equipment_mounted(factory.spec, "EQ1", 10.0, 0.0, u_s=4e-5, r=0.35)
    p = build_vehicle(spec, device_channels=("EQ1",))
    y = simulate_record(p, _empty_record(factory, plant=p))
    d, f = y[p.channel_names.index("EQ1_dz")], y[p.channel_names.index("EQ1_fz")]
    k = factory.spec.equipment_named("EQ1").mass * (2 * np.pi * 10.0) ** 2
    want = np.where(np.abs(d) <= 4e-5, k * d, 0.35 * k * d + 0.65 * k * 4e-5 * np.sign(d))
    assert np.max(np.abs(d)) > 4e-5  # the record reaches the softer branch
    assert np.max(np.abs(f - want)) < 1e-6 * np.max(np.abs(f))
