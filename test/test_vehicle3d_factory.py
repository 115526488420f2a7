"""The 3D car as a model factory (modal_twin.models.vehicle3d_factory; issue 23 items 4, 7)."""

from __future__ import annotations

import numpy as np
import pytest

from modal_twin.errors import OptionError
from modal_twin.models.effects import EffectSpec
from modal_twin.models.loading import load_model
from modal_twin.models.reduced import ReducedSystem
from modal_twin.models.vehicle3d import build_vehicle3d
from modal_twin.models.vehicle3d_factory import Vehicle3DFactory
from modal_twin.models.vehicle3d_spec import DEFAULT_VEHICLE3D_YAML
from modal_twin.twin.simulator import simulate

FS = 400.0


@pytest.fixture(scope="module")
def factory() -> Vehicle3DFactory:
    f = load_model(DEFAULT_VEHICLE3D_YAML)
    assert isinstance(f, Vehicle3DFactory)
    return f


def _frf(s: ReducedSystem, w: float) -> np.ndarray:
    """Outputs per input of M x'' + C x' + K x = -Gamma w at ``i w`` (closed form)."""
    X = np.linalg.solve(-w**2 * s.M + 1j * w * s.C + s.K, -s.Gamma)
    n = s.n
    return (s.C_out[:, :n] @ X + 1j * w * s.C_out[:, n:2 * n] @ X
            - w**2 * s.C_out[:, 2 * n:] @ X + s.D_out)


def _car_frf(spec, w: float) -> np.ndarray:
    """The floor rows of the 3D car's own first-order model at ``i w``."""
    v = build_vehicle3d(spec)
    A, B = v.state_space(spec.speed)
    Cy, Dy, _ = v.floor_outputs(A, B)
    return Cy @ np.linalg.solve(1j * w * np.eye(A.shape[0]) - A, B) + Dy


@pytest.mark.parametrize("f_hz", [0.4, 1.5, 6.0, 25.0])
def test_plant_is_the_cars_linear_model(factory: Vehicle3DFactory, f_hz: float) -> None:
    # Maxwell dampers as coordinates p' = e: the same input-output map as the first-order car
    w = 2 * np.pi * f_hz
    H = _frf(factory.plant().system, w)[:6]
    Hv = _car_frf(factory.spec, w)
    assert np.abs(H - Hv).max() <= 1e-10 * np.abs(Hv).max()


def test_parameter_is_the_elements_value(factory: Vehicle3DFactory) -> None:
    # the four yaw dampers at 30 %: the car built from a file with that damper value
    c = 0.3 * factory.spec.v("yaw_damper", "c")
    th = {f"c_yaw_damper_{b}{s}": c for b in (1, 2) for s in "LR"}
    w = 2 * np.pi * 2.0
    H = _frf(factory.with_theta(th).plant().system, w)[:6]
    Hv = _car_frf(factory.spec.with_values(yaw_damper={"c": c}), w)
    assert np.abs(H - Hv).max() <= 1e-10 * np.abs(Hv).max()
    H0 = _frf(factory.plant().system, w)[:6]
    assert np.abs(H - H0).max() > 1e-3 * np.abs(Hv).max()  # the change is seen
    info = factory.parameter_info("c_yaw_damper_1L")
    assert (info.kind, info.nominal) == ("damping", factory.spec.v("yaw_damper", "c"))


