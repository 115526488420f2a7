"""Fits of laws with thresholds: a grid over the threshold before the local refine.

Known answers in closed form (not the library's laws): a Jenkins element (a spring in
series with a Coulomb slider, the force of a stop operator) beside a dashpot, and a
symmetric dead-band contact spring beside the nominal spring-dashpot, each driven along a
prescribed drift. Started with the threshold beyond every drift the path reaches (a
slider that never slips, a clearance never closed), the law is linear there and its
residual flat in the threshold: a local fit from that start stays put; the grid of
:func:`~modal_twin.diagnosis.fitting.threshold_start` finds the truth's threshold.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy import signal
from scipy.optimize import least_squares

from modal_twin.diagnosis.device_kind import DEVICE
from modal_twin.diagnosis.effect_kind import Round
from modal_twin.diagnosis.fitting import THRESHOLDS, _transform, threshold_start
from modal_twin.diagnosis.record import Record
from modal_twin.models.building_factory import INPUTS_6DOF, BuildingFactory
from modal_twin.models.effects import effect_device
from modal_twin.models.structure_yaml import DeviceSpec

FS = 100.0
K, C = 2.0e6, 5.0e4  # nominal spring (N/m) and dashpot (N s/m) of the site
SPEC = DeviceSpec("D", ("N", 0), np.array([K, K]), np.array([C, C]), 0.0, "linear")


def drift() -> tuple[np.ndarray, np.ndarray]:
    """A band-limited random drift of 0.1 m RMS in x (y at rest) and its velocity."""
    rng = np.random.default_rng(3)
    sos = signal.butter(4, [0.3, 3.0], btype="band", fs=FS, output="sos")
    x = signal.sosfiltfilt(sos, rng.standard_normal(int(20 * FS)))
    u = np.vstack([0.1 * x / x.std(), np.zeros_like(x)])
    return u, np.gradient(u, 1.0 / FS, axis=1)


def jenkins(u: np.ndarray, v: np.ndarray, fk: float, kt: float, c: float) -> np.ndarray:
    """A spring ``kt`` in series with a slider of force ``fk``, a dashpot ``c`` beside."""
    z, out = 0.0, np.empty(u.size)
    for i in range(u.size):
        z = float(np.clip(z + (u[i] - u[i - 1] if i else u[0]), -fk / kt, fk / kt))
        out[i] = kt * z
    return out + c * v


def dead_band(u: np.ndarray, v: np.ndarray, g: float, kc: float) -> np.ndarray:
    """Contact spring ``kc`` beyond a clearance ``g`` either side, beside k and c."""
    return K * u + C * v + kc * np.sign(u) * np.maximum(np.abs(u) - g, 0.0)


CASES = {
    # law: (truth's threshold parameters, start with the threshold beyond every drift)
    "stick_slip": ({"Fk": 6.0e4}, {"Fk": 8.0e5, "Fs": 8.0e5}),
    "gap": ({"g": 0.08}, {"g": 0.6, "g_neg": 0.6, "k": 0.5 * K, "kp": 1.0}),
}


def measured(law: str, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    if law == "stick_slip":
        return jenkins(u[0], v[0], CASES[law][0]["Fk"], K, C)
    return dead_band(u[0], v[0], CASES[law][0]["g"], 2.0 * K)


def objective_of(law: str, start: dict[str, float]):  # type: ignore[no-untyped-def]
    """Equation error of the law along the drift, in units of the measured force's RMS."""
    u, v = drift()
    f = measured(law, u, v)
    names, to_params, to_x, lo, hi = _transform(law, start, K)

    def residual(x: np.ndarray) -> np.ndarray:
        dev = effect_device(SPEC, law, to_params(x))
        return (dev.respond(u, v).f[0] - f) / f.std()

    return residual, names, to_params, np.clip(to_x(start), lo + 1e-9, hi - 1e-9), lo, hi


