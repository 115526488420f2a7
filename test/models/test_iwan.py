"""The Iwan microslip joint (uniform slip density, Masing branches, Madelung memory).

Known answers: the closed-form backbone of the uniform density (Iwan 1966; Segalman 2005
with chi = 0), ``B(u) = k u - k^2 u^2 / (4 F_y)`` up to full slip at ``uy`` (``F_y =
k uy / 2``) and flat beyond; Masing's unloading branch, the backbone scaled by 2 about the
reversal point; the energy of a symmetric cycle, ``2 k a^3 / (3 uy)``; and, along a
random path with nested sub-loops, the set of Jenkins elements itself written here in
numpy from its definition (``n`` springs ``k / n`` in series with sliders that slip at
drifts spread uniformly over ``(0, uy]``). Last, the fit transform recovers the
parameters of a known joint from its force.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal
from scipy.optimize import least_squares

from modal_twin.diagnosis.behaviour import classify_behaviour
from modal_twin.diagnosis.fitting import _transform
from modal_twin.errors import ModelError
from modal_twin.models.devices import IwanJoint
from modal_twin.models.effects import effect_device
from modal_twin.models.structure_yaml import DeviceSpec

K, UY = 2.0e6, 0.01  # stuck stiffness (N/m) and full-slip drift (m) of the Jenkins set
FY = K * UY / 2.0  # the slip force, N


def backbone(u: np.ndarray) -> np.ndarray:
    """``k u - k^2 u^2 / (4 F_y)`` up to ``uy``, ``F_y`` beyond (odd in u)."""
    a = np.abs(u)
    return np.sign(u) * np.where(a <= UY, K * a - K**2 * a**2 / (4.0 * FY), FY)


def jenkins_set(u: np.ndarray, k: float = K, uy: float = UY, n: int = 4000) -> np.ndarray:
    """Force of ``n`` Jenkins elements (stiffness k / n, slip drifts uniform on (0, uy])."""
    phi = uy * (np.arange(n) + 0.5) / n
    slider = np.zeros(n)
    out = np.empty(u.size)
    for i, x in enumerate(u):
        e = np.clip(x - slider, -phi, phi)  # each spring's stretch, at most its slip drift
        out[i] = k / n * e.sum()
        slider = x - e
    return out


def narrowband(nt: int, rms: float, seed: int = 3) -> np.ndarray:
    """A 1 Hz response with a 5 Hz one on top (sub-loops in every cycle), 100 Hz."""
    rng = np.random.default_rng(seed)
    w = rng.standard_normal(nt)
    one = signal.sosfilt(signal.butter(2, [0.9, 1.1], "band", fs=100.0, output="sos"), w)
    five = signal.sosfilt(signal.butter(2, [4.5, 5.5], "band", fs=100.0, output="sos"), w)
    return rms * (one / one.std() + 0.2 * five / five.std())


def test_virgin_loading_is_the_parabolic_backbone_then_the_slip_force() -> None:
    u = np.linspace(0.0, 1.5 * UY, 301)
    f = IwanJoint(K, 0.0, UY, [0.0]).respond(u).f[0]
    np.testing.assert_allclose(f, backbone(u), rtol=1e-12, atol=1e-9 * FY)
    # a residual spring and a dashpot add in parallel
    v = np.full_like(u, 0.2)
    f2 = IwanJoint(K, 3.0e5, UY, [1.0e4]).respond(u, v).f[0]
    np.testing.assert_allclose(f2, backbone(u) + 3.0e5 * u + 1.0e4 * v, rtol=1e-12)


@pytest.mark.parametrize("a", [0.4 * UY, UY, 1.7 * UY])
def test_unloading_is_the_backbone_scaled_by_two_about_the_reversal(a: float) -> None:
    down = np.linspace(a, -a, 401)
    u = np.concatenate([np.linspace(0.0, a, 101), down[1:]])
    f = IwanJoint(K, 0.0, UY, [0.0]).respond(u).f[0]
    fa = backbone(np.array([a]))[0]
    np.testing.assert_allclose(f[101:], fa - 2.0 * backbone((a - down[1:]) / 2.0),
                               rtol=1e-12, atol=1e-9 * FY)
    # Masing: the branch ends at the mirror of the tip
    assert f[-1] == pytest.approx(-fa, rel=1e-12)


@pytest.mark.parametrize("a", [0.3 * UY, 0.8 * UY])
def test_energy_per_cycle_is_the_closed_form(a: float) -> None:
    t = np.linspace(0.0, 3.0, 30001)
    u = a * np.sin(2 * np.pi * t)  # three cycles; the last two are the steady loop
    f = IwanJoint(K, 0.0, UY, [0.0]).respond(u).f[0]
    last = t >= 1.0
    energy = np.trapezoid(f[last], u[last]) / 2.0  # per cycle, loop area
    assert energy == pytest.approx(2.0 * K * a**3 / (3.0 * UY), rel=1e-4)
    if a < 0.5 * UY:  # a small loop reads as a stiffness change beside the residual spring
        return
    # what the diagnosis reads of it: a loop that encloses area (hysteresis)
    v = np.gradient(u, t)
    b = classify_behaviour(u, v, f + 3.0e5 * u, k=K + 3.0e5, c=0.0, f_static=f + 3.0e5 * u)
    assert b.family == "hysteresis"


def test_a_sub_loop_closes_and_the_outer_branch_carries_on() -> None:
    """Madelung's rule: 0 -> a -> -a/2 -> a/4 -> -a: past -a/2 the branch from a again."""
    a = 0.6 * UY
    legs = [np.linspace(0.0, a, 61), np.linspace(a, -a / 2, 91)[1:],
            np.linspace(-a / 2, a / 4, 46)[1:], np.linspace(a / 4, -a, 126)[1:]]
    u = np.concatenate(legs)
    f = IwanJoint(K, 0.0, UY, [0.0]).respond(u).f[0]
    fa = backbone(np.array([a]))[0]
    past = u[-125:] <= -a / 2
    outer = fa - 2.0 * backbone((a - u[-125:][past]) / 2.0)
    np.testing.assert_allclose(f[-125:][past], outer, rtol=1e-12, atol=1e-9 * FY)
    np.testing.assert_allclose(f, jenkins_set(u), atol=2e-3 * FY)


