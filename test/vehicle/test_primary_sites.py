"""The car's primary suspensions as device sites (issue 20, item 6).

A primary stroke ``z_b + a_i beta_b - z_i`` holds the track input: the device there sees
``B q + E u`` and its rate ``B q' + Ed u``. Known answers: the nominal plant's primary force
channel is ``k_p d + c_p d'`` of its stroke channel; the registry's ``linear`` law at a
primary site with the element's own k and c reproduces the nominal plant to round-off (the
element's K, C and track terms of Gamma leave, the device's input feed-through brings them
back); a constant track lift leaves every primary stroke at zero (the car rides up as a
rigid body); friction there adds a force bounded by its slip force, and the evidence and
screening on that site's stroke and force name friction.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from modal_twin.diagnosis.device_kind import input_share, measured_device
from modal_twin.diagnosis.evidence import device_evidence
from modal_twin.diagnosis.fitting import simulate_record
from modal_twin.diagnosis.record import Record
from modal_twin.diagnosis.restoring_force import state_derivatives
from modal_twin.diagnosis.screening import screen_components
from modal_twin.models.effects import EffectSpec
from modal_twin.models.track import random_profile, wheelset_inputs
from modal_twin.models.vehicle import PRIMARY_SITES
from modal_twin.models.vehicle_factory import VehicleFactory

ROOT = Path(__file__).resolve().parents[2]
VEHICLE = ROOT / "config" / "vehicles" / "trailer_car.yaml"
FS = 200.0
T = 8.0
FRICTION = EffectSpec("primary_2", "regularised_friction",
                      {"Fs": 1000.0, "Fk": 1000.0, "kp": 1.0, "v_s": 0.0})


@pytest.fixture(scope="module")
def factory() -> VehicleFactory:
    return VehicleFactory(VEHICLE)


def _record(factory: VehicleFactory, u: np.ndarray) -> Record:
    p = factory.plant()
    return Record(FS, p.input_names, u, p.channel_names,
                  np.zeros((len(p.channel_names), u.shape[1])), "track")


def _track(factory: VehicleFactory, seed: int = 3) -> np.ndarray:
    v = 300.0 / 3.6
    return wheelset_inputs(random_profile(v * T + 40.0, rng=seed), factory.spec.axle_x, v,
                           FS, T)


def _stroke_rate(d: np.ndarray, u: np.ndarray, i: int) -> np.ndarray:
    """Rate of wheelset i's primary stroke: of the bogie's point (smooth, spectral) less the
    track's own rate (an input: the rough track has content up to Nyquist)."""
    return state_derivatives(d + u[i], FS, f_max_hz=95.0)[1] - u[4 + i]


def test_primary_force_channel_is_the_closed_form_of_its_stroke(
        factory: VehicleFactory) -> None:
    p = factory.plant()
    u = _track(factory)
    rec = _record(factory, u)
    y = simulate_record(p, rec)
    for i, site in enumerate(PRIMARY_SITES):
        assert measured_device(p.channels, rec, site) == ([f"{site}_dz"], [f"{site}_fz"])
        d = y[p.channel_names.index(f"{site}_dz")]
        f = y[p.channel_names.index(f"{site}_fz")]
        kp = factory.spec.suspension("k_primary", i // 2)
        cp = factory.spec.suspension("c_primary", i // 2)
        err = (f - (kp * d + cp * _stroke_rate(d, u, i)))[50:-50]
        assert np.max(np.abs(err)) < 0.01 * np.max(np.abs(f))


def test_linear_law_at_every_primary_is_the_nominal_element(factory: VehicleFactory) -> None:
    rec = _record(factory, _track(factory))
    y0 = simulate_record(factory.plant(), rec)
    y1 = simulate_record(factory.plant([EffectSpec(s, "linear", {}) for s in PRIMARY_SITES]),
                         rec)
    scale = np.max(np.abs(y0), axis=1, keepdims=True)
    # from sample 1 on: sample 0 is the twin's rest state, where a device reports no force
    # (the linear element's output row there has the track's -k_p z_i(0))
    assert np.max(np.abs(y1 - y0)[:, 1:] / scale) < 1e-9


def test_a_constant_track_lift_leaves_no_primary_stroke(factory: VehicleFactory) -> None:
    # all wheelsets raised by 5 mm over 0.5 s (smooth), then held for 20 s: the car follows
    # as a rigid body, its primary strokes return to zero, the law's as the element's
    t = np.arange(0.0, 20.0, 1.0 / FS)
    r = np.clip(t / 0.5, 0.0, 1.0)
    z = 5e-3 * (3 * r**2 - 2 * r**3)
    vz = 5e-3 * np.where(t < 0.5, 6 * (r - r**2) / 0.5, 0.0)
    u = np.vstack([z, z, z, z, vz, vz, vz, vz])
    rec = _record(factory, u)
    for effects in ([], [EffectSpec("primary_3", "linear", {})]):
        p = factory.plant(effects)
        y = simulate_record(p, rec)
        for site in PRIMARY_SITES:
            d = y[p.channel_names.index(f"{site}_dz")]
            assert np.max(np.abs(d)) > 1e-5  # it moved while the track rose
            assert np.max(np.abs(d[-int(FS):])) < 1e-6 * 5e-3


def test_friction_at_a_primary_is_bounded_and_screened(factory: VehicleFactory) -> None:
    p = factory.plant([FRICTION])
    u = _track(factory)
    y = simulate_record(p, _record(factory, u))
    d = y[p.channel_names.index("primary_2_dz")]
    f = y[p.channel_names.index("primary_2_fz")]
    kp = factory.spec.suspension("k_primary", 0)
    cp = factory.spec.suspension("c_primary", 0)
    extra = (f - kp * d - cp * _stroke_rate(d, u, 1))[50:-50]
    assert np.quantile(np.abs(extra), 0.9) == pytest.approx(1000.0, rel=0.15)
    assert np.max(np.abs(extra)) < 1000.0 * 1.3
    # the evidence differentiates only the bogie's part of the stroke; the track's rate is
    # an input (input_share), so the rough track does not show as a damping error
    site = factory.sites["primary_2"]
    rec = _record(factory, u)
    share = input_share(factory, "primary_2", rec, 1)
    assert share is not None
    np.testing.assert_array_equal(share[0][0], -u[1])
    np.testing.assert_array_equal(share[1][0], -u[5])
    ev = device_evidence("primary_2", d[None, :], f[None, :], site.k, site.c, FS,
                         input_share=share)
    scores = ev.family_scores()
    assert max(scores, key=scores.__getitem__) == "friction", scores
    scr = screen_components({"primary_2": d[None, :]}, {"primary_2": f[None, :]},
                            {"primary_2": site}, {"primary_2": 1.0}, FS,
                            laws=("regularised_friction", "bouc_wen", "maxwell"),
                            input_shares={"primary_2": share})
    assert scr[0].law == "regularised_friction", [(c.law, round(c.score, 3)) for c in scr]
