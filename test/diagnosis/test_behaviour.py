"""Labels from behaviour (issue 20, item 4): closed-form force laws written here, not the
library's, each read off its force along a random drift history."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
from scipy import signal

from modal_twin.diagnosis.behaviour import classify_behaviour, turning_points

FS = 100.0
K, C = 1.0e6, 2.0e4  # nominal linear law, N/m and N s/m


def drift(seed: int = 1, nt: int = 12000) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    sos = signal.butter(4, [0.3, 1.5], btype="band", fs=FS, output="sos")
    u = signal.sosfiltfilt(sos, rng.standard_normal(nt))
    u *= 0.05 / np.std(u)  # 5 cm RMS
    return u, np.gradient(u, 1 / FS)


def elastoplastic(u: np.ndarray, fy: float, uy: float) -> np.ndarray:
    """A slider of strength fy behind a spring fy / uy (return mapping, exact for a path)."""
    z, out = 0.0, np.empty_like(u)
    prev = u[0]
    for i, x in enumerate(u):
        z = float(np.clip(z + fy / uy * (x - prev), -fy, fy))
        prev = x
        out[i] = z
    return out


def iwan(u: np.ndarray, fy: float, uy_max: float, n: int = 40) -> np.ndarray:
    """Microslip: n parallel elastoplastic elements, yield drifts spread up to uy_max."""
    return sum(elastoplastic(u, fy / n, uy_max * (j + 1) / n) for j in range(n))


LAWS: dict[str, tuple[str, Callable[[np.ndarray, np.ndarray], np.ndarray]]] = {
    "stiffer": ("stiffness", lambda u, v: 1.3 * K * u + C * v),
    "more damping": ("damping", lambda u, v: K * u + 3.0 * C * v),
    "a dashpot-like Bouc-Wen fit (less damping)": ("damping", lambda u, v: K * u + 0.3 * C * v),
    "Coulomb slider, stiff stick": ("friction",
                                    lambda u, v: K * u + C * v + elastoplastic(u, 2e4, 2e-4)),
    "yielding damper": ("hysteresis", lambda u, v: K * u + C * v + elastoplastic(u, 2e4, 0.02)),
    "microslip": ("hysteresis", lambda u, v: K * u + C * v + iwan(u, 2e4, 0.08)),
    "cubic hardening": ("hardening", lambda u, v: K * u + C * v + 4e8 * u**3),
    "tanh softening": ("softening",
                       lambda u, v: K * 0.06 * np.tanh(u / 0.06) + C * v),
    "gap at 6 cm": ("gap", lambda u, v: K * u + C * v
                    + 3 * K * np.sign(u) * np.clip(np.abs(u) - 0.06, 0.0, None)),
    "nominal": ("nothing", lambda u, v: K * u + C * v),
}


@pytest.mark.parametrize("name", list(LAWS))
def test_each_closed_form_law_reads_as_its_family(name: str) -> None:
    family, law = LAWS[name]
    u, v = drift()
    b = classify_behaviour(u, v, law(u, v), k=K, c=C)
    assert b.family == family, f"{name}: {b.text()}"


def test_turning_points_ignore_small_wiggles() -> None:
    t = np.arange(2000) / FS
    u = np.sin(2 * np.pi * 0.5 * t) + 0.005 * np.sin(2 * np.pi * 20 * t)
    tp = turning_points(u)
    assert tp.size == 20  # two per period over 20 s, the 20 Hz ripple ignored
    np.testing.assert_allclose(np.abs(u[tp]), 1.0, atol=0.01)