def test_every_secondary_element_is_a_site(factory: Vehicle3DFactory) -> None:
    sites = factory.sites
    for b in (1, 2):
        for s in "LR":
            for name in (f"air_spring_{b}{s}_x", f"air_spring_{b}{s}_y", f"air_spring_{b}{s}_z",
                         f"vertical_damper_{b}{s}", f"yaw_damper_{b}{s}"):
                assert name in sites
        assert f"lateral_damper_{b}" in sites and f"anti_roll_bar_{b}" in sites
    # the primary vertical elements too (session 8): their stroke holds the track's share
    for a in range(1, 5):
        for s in "LR":
            for name in (f"primary_{a}{s}_x", f"primary_{a}{s}_y", f"primary_{a}{s}_z",
                         f"primary_{a}{s}_cz"):
                assert name in sites
    assert len(sites) == 8 * 4 + 4 * 5 + 2 * 3  # axle boxes, air springs + dampers, bogies
    b = factory.spec.v("primary", "half_spacing")
    assert factory.site_inputs("primary_3R_z") == ({"zt3": -1.0, "phit3": pytest.approx(b)},
                                                   {"dzt3": -1.0, "dphit3": pytest.approx(b)})
    assert factory.site_inputs("air_spring_1L_z") == ({}, {})
    with pytest.raises(OptionError):
        factory.plant([EffectSpec("primary_1L_w", "linear", {})])
    with pytest.raises(OptionError):
        factory.with_theta({"c_nothing": 1.0})


def _track(nt: int, seed: int = 3) -> np.ndarray:
    rng = np.random.default_rng(seed)
    u = np.cumsum(rng.standard_normal((12, nt)), axis=1) * 1e-5  # smooth enough
    return np.vstack([u, np.gradient(u, 1.0 / FS, axis=1)])


def test_linear_law_at_every_spring_site_is_the_nominal_car(factory: Vehicle3DFactory) -> None:
    springs = [n for n, d in factory.sites.items() if d.c[0] == 0.0]
    assert len(springs) >= 20
    w = _track(800)
    p0 = factory.plant()
    p1 = factory.plant([EffectSpec(n, "linear", {}) for n in springs])
    assert len(p1.system.devices) == len(springs)
    # (from sample 1: at a run's first sample the twin puts a device at rest, so the force
    # of a primary vertical spring, whose stroke holds the track, is 0 there, while the
    # linear element's force row reads k h' u of this track, which does not start at 0)
    y0 = p0.measure(simulate(p0.system, w, 1.0 / FS))[:, 1:]
    y1 = p1.measure(simulate(p1.system, w, 1.0 / FS))[:, 1:]
    scale = np.abs(y0).max(axis=1, keepdims=True)
    assert np.abs(y1 - y0).max(axis=None) <= 1e-9 * scale.max()
    assert np.all(np.abs(y1 - y0) <= 1e-7 * scale + 1e-300)


def test_force_channels_are_the_elements_laws(factory: Vehicle3DFactory) -> None:
    p = factory.plant()
    names = p.channel_names
    r = simulate(p.system, _track(800), 1.0 / FS)
    y = p.measure(r)
    el = {e.name: e for e in factory.elements()}
    for site in ("air_spring_1L_y", "primary_2R_x", "traction_rod_1"):
        axis = el[site].axis
        d, f = y[names.index(f"{site}_d{axis}")], y[names.index(f"{site}_f{axis}")]
        assert np.abs(d).max() > 0
        np.testing.assert_allclose(f, el[site].k * d, rtol=1e-9, atol=1e-9 * np.abs(f).max())
    # Maxwell: force / stroke = k i w c / (k + i w c), the closed-form complex stiffness
    for site in ("yaw_damper_1L", "lateral_damper_2", "vertical_damper_2R"):
        e = el[site]
        i_d, i_f = names.index(f"{site}_d{e.axis}"), names.index(f"{site}_f{e.axis}")
        for f_hz in (0.5, 4.0, 20.0):
            w = 2 * np.pi * f_hz
            H = _frf(p.system, w)
            j = int(np.argmax(np.abs(H[i_d])))
            kw = e.k * 1j * w * e.c / (e.k + 1j * w * e.c)
            assert abs(H[i_f, j] / H[i_d, j] - kw) <= 1e-9 * abs(kw)


