"""Carbody zone updating ([002] Sec. 3-4) against a truth carbody with known zone errors.

The truth (``test/benchmarks/_truth/carbody.py``) is the same mesh rebuilt with its zone
table rewritten; its FRFs go through PolyMAX + LSFD, the screening and the differential
evolution, and the perturbed factors must come back; the 3D car on the updated carbody
then rides like the car on the truth's (closer than on the nominal carbody).
"""

from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from modal_twin.cli import main
from modal_twin.errors import OptionError, ShapeError
from modal_twin.identification.metrics import mpc
from modal_twin.models.carbody3d import CarbodyParams, build_carbody
from modal_twin.models.carbody3d_file import load_zone_factors, save_zone_factors
from modal_twin.models.vehicle3d import build_vehicle3d
from modal_twin.models.vehicle3d_ride import bending_peak, ride_run
from modal_twin.models.vehicle3d_spec import DEFAULT_VEHICLE3D_YAML, load_vehicle3d
from modal_twin.updating.carbody import (
    ZoneModel,
    driving_points,
    identify_test_modes,
    pair_test_modes,
    reciprocity,
    screen_zones,
    sensor_layout,
    update_zones,
)

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))
from _truth.carbody import modal_test, truth_params  # noqa: E402

TRUTH = {"E_side_wall": 0.88, "E_underframe": 1.10}  # both screened in (|r| >= 0.5)
BASE = CarbodyParams(n_length=10, n_width=2, n_height=2)


@pytest.fixture(scope="module")
def setup() -> dict:
    car = build_carbody(BASE)
    drives = driving_points(car)
    channels = sensor_layout(car) + drives
    test = modal_test(BASE, channels, drives, factors=TRUTH, noise=0.005)
    ident = identify_test_modes(test.H, test.f_hz, ((7.0, 13.8), (15.5, 21.0)))
    keep = np.flatnonzero(mpc(ident.shapes) >= 0.9)[:6]
    model = ZoneModel.build(car, channels, n_points=4)
    return {"car": car, "channels": channels, "test": test, "model": model,
            "f": ident.f_hz[keep], "phi": ident.shapes[:, keep]}


def test_layout_is_on_the_carbody() -> None:
    car = build_carbody(BASE)
    s = sensor_layout(car)
    assert len(s) == 81
    z = {n: car.asm.xyz[car.asm.nodes.index(n), 2] for n, _ in s}
    assert sum(1 for n, d in s if d == "uz" and abs(z[n]) < 1e-9) == 27  # floor
    assert sum(1 for n, d in s if abs(z[n] - BASE.height) < 1e-9) == 36  # roof corners
    assert len({car.asm.dof_index(n, d) for n, d in s}) == 81  # distinct free DOFs
    drives = driving_points(car)
    assert [d for _, d in drives] == ["uz", "uz", "uy"]
    assert drives[0][0] != drives[1][0]


def test_identified_modes_are_the_truths(setup: dict) -> None:
    """Six body modes within 0.3 % of the truth's frequencies, real (MPC > 0.9)."""
    f = setup["f"]
    assert f.size == 6
    truth = setup["test"].f_true
    nearest = np.min(np.abs(truth[None, :] / f[:, None] - 1.0), axis=1)
    assert np.all(nearest < 0.003)
    assert np.all(mpc(setup["phi"]) > 0.9)


def test_ritz_model_matches_the_full_model(setup: dict) -> None:
    m: ZoneModel = setup["model"]
    x = np.ones(len(m.names))
    x[m.names.index("E_roof")] = 1.3
    x[m.names.index("rho_underframe")] = 0.8
    f_full, _ = m.modes(x, 8)
    f_red, _ = m.reduced_modes(x, 8)
    assert np.max(np.abs(f_red / f_full - 1.0)) < 5e-3


