"""Smooth bilinear (Richard-Abbott) spring against its closed form and its limits."""

from __future__ import annotations

import numpy as np
import pytest

from modal_twin.errors import ModelError
from modal_twin.models.devices import BilinearElastic, SmoothBilinearSpring

K, KB, UB = 2.0e6, 0.5e6, 0.01  # N/m, N/m, m


def _force(dev: SmoothBilinearSpring, u: np.ndarray) -> np.ndarray:
    return dev.respond(np.atleast_1d(u)).f[0]


@pytest.mark.parametrize("n", [1.0, 2.0])
def test_force_is_the_closed_form_at_a_few_drifts(n: float) -> None:
    """n = 1: kb u + (k - kb) u / (1 + |u| / ub); n = 2: ... / sqrt(1 + (u / ub)^2).

    At u = ub the rounded knee gives kb ub + (k - kb) ub / 2^(1/n), below the bilinear
    corner k ub; at -3 ub the force is odd."""
    dev = SmoothBilinearSpring(K, KB, UB, [0.0], n=n)
    u = np.array([0.5 * UB, UB, -3.0 * UB, 20.0 * UB])
    want = {1.0: KB * u + (K - KB) * u / (1.0 + np.abs(u) / UB),
            2.0: KB * u + (K - KB) * u / np.sqrt(1.0 + (u / UB) ** 2)}[n]
    np.testing.assert_allclose(_force(dev, u), want, rtol=1e-12)
    assert _force(dev, np.array([UB]))[0] == pytest.approx(KB * UB + (K - KB) * UB / 2 ** (1 / n))


def test_dashpot_beside_the_spring() -> None:
    dev = SmoothBilinearSpring(K, KB, UB, [3.0e3])
    u, v = np.array([[0.02]]), np.array([[0.4]])
    spring = KB * 0.02 + (K - KB) * 0.02 / np.sqrt(1.0 + 4.0)
    assert dev.respond(u, v).f[0, 0] == pytest.approx(spring + 3.0e3 * 0.4, rel=1e-12)


def test_a_sharp_knee_is_the_bilinear_spring() -> None:
    """n = 100 against Eq. (9) of [004]: the largest gap is at the corner, (k - kb) ub
    (1 - 2^(-1/100)) = 0.69 % of (k - kb) ub; n = 2 is far from it (29 %)."""
    u = np.linspace(-5 * UB, 5 * UB, 2001)
    bil = BilinearElastic(K, KB, UB, [0.0]).respond(u[None, :]).f[0]
    scale = (K - KB) * UB
    gap100 = np.max(np.abs(_force(SmoothBilinearSpring(K, KB, UB, [0.0], n=100.0), u) - bil))
    gap2 = np.max(np.abs(_force(SmoothBilinearSpring(K, KB, UB, [0.0], n=2.0), u) - bil))
    assert gap100 == pytest.approx(scale * (1 - 2 ** -0.01), rel=1e-3)
    assert gap100 < 0.01 * scale
    assert gap2 == pytest.approx(scale * (1 - 2 ** -0.5), rel=1e-3)


@pytest.mark.parametrize(("kb", "n"), [(KB, 2.0), (KB, 7.0), (3.0 * K, 1.5)])
def test_tangent_is_k_at_rest_kb_far_out_and_the_slope_of_the_force(kb: float, n: float
                                                                   ) -> None:
    dev = SmoothBilinearSpring(K, kb, UB, [0.0], n=n)
    u = np.array([0.0, 0.3 * UB, -1.7 * UB, 1e3 * UB])
    kt = dev.respond(u).Kt[0, 0]
    assert kt[0] == K
    assert kt[-1] == pytest.approx(kb, rel=1e-6)
    h = 1e-7 * UB
    num = (_force(dev, u + h) - _force(dev, u - h)) / (2 * h)
    np.testing.assert_allclose(kt, num, rtol=1e-6)


def test_hardening_when_kb_exceeds_k() -> None:
    """kb = 3 k: the secant stiffness rises from k towards kb with the drift."""
    dev = SmoothBilinearSpring(K, 3.0 * K, UB, [0.0])
    u = np.array([0.1, 1.0, 10.0, 100.0]) * UB
    secant = _force(dev, u) / u
    assert np.all(np.diff(secant) > 0)
    assert secant[0] == pytest.approx(K, rel=0.01)
    assert secant[-1] == pytest.approx(3.0 * K, rel=0.01)


def test_no_overflow_far_beyond_the_knee() -> None:
    dev = SmoothBilinearSpring(K, KB, UB, [0.0], n=100.0)
    f = _force(dev, np.array([1e4 * UB]))
    assert f[0] == pytest.approx(KB * 1e4 * UB + (K - KB) * UB, rel=1e-12)


@pytest.mark.parametrize("bad", [{"k": 0.0}, {"kb": -1.0}, {"ub": 0.0}, {"n": 0.1},
                                 {"n": 500.0}, {"c": [-1.0]}])
def test_bad_parameters_are_refused(bad: dict) -> None:
    p = {"k": K, "kb": KB, "ub": UB, "c": [0.0], **bad}
    n = p.pop("n", 2.0)
    with pytest.raises(ModelError):
        SmoothBilinearSpring(p["k"], p["kb"], p["ub"], p["c"], n=n)