@pytest.mark.parametrize("law", sorted(CASES))
def test_a_grid_over_the_threshold_finds_what_a_single_start_misses(law: str) -> None:
    truth, start = CASES[law]
    residual, names, to_params, x0, lo, hi = objective_of(law, start)
    axes = [names.index(n) for n in THRESHOLDS[law]]

    def refine(x: np.ndarray) -> dict[str, float]:
        sol = least_squares(residual, x, bounds=(lo, hi), diff_step=1e-3, max_nfev=60,
                            x_scale="jac")
        return to_params(sol.x)

    single = refine(x0)
    name = next(iter(truth))
    # the single start ends where it began: the threshold beyond every drift, a linear law
    assert single[name] > 3.0 * truth[name]
    multi = refine(threshold_start(residual, axes, x0, lo, hi))
    for n, value in truth.items():
        assert multi[n] == pytest.approx(value, rel=0.01)
    if law == "gap":  # the other side of the dead band and the contact stiffness too
        assert multi["g_neg"] == pytest.approx(truth["g"], rel=0.01)
        assert multi["k"] == pytest.approx(2.0 * K, rel=0.01)
    else:  # a stuck slider at the nominal stiffness: Fs = Fk, kt = k
        assert multi["Fs"] == pytest.approx(truth["Fk"], rel=0.01)
        assert multi["kt_factor"] == pytest.approx(1.0, rel=0.01)


def test_without_thresholds_the_start_is_kept() -> None:
    calls = []

    def residual(x: np.ndarray) -> np.ndarray:
        calls.append(x)
        return x - np.array([1.2, 1.0])

    x0 = np.array([0.2, 0.3])
    out = threshold_start(residual, [], x0, np.zeros(2), np.full(2, 2.0))
    np.testing.assert_array_equal(out, x0)
    assert not calls  # nothing simulated
    # one axis: of the six grid points (1 + 2 i) / 6 in (0, 2), the one nearest the
    # minimum at 1.2 is 7 / 6
    out = threshold_start(residual, [0], x0, np.zeros(2), np.full(2, 2.0))
    assert out[0] == pytest.approx(7.0 / 6.0)
    assert out[1] == x0[1]
    assert len(calls) == 7  # the start and six grid points


BUILDING = Path(__file__).resolve().parents[2] / "config" / "structures" / "building.yaml"


def slider_records(amplitudes: tuple[float, ...], slider: str = "tanh") -> list[Record]:
    """Drift and force of SDP2 at each level: a slider of 30 kN beside the damper's spring
    and half its dashpot (a closed form: ``k u + c v / 2 + F tanh(v / 2 mm/s)``; with
    ``slider="jenkins"`` the slider behind a spring of 40 MN/m, :func:`jenkins`, which
    slips beyond 0.75 mm)."""
    k, c = np.array([3.881e6, 3.995e6]), np.array([1.8222e5, 1.8045e5])
    out = []
    for i, a in enumerate(amplitudes):
        rng = np.random.default_rng(10 + i)
        sos = signal.butter(4, [0.3, 1.0], btype="band", fs=FS, output="sos")
        x = signal.sosfiltfilt(sos, rng.standard_normal((2, int(60 * FS))), axis=1)
        u = a * x / x.std(axis=1, keepdims=True)
        v = np.gradient(u, 1.0 / FS, axis=1)
        f = k[:, None] * u + 0.5 * c[:, None] * v + (
            3.0e4 * np.tanh(v / 2e-3) if slider == "tanh" else
            np.vstack([jenkins(u[j], v[j], 3.0e4, 4.0e7, 0.0) for j in range(2)]))
        out.append(Record(FS, INPUTS_6DOF, np.zeros((6, u.shape[1])),
                          ("SDP2_dx", "SDP2_dy", "SDP2_fx", "SDP2_fy"), np.vstack([u, f]),
                          f"level {a} m"))
    return out


