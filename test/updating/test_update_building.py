"""Building of [004]: truth recovery from identified modes, 004-like staged update, device k-c."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import scipy.signal as sig

from modal_twin.errors import OptionError, ShapeError, SignalError
from modal_twin.identification import n4sid, select_modes, stabilization_diagram
from modal_twin.models.building import DEFAULT_BUILDING_YAML, build_building
from modal_twin.models.fe import solve_modes
from modal_twin.models.loading import load_model
from modal_twin.twin.simulator import simulate
from modal_twin.updating.device_ls import device_kc, fit_devices, kc_bounds, kc_nominal
from modal_twin.updating.problem import ModeTargets
from modal_twin.updating.stages import Stage, building_stages, staged_update

FS = 50.0


@pytest.fixture(scope="module")
def bld():
    return build_building()


def table_input(n, seed):
    """Band-limited (0-20 Hz) random table accelerations, x y z, m/s^2."""
    rng = np.random.default_rng(seed)
    b, a = sig.butter(4, 20.0, fs=FS)
    ag = np.zeros((6, n))
    ag[:3] = sig.lfilter(b, a, rng.standard_normal((3, n)), axis=1)
    return ag


@pytest.fixture(scope="module")
def truth_run(bld):
    """Truth: moduli -7 % / +7 % / -10 %, isolators +6 %; 200 s of simulated response."""
    par = bld.assembly.parametric
    truth = {"E_Fc36": 3.278e10 * 0.93, "E_Fc27": 2.915e10 * 1.07, "E_Fc21": 2.585e10 * 0.90}
    for n in par.names:
        if n.startswith("k_"):
            truth[n] = par.theta0[par.index(n)] * 1.06
    plant = load_model(DEFAULT_BUILDING_YAML, theta=truth, n_modes=16).plant()
    ag = table_input(int(200 * FS), 1)
    res = simulate(plant.system, ag, 1.0 / FS)
    return truth, plant, ag, res


def test_a_truth_parameters_from_identified_modes(bld, truth_run):
    truth, plant, ag, res = truth_run
    rng = np.random.default_rng(2)
    y = plant.measure(res)[:42]  # the 42 absolute accelerations
    y = y + 0.02 * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)  # 2 % noise
    sw = n4sid(ag[:3], y, FS, orders=np.arange(20, 62, 4), f_min_hz=4.0)
    mm = select_modes(stabilization_diagram(sw), f_range_hz=(0.3, 21.0))
    assert mm.f_hz.size >= 10  # 3 isolation + >= 7 superstructure modes
    t = ModeTargets.from_modal_model(mm)
    par = bld.assembly.parametric
    sup, iso = building_stages(par, f_split_hz=2.0, prior_weight_devices=1.0,
                               global_stage=False)
    sup, iso = replace(sup, use_std=True), replace(iso, use_std=True)
    out = staged_update(par, bld.S, t, [sup, iso, replace(sup, name="superstructure 2")])
    tv = par.theta_vector(truth)
    err = out.theta / tv - 1.0
    last = out.stages[-1]
    u = last.uncertainty
    assert u is not None
    # the claim holds for the parameters the uncertainty marks as determined: here all three
    # moduli (std 0.01-0.04 % from the n4sid standard deviations); measured errors <= 0.06 %
    assert u.determined.all()
    for nm in last.names:
        assert abs(err[par.index(nm)]) < 0.02, nm
    # twelve isolator rates from three isolation modes: individually undetermined ...
    iso_res = out.stages[1]
    assert iso_res.uncertainty is not None
    assert not iso_res.uncertainty.determined.any()
    # ... but the isolation frequencies are matched and the total x / y stiffness comes back
    assert np.nanmax(np.abs(iso_res.pairing_after.df_rel)) < 0.005
    for ax in "xy":
        idx = [par.index(n) for n in par.names if n.startswith("k_") and n.endswith(ax)]
        assert out.theta[idx].sum() == pytest.approx(tv[idx].sum(), rel=0.02)


def test_b_004_like_nominal_far_off(bld):
    par = bld.assembly.parametric
    # lateral and torsional modes 20-30 % off (Table 7 of [004]: 18-29 %); the vertical
    # mode only 12 %, as the bearings' vertical stiffness (not a modulus) governs it
    truth = {"E_Fc36": 3.278e10 * 0.62, "E_Fc27": 2.915e10 * 0.58, "E_Fc21": 2.585e10 * 0.62}
    th = par.theta_vector(truth)
    s = solve_modes(par.K(th), par.M(th), 12)
    s0 = solve_modes(par.K(), par.M(), 12)
    off = s0.f_hz[3:9] / s.f_hz[3:9] - 1.0
    # nominal superstructure modes 16-24 % too high (Table 7 of [004]: 18-29 %), the
    # vertical mode (bearing-dominated) 10 %
    assert off.max() > 0.24
    assert np.sort(off)[1] > 0.19  # all but the vertical mode >= 19.7 %
    rng = np.random.default_rng(3)
    f = s.f_hz * (1 + 0.003 * rng.standard_normal(12))  # identification scatter 0.3 %
    phi = bld.S @ s.Phi
    phi = phi + 0.03 * np.abs(phi).max(axis=0) * rng.standard_normal(phi.shape)
    t = ModeTargets.create(f[:9], phi[:, :9], std_f_hz=0.003 * f[:9])
    sup, iso = building_stages(par, f_split_hz=2.0, prior_weight_devices=1.0)
    out = staged_update(par, bld.S, t, [replace(sup, rel_bounds=0.6),
                                        replace(iso, global_stage=False)],
                        reduced=True, maxiter=20)
    sup_res = out.stages[0]
    assert sup_res.pairing_before.n_matched < 6  # outside the 10 % window before
    assert sup_res.pairing_after.n_matched == 6
    assert sup_res.max_abs_df_pct < 1.5
    assert sup_res.min_mac > 0.9
    assert out.stages[1].max_abs_df_pct < 1.5
    # the two moduli the superstructure modes carry come back within 2 % (E_Fc36, of the
    # base beams only, is weakly determined)
    for nm in ("E_Fc27", "E_Fc21"):
        assert out.theta[par.index(nm)] == pytest.approx(th[par.index(nm)], rel=0.02)


def test_stage_errors(bld):
    par = bld.assembly.parametric
    t = ModeTargets.create([5.0], np.ones((42, 1)))
    with pytest.raises(OptionError, match="stages: expected at least one"):
        staged_update(par, bld.S, t, [])
    with pytest.raises(OptionError, match="expected identified modes in"):
        staged_update(par, bld.S, t, [Stage("s", ("E_Fc27",), f_range_hz=(8.0, 9.0))])
    with pytest.raises(OptionError, match="expected at least one parameter"):
        staged_update(par, bld.S, t, [Stage("s", ())])
    with pytest.raises(OptionError, match="expected parameters for both stages"):
        building_stages(par, f_split_hz=2.0, moduli=())


# ---------------------------------------------------------------- device k-c, Eqs. (1)-(2)
def test_device_kc_from_simulated_building(bld, truth_run):
    truth, plant, _ag, res = truth_run
    ch = plant.measure(res)
    names = plant.channel_names
    drifts = {n[:-3] + "_" + n[-1]: ch[i] for i, n in enumerate(names) if n[-3:-1] == "_d"}
    forces = {n[:-3] + "_" + n[-1]: ch[i] for i, n in enumerate(names) if n[-3:-1] == "_f"}
    fits = fit_devices(drifts, forces, fs_hz=FS)
    assert len(fits) == 12
    par = bld.assembly.parametric
    for key, fit in fits.items():
        k_true = truth[f"k_{key}"]
        c_true = par.theta0[par.index(f"c_{key}")]
        assert fit.k == pytest.approx(k_true, rel=1e-3)  # measured <= 2e-4
        assert fit.c == pytest.approx(c_true, rel=0.02)  # velocity by differences
        assert fit.err_kc < 0.01
        assert fit.k_bounds[0] < fit.k < fit.k_bounds[1]
    nom = kc_nominal(fits)
    assert set(nom) == {f"{p}_{k}" for k in fits for p in "kc"}
    b = kc_bounds(fits, min_rel=0.2)
    lo, hi = b["k_RB1_x"]
    assert lo == pytest.approx(0.8 * fits["RB1_x"].k)
    assert hi == pytest.approx(1.2 * fits["RB1_x"].k)


def test_device_kc_bounds_closed_form_and_errors():
    rng = np.random.default_rng(5)
    x = rng.standard_normal(500)
    v = rng.standard_normal(500)
    f = 2.0e6 * x + 4.0e4 * v + 1.0e4 * rng.standard_normal(500)
    fit = device_kc(x, f, velocity=v)
    k_ls, c_ls = np.linalg.lstsq(np.column_stack([x, v]), f, rcond=None)[0]  # pseudo-inverse
    assert fit.k == pytest.approx(k_ls, rel=1e-10)
    assert fit.c == pytest.approx(c_ls, rel=1e-10)
    # the bounds give ||r + a_k dk|| = 1.5 ||r|| (Sec. 4 of [004])
    r = x * fit.k + v * fit.c - f
    for kb in fit.k_bounds:
        assert np.linalg.norm(r + x * (kb - fit.k)) == pytest.approx(1.5 * np.linalg.norm(r))
    # a negative unconstrained damping is clipped to 0 by the bounded solver
    neg = device_kc(x, 2.0e6 * x - 1.0e3 * v, velocity=v)
    assert neg.c == 0.0
    assert neg.k == pytest.approx(2.0e6, rel=1e-3)
    with pytest.raises(ShapeError, match="drift, force: expected equal lengths"):
        device_kc(x, f[:10], velocity=v)
    with pytest.raises(OptionError, match="fs_hz: expected a sample rate"):
        device_kc(x, f)
    with pytest.raises(OptionError, match="rho: expected"):
        device_kc(x, f, velocity=v, rho=1.0)
    with pytest.raises(ShapeError, match="velocity: expected 500 samples"):
        device_kc(x, f, velocity=v[:3])
    with pytest.raises(SignalError, match="expected finite samples"):
        device_kc(np.r_[x[:-1], np.nan], f, velocity=v)
    with pytest.raises(SignalError, match="expected a moving device"):
        device_kc(np.zeros(500), f, fs_hz=100.0)
    with pytest.raises(OptionError, match="forces: expected the keys"):
        fit_devices({"a": x}, {"b": f}, fs_hz=100.0)