def test_pairing_follows_shapes_not_order(setup: dict) -> None:
    """Swapping two model modes swaps the pairing with them (a mode swap)."""
    m: ZoneModel = setup["model"]
    f, phi = m.modes(np.ones(len(m.names)), 10)
    p0 = pair_test_modes(setup["f"], setup["phi"], f, phi)
    perm = np.arange(f.size)
    a, b = int(p0.fem_index[0]), int(p0.fem_index[1])
    perm[[a, b]] = perm[[b, a]]
    p1 = pair_test_modes(setup["f"], setup["phi"], f[perm], phi[:, perm])
    assert p1.fem_index[0] == b and p1.fem_index[1] == a
    np.testing.assert_allclose(p1.mac, p0.mac)


def test_reciprocity_of_the_two_floor_shakers(setup: dict) -> None:
    t = setup["test"]
    n_s = len(setup["channels"]) - 3
    band = (t.f_hz >= 5.0) & (t.f_hz <= 25.0)
    rel, frac = reciprocity(t.H_clean[n_s, 1, band], t.H_clean[n_s + 1, 0, band])
    assert rel < 1e-9 and frac > 1 - 1e-12  # Maxwell-Betti on the noise-free FRFs
    rel_n, frac_n = reciprocity(t.H[n_s, 1, band], t.H[n_s + 1, 0, band])
    assert 1e-4 < rel_n < 0.05 and frac_n > 0.99
    with pytest.raises(ShapeError):
        reciprocity(t.H[n_s, 1, :3], t.H[n_s, 1, :4])


@pytest.fixture(scope="module")
def updated(setup: dict):
    """The search on the two screened factors (the carbody updating's result)."""
    return update_zones(setup["model"], setup["f"], setup["phi"],
                        ("E_side_wall", "E_underframe"), maxiter=12, popsize=8)


def test_screening_and_search_recover_the_zone_factors(setup: dict, updated) -> None:
    m: ZoneModel = setup["model"]
    sc = screen_zones(m, setup["f"], setup["phi"], n_samples=80)
    assert {"E_side_wall", "E_underframe"} <= set(sc.selected)
    assert sc.kept.sum() > 40
    macs = sc.features[:, setup["f"].size:]
    assert np.all(macs[sc.kept] >= 0.5)  # [002] Sec. 4.1: samples with MAC < 0.5 dropped
    assert not np.any(np.all(np.nan_to_num(macs[~sc.kept]) >= 0.5, axis=1))
    up = updated
    fac = dict(zip(m.names, up.factors, strict=True))
    assert abs(fac["E_side_wall"] / TRUTH["E_side_wall"] - 1.0) < 0.02
    assert abs(fac["E_underframe"] / TRUTH["E_underframe"] - 1.0) < 0.02
    df_after = np.abs(up.f_after / setup["f"] - 1.0)
    df_before = np.abs(up.f_before / setup["f"] - 1.0)
    assert df_after.max() < 0.005 < df_before.max()
    assert np.all(up.mac_after > 0.9)  # [002] Fig. 12: MAC > 0.8 after updating


def test_bad_options_are_refused(setup: dict) -> None:
    m: ZoneModel = setup["model"]
    with pytest.raises(OptionError):
        update_zones(m, setup["f"], setup["phi"], ())
    with pytest.raises(OptionError):
        screen_zones(m, setup["f"], setup["phi"], n_samples=3)
    with pytest.raises(OptionError):
        update_zones(m, setup["f"], setup["phi"], ("E_roof",), lower=1.1, upper=1.5)
    with pytest.raises(OptionError):
        update_zones(m, setup["f"], setup["phi"], ("E_nowhere",))
    with pytest.raises(ShapeError):
        m.reduced_modes(np.ones(2))
    with pytest.raises(ShapeError):
        m.modes(np.full(len(m.names), -1.0))


def test_search_is_the_same_on_a_process_pool(setup: dict) -> None:
    m: ZoneModel = setup["model"]
    a = update_zones(m, setup["f"], setup["phi"], ("E_side_wall",), maxiter=2, popsize=5)
    b = update_zones(m, setup["f"], setup["phi"], ("E_side_wall",), maxiter=2, popsize=5,
                     executor=2)
    np.testing.assert_array_equal(a.factors, b.factors)
    assert a.nfev == b.nfev