def _screened(records: list[Record]) -> Any:
    """The device candidate at SDP2 screened on ``records`` (noise 0.01 %)."""
    factory = BuildingFactory(BUILDING)
    rnd = Round(factory, records, factory.plant(), [np.full(4, 1e-4)] * len(records),
                (), [], lambda s: None)
    return {c.evidence.component: c for c in DEVICE.screen(rnd)}["SDP2"]


def test_a_slider_hidden_at_one_level_is_named_from_another() -> None:
    """At 8 cm the slider leaves under 1 % of the damper's force: no family is named from
    that record alone; the low level (2.5 mm, the slider mostly stuck) shows the site is
    not nominal, so the training record is read in full and names friction, and the
    starts screened on the low level hold the slider's force within a factor of two."""
    train, test, low = slider_records((0.08, 0.08, 0.0025))
    alone = _screened([train, test])
    assert alone.evidence.residual_share < 0.01
    assert alone.laws == ()
    both = _screened([train, test, low])
    assert both.evidence.residual_share < 0.01  # the training record's evidence, in full
    assert both.evidence.significant[0] == "friction"
    assert both.laws[0] == "stick_slip"
    assert {"stick_slip", "regularised_friction"} <= set(both.laws)
    start = {s.law: s.params for s in both.screened}["regularised_friction"]
    assert 1.5e4 < start["Fk"] < 6.0e4
    assert "read in full: level 0.0025 m shows the site is not nominal" in (
        both.evidence.format())


def test_a_slider_read_as_hysteresis_at_the_low_level_is_friction_on_the_strong_one() -> None:
    """A Jenkins slider (30 kN behind 40 MN/m, slipping beyond 0.75 mm) at 2.5 mm slips
    only near its peaks: alone, that level names hysteresis first (stop operators of a
    gradual yield) and the friction laws that fit a slider beside a halved dashpot
    (``regularised_friction``) are not tried. At 8 cm the slider leaves 0.3 % of the
    force; read in full, that record names friction first, as the closed form is."""
    train, test, low = slider_records((0.08, 0.08, 0.0025), slider="jenkins")
    low_alone = _screened([low, test])
    assert low_alone.evidence.significant[0] == "hysteresis"
    assert "regularised_friction" not in low_alone.laws
    both = _screened([train, test, low])
    assert both.evidence.residual_share < 0.01
    assert both.evidence.significant[0] == "friction"
    assert both.laws[:2] == ("stick_slip", "regularised_friction")


def test_an_extension_run_to_its_far_bound_is_switched_off_and_the_rest_refitted() -> None:
    """A static-to-kinetic ratio that runs to its cap cannot be accepted (a fit stopped by
    its bound); the fit is repeated in the law's classical form (Fs = Fk) with the other
    parameters free: on a known quadratic, their optimum given the held value."""
    from scipy.optimize import least_squares

    from modal_twin.diagnosis.fitting import _extensions_at_far_bound, _held_fit

    names = ["Fk", "Fs", "kp", "v_s", "v_reg"]
    lo = np.array([0.0, 1.0, 0.0, -3.0, -4.0])
    hi = np.array([10.0, 3.0, 1.5, 0.0, -1.0])

    def objective(x: np.ndarray) -> np.ndarray:  # wants ratio 5 (beyond the cap of 3)
        return np.array([x[0] - 4.0 + 0.5 * (x[1] - 1.0), x[1] - 5.0, x[2] - 0.5,
                         x[3] + 1.0, x[4] + 2.0])

    sol = least_squares(objective, np.array([1.0, 1.5, 0.1, -2.0, -3.0]), bounds=(lo, hi))
    assert _extensions_at_far_bound("regularised_friction", names, sol) == [1]
    held = _held_fit(objective, sol, [1], [-1], lo, hi, 50)
    assert held.x[1] == 1.0  # Fs = Fk: switched off
    np.testing.assert_allclose(held.x[[0, 2, 3, 4]], [4.0, 0.5, -1.0, -2.0], atol=1e-6)
    assert not _extensions_at_far_bound("regularised_friction", names, held)
    assert not np.any(held.jac[:, 1])  # the held coordinate: not determined by the data
