"""Maxwell damper (models/devices/maxwell.py) against its closed forms.

Steady harmonic motion: the force is Re(K(w) U e^{i w t}) with K(w) = kp + kb i w c /
(kb + i w c) (Eq. (2) of the module); a step in velocity: the branch force relaxes as
c v0 (1 - e^{-t / tau}). In the twin, a mass on a bare Maxwell element beside a spring has
the frequency response of m s^2 + K(w).
"""

from __future__ import annotations

import numpy as np
import pytest

from modal_twin.errors import ModelError, OptionError
from modal_twin.models.devices import MaxwellDamper
from modal_twin.models.devices.maxwell import maxwell_stiffness
from modal_twin.models.devices.registry import Site, build_device, build_effect_device
from modal_twin.models.reduced import DeviceAttachment, ReducedSystem
from modal_twin.twin.simulator import simulate


def _harmonic_amplitude(t: np.ndarray, f: np.ndarray, w: float) -> complex:
    """Complex amplitude F of f = Re(F e^{i w t}) by least squares on cos, sin."""
    A = np.column_stack([np.cos(w * t), np.sin(w * t), np.ones_like(t)])
    a, b, _ = np.linalg.lstsq(A, f, rcond=None)[0]
    return complex(a, -b)


@pytest.mark.parametrize("f_hz", [0.3, 3.0, 30.0])  # w tau = 0.09, 0.9, 9
def test_steady_harmonic_force_is_the_complex_stiffness(f_hz: float) -> None:
    kp, kb, c = 2.0e5, 8.0e5, 4.0e4  # tau = 0.05 s
    dev = MaxwellDamper([kp], [kb], [c])
    w = 2 * np.pi * f_hz
    dt = 1e-3 / f_hz  # 1000 samples per cycle
    t = np.arange(0.0, 40 * 0.05 + 20.0 / f_hz, dt)  # 40 tau to settle, then 20 cycles
    U = 1e-3
    u, v = U * np.sin(w * t), U * w * np.cos(w * t)
    f = dev.respond(u, v, dt=dt).f[0]
    keep = t >= t[-1] - 10.0 / f_hz
    got = _harmonic_amplitude(t[keep], f[keep], w)
    want = complex(maxwell_stiffness(kp, kb, c, np.array([w]))[0]) * U * -1j  # u = Im(U e^iwt)
    assert abs(got - want) <= 1e-5 * abs(want)


def test_limits_are_a_dashpot_and_a_spring() -> None:
    kb, c = 1.0e6, 1.0e4  # tau = 0.01 s
    K = maxwell_stiffness(0.0, kb, c, np.array([1e-3, 1e4]))
    assert K[0] == pytest.approx(1j * 1e-3 * c, rel=1e-4)  # w tau << 1
    assert K[1].real == pytest.approx(kb, rel=1e-3)  # w tau >> 1: the spring kb ...
    assert K[1].imag == pytest.approx(kb / (1e4 * c / kb), rel=1e-3)  # ... losing kb / w tau


def test_velocity_step_relaxes_with_tau() -> None:
    kb, c, v0 = 5.0e5, 1.0e4, 0.02  # tau = 0.02 s
    dt = 1e-3
    t = np.arange(0.0, 0.2, dt)
    v = np.full_like(t, v0)
    v[0] = 0.0
    u = np.concatenate([[0.0], v0 * (t[1:] - 0.5 * dt)])  # the trapezoid of v
    f = MaxwellDamper([0.0], [kb], [c]).respond(u, v, dt=dt).f[0]
    # v rises linearly over the first step, then stays: the exact branch force
    tau = c / kb
    f1 = c * v0 * (1.0 - tau / dt * (1.0 - np.exp(-dt / tau)))
    want = c * v0 + (f1 - c * v0) * np.exp(-(t[1:] - dt) / tau)
    np.testing.assert_allclose(f[1:], want, rtol=1e-12, atol=1e-12 * c * v0)


def test_a_rate_law_needs_the_time_step() -> None:
    dev = MaxwellDamper([0.0], [1e6], [1e4])
    with pytest.raises(OptionError, match="sample interval"):
        dev.respond(np.zeros(5), np.zeros(5))
    with pytest.raises(ModelError):
        MaxwellDamper([0.0], [0.0], [1e4])


def test_registry_forms() -> None:
    site = Site("SD", np.array([2.0e5, 4.0e5]), np.array([4.0e4, 2.0e4]))
    rel = build_effect_device("maxwell", {"tau": 0.05, "c_factor": 2.0}, site)
    np.testing.assert_allclose(rel.params[0:6], [2e5, 4e5, 1.6e6, 8e5, 8e4, 4e4])
    ab = build_device("maxwell", {"kb": 3.0e6}, site)
    np.testing.assert_allclose(ab.params[0:6], [2e5, 4e5, 3e6, 3e6, 4e4, 2e4])


def test_twin_frequency_response_of_a_mass_on_a_maxwell_element() -> None:
    # m x'' + kp x + f_m = -m a_g: the steady response to a harmonic a_g is
    # X = -m A / (K(w) - m w^2)
    m, kp, kb, c = 1.0, (2 * np.pi * 2.0) ** 2, 60.0, 3.0  # tau = 0.05 s
    dt = 1e-3
    dev = MaxwellDamper([0.0], [kb], [c])
    s = ReducedSystem(np.array([[m]]), np.zeros((1, 1)), np.array([[kp]]), np.array([[m]]),
                      (DeviceAttachment(dev, np.ones((1, 1))),),
                      np.array([[1.0, 0.0, 0.0]]), np.zeros((1, 1)))
    w = 2 * np.pi * 2.5
    t = np.arange(0.0, 60.0, dt)
    ag = np.sin(w * t)[None, :]
    y = simulate(s, ag, dt).y[0]
    keep = t >= 40.0
    got = _harmonic_amplitude(t[keep], y[keep], w)
    K = complex(maxwell_stiffness(kp, kb, c, np.array([w]))[0])
    want = -m / (K - m * w**2) * -1j  # a_g = Im(e^{i w t})
    assert abs(got - want) <= 1e-4 * abs(want)