def test_updated_carbody_rides_like_the_truth(setup: dict, updated, tmp_path, capsys) -> None:
    """[002] Sec. 5 after updating: the car on the updated carbody rides like the truth's.

    Known answer: the truth's zone factors (its carbody built by ``_truth``, not by the
    library's factor path). On the same track, the Sperling indices, the first vertical
    bending and the mid-floor PSD peak there of the car on the updated carbody are closer
    to the truth car's than those on the nominal carbody; ``ride --carbody-params FILE``
    gives the in-process run's indices.
    """
    fac = {n: float(v) for n, v in zip(setup["model"].names, updated.factors, strict=True)
           if n in updated.names}
    path = tmp_path / "factors.yaml"
    save_zone_factors(path, fac)
    assert load_zone_factors(path) == fac
    text = DEFAULT_VEHICLE3D_YAML.read_text()
    mesh = "mesh: {n_length: 30, n_width: 4, n_height: 4}"
    assert mesh in text
    vfile = tmp_path / "car.yaml"  # the updating's mesh in the vehicle
    vfile.write_text(text.replace(mesh, "mesh: {n_length: 10, n_width: 2, n_height: 2}"))
    spec = load_vehicle3d(vfile).with_carbody("shell")
    assert spec.shell.params.n_length == BASE.n_length
    cases = {"nominal": spec, "updated": spec.with_zone_factors(load_zone_factors(path)),
             "truth": replace(spec, shell=replace(spec.shell, params=truth_params(
                 spec.shell.params, TRUTH)))}
    W, peak = {}, {}
    for name, s in cases.items():
        veh = build_vehicle3d(s)
        W[name] = ride_run(veh, 300.0, duration_s=30.0, fs_hz=400.0, seed=1).W
        peak[name] = bending_peak(veh, 300.0 / 3.6)
    d_nom = np.abs(W["nominal"] - W["truth"]).sum()
    d_upd = np.abs(W["updated"] - W["truth"]).sum()
    assert d_nom > 0.02  # the nominal car rides measurably differently (mid-car Wy 2 %)
    assert d_upd < 0.2 * d_nom  # measured: 0.003 against 0.061
    p_t = peak["truth"].psd_peak  # measured: nominal +10 %, updated +1.3 %
    assert abs(peak["updated"].psd_peak - p_t) < 0.3 * abs(peak["nominal"].psd_peak - p_t)
    f_t = peak["truth"].f_mode_hz  # the two zone errors nearly cancel here (0.1 %)
    assert abs(peak["updated"].f_mode_hz - f_t) < abs(peak["nominal"].f_mode_hz - f_t)
    assert main(["ride", str(vfile), "--carbody-params", str(path), "--speed", "300",
                 "--duration", "30", "--seed", "1", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    np.testing.assert_allclose(list(doc["runs"][0]["sperling"].values()), W["updated"],
                               rtol=1e-9)


def test_zone_factor_files_and_options_are_checked(tmp_path, capsys) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("carbody_zone_factors: {E_nowhere: 1.1}\n")
    assert main(["ride", "--carbody-params", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "unknown keys ['E_nowhere']" in err and err.count("\n") == 1
    bad.write_text("carbody_zone_factors: {E_roof: -1.0}\n")
    assert main(["ride", "--carbody-params", str(bad)]) == 2
    assert "E_roof: expected a factor > 0" in capsys.readouterr().err
    good = tmp_path / "good.yaml"
    save_zone_factors(good, {"E_roof": 0.9})
    assert main(["ride", "--carbody", "rigid", "--carbody-params", str(good)]) == 2
    assert "expected the shell carbody" in capsys.readouterr().err
    with pytest.raises(OptionError, match="zone factor 'E_nowhere'"):
        BASE.with_zone_factors({"E_nowhere": 1.0})
    p = BASE.with_zone_factors({"E_window_belt": 0.5, "rho_roof": 2.0})
    z0, z1 = BASE.zones["window_belt"], p.zones["window_belt"]
    assert z1.E == 0.5 * z0.E and z1.E_service == 0.5 * z0.E_service
    assert p.zones["roof"].rho == 2.0 * BASE.zones["roof"].rho
    assert p.zones["roof"].nsm == BASE.zones["roof"].nsm