def test_a_worn_yaw_damper_law_moves_the_lateral_floor(factory: Vehicle3DFactory) -> None:
    # a linear law at a Maxwell site is its joint and dashpot in parallel; with 30 % of c
    # the lateral floor response changes
    w = _track(1600)
    p0 = factory.plant()
    c = factory.sites["yaw_damper_1L"].c[0]
    assert factory.sites["yaw_damper_1L"].k[0] == factory.spec.v("yaw_damper", "k_series")
    p1 = factory.plant([EffectSpec("yaw_damper_1L", "linear", {"c": 0.3 * c})])
    y0 = p0.measure(simulate(p0.system, w, 1.0 / FS))
    y1 = p1.measure(simulate(p1.system, w, 1.0 / FS))
    names = p0.channel_names
    i = names.index("floor_front_y")
    assert np.std(y1[i] - y0[i]) > 1e-3 * np.std(y0[i])
    j = names.index("yaw_damper_1L_fx")  # along x (longitudinal anti-yaw damper)
    assert p1.sources[j][0] == "force"  # the device's force is the channel


def test_the_shell_car_plant_is_the_shell_cars_model(factory: Vehicle3DFactory) -> None:
    # the carbody by option: the Craig-Bampton shell in the same second-order form
    from modal_twin.models.vehicle3d import default_carbody
    from modal_twin.models.vehicle3d_factory import build_vehicle3d_plant

    spec = factory.spec.with_carbody("shell")
    cb = default_carbody(spec)
    assert cb.n > 6
    p = build_vehicle3d_plant(spec, carbody=cb)
    v = build_vehicle3d(spec, cb)
    A, B = v.state_space(spec.speed)
    Cy, Dy, _ = v.floor_outputs(A, B)
    for f_hz in (1.0, 9.0):
        w = 2 * np.pi * f_hz
        Hv = Cy @ np.linalg.solve(1j * w * np.eye(A.shape[0]) - A, B) + Dy
        H = _frf(p.system, w)[:6]
        assert np.abs(H - Hv).max() <= 1e-9 * np.abs(Hv).max()


def test_a_file_without_yaw_dampers_has_no_yaw_damper_sites(factory: Vehicle3DFactory) -> None:
    from modal_twin.models.vehicle3d_factory import build_vehicle3d_plant

    spec = factory.spec.with_values(yaw_damper={"c": 0.0})
    p = build_vehicle3d_plant(spec, device_channels=("lateral_damper_1",))
    assert "lateral_damper_1_fy" in p.channel_names
    with pytest.raises(OptionError):
        build_vehicle3d_plant(spec, device_channels=("yaw_damper_1L",))
    w = 2 * np.pi * 1.2
    Hv = _car_frf(spec, w)
    assert np.abs(_frf(p.system, w)[:6] - Hv).max() <= 1e-10 * np.abs(Hv).max()


def test_a_primary_dashpot_site_takes_the_track_rate(factory: Vehicle3DFactory) -> None:
    # the linear law at a primary vertical dashpot: its rate holds the track's rate (Ed);
    # the nominal car from sample 1, the force channel c (g' q' + h' u') of the element
    w = _track(800)
    p0 = factory.plant()
    p1 = factory.plant([EffectSpec("primary_2R_cz", "linear", {})])
    y0 = p0.measure(simulate(p0.system, w, 1.0 / FS))[:, 1:]
    y1 = p1.measure(simulate(p1.system, w, 1.0 / FS))[:, 1:]
    assert np.abs(y1 - y0).max() <= 1e-9 * np.abs(y0).max()
    i = p1.channel_names.index("primary_2R_cz_fz")
    assert p1.sources[i][0] == "force" and np.std(y1[i]) > 0.0
    # the device's force is c times the rate of the stroke channel (bogie less track)
    d = y1[p1.channel_names.index("primary_2R_cz_dz")]
    rate = np.gradient(d, 1.0 / FS)
    c_fit = float(np.dot(y1[i], rate) / np.dot(rate, rate))
    assert c_fit == pytest.approx(factory.spec.v("primary", "cz"), rel=0.02)