@pytest.mark.parametrize("rms", [0.3 * UY, 0.5 * UY])
def test_a_random_path_with_nested_loops_is_the_set_of_jenkins_elements(rms: float) -> None:
    u = narrowband(20000, rms)
    f = IwanJoint(K, 0.0, UY, [0.0]).respond(u).f[0]
    ref = jenkins_set(u)
    # the discretised set (4000 elements) and the memory's depth leave a few per mille
    assert np.sqrt(np.mean((f - ref) ** 2)) < 5e-3 * np.sqrt(np.mean(ref**2))


def test_bad_parameters_are_refused_with_their_values() -> None:
    with pytest.raises(ModelError, match=r"uy=0\.0"):
        IwanJoint(K, 0.0, 0.0, [0.0])
    with pytest.raises(ModelError, match=r"kr=-1\.0"):
        IwanJoint(K, -1.0, UY, [0.0])


def test_the_fit_recovers_a_known_joint_from_its_force() -> None:
    """The relative form fitted by least squares on the force of a known joint (the
    Jenkins elements of this file): alpha, uy, k and the dashpot come back."""
    k_nom, c_nom = 1.0e6, 5.0e4
    spec = DeviceSpec("D", ("N", 0), np.array([k_nom, k_nom]), np.array([c_nom, c_nom]),
                      0.0, "linear")
    truth = {"alpha": 0.25, "uy": 0.012, "k": 1.1 * k_nom, "c_factor": 0.6}
    u = narrowband(6000, 0.008, seed=11)[None, :]
    v = np.gradient(u, 0.01, axis=1)
    f = ((1 - truth["alpha"]) * jenkins_set(u[0], truth["k"], truth["uy"], 2000)
         + truth["alpha"] * truth["k"] * u[0] + truth["c_factor"] * c_nom * v[0])
    start = {"alpha": 0.1, "uy": 0.02, "c_factor": 1.0}
    _, to_p, to_x, lo, hi = _transform("iwan", start, k_nom)

    def residual(x: np.ndarray) -> np.ndarray:
        dev = effect_device(spec, "iwan", to_p(x))
        return (dev.respond(np.vstack([u, u]), np.vstack([v, v])).f[0] - f) / f.std()

    sol = least_squares(residual, np.clip(to_x(start), lo + 1e-9, hi - 1e-9),
                        bounds=(lo, hi), diff_step=1e-4, max_nfev=200)
    got = to_p(sol.x)
    assert np.sqrt(np.mean(sol.fun**2)) < 3e-3
    for name, want in truth.items():
        assert got[name] == pytest.approx(want, rel=0.03), name


@pytest.mark.parametrize("isotropic", [False, True])
def test_the_screening_starts_the_anisotropy_the_force_shows(isotropic: bool) -> None:
    """A site whose nominal spring is 30 % stiffer in y: a joint that is the same in x and
    y starts ``isotropic``, one that keeps the nominal anisotropy does not."""
    from modal_twin.diagnosis.screening import screen_components

    kn = np.array([1.0e6, 1.3e6])
    spec = DeviceSpec("D", ("N", 0), kn, np.array([5.0e4, 5.0e4]), 0.0, "linear")
    u = np.vstack([narrowband(4000, 0.006, seed=5), narrowband(4000, 0.006, seed=6)])
    v = np.gradient(u, 0.01, axis=1)
    k = np.full(2, kn.mean()) if isotropic else kn
    f = np.vstack([0.8 * jenkins_set(u[i], k[i], 0.01, 1000) + 0.2 * k[i] * u[i]
                   for i in range(2)]) + 5.0e4 * v
    scr = screen_components({"D": u}, {"D": f}, {"D": spec}, {"D": 0.0}, 100.0,
                            laws=("iwan",))
    (iw,) = [s for s in scr if s.law == "iwan"]
    assert (iw.params.get("isotropic") == 1.0) is isotropic
    # the relative form: one joint in x and y about the mean stiffness
    dev = effect_device(spec, "iwan", {"isotropic": 1.0, "alpha": 0.2})
    np.testing.assert_allclose(dev.params[:4], [0.8 * kn.mean()] * 2 + [0.2 * kn.mean()] * 2)
