"""Carbody zone updating ([002] Sec. 3-4) against a truth carbody with known zone errors.

The truth (``test/benchmarks/_truth/carbody.py``) is the same mesh rebuilt with its zone
table rewritten; its FRFs go through PolyMAX + LSFD, the screening and the differential
evolution, and the perturbed factors must come back.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from modal_twin.errors import OptionError, ShapeError
from modal_twin.identification.metrics import mpc
from modal_twin.models.carbody3d import CarbodyParams, build_carbody
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
from _truth.carbody import modal_test  # noqa: E402

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


def test_screening_and_search_recover_the_zone_factors(setup: dict) -> None:
    m: ZoneModel = setup["model"]
    sc = screen_zones(m, setup["f"], setup["phi"], n_samples=80)
    assert {"E_side_wall", "E_underframe"} <= set(sc.selected)
    assert sc.kept.sum() > 40
    macs = sc.features[:, setup["f"].size:]
    assert np.all(macs[sc.kept] >= 0.5)  # [002] Sec. 4.1: samples with MAC < 0.5 dropped
    assert not np.any(np.all(np.nan_to_num(macs[~sc.kept]) >= 0.5, axis=1))
    up = update_zones(m, setup["f"], setup["phi"], ("E_side_wall", "E_underframe"),
                      maxiter=12, popsize=8)
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
