"""A yielding damper in each direction on its own: the Bouc-Wen law's ``uncoupled`` form.

Known answers written here in numpy, not with the library's laws: a Bouc-Wen damper with
exponent 1 (a soft knee, ``dz/du = 1 - z / u_y`` on loading) whose two directions yield
independently (two orthogonal dampers), and one with the circular yield surface of
Eq. (10) of [004] (exponent 2, the directions coupled), each driven along a drift that
yields in x and y at once. The screening (:func:`.screening.screen_components`) must
start the right form from the measured force, and the fit of the uncoupled form must
leave a fraction of what the coupled one leaves on the uncoupled damper (the model-form
gap of the benchmark's ``new_bw_yielding_damper_SDP1``).
"""

from __future__ import annotations

import numpy as np
from scipy import signal
from scipy.optimize import least_squares

from modal_twin.diagnosis.fitting import _transform
from modal_twin.diagnosis.screening import screen_components
from modal_twin.models.effects import effect_device
from modal_twin.models.structure_yaml import DeviceSpec

FS = 100.0
K, C = 3.8e6, 1.5e5  # nominal spring (N/m) and dashpot (N s/m) of the site
SPEC = DeviceSpec("D", ("N", 0), np.array([K, K]), np.array([C, C]), 0.0, "linear")
UY, ALPHA, C_FRAC = 0.01, 0.05, 0.2  # the truth's yield drift, post-yield ratio, dashpot


def drift() -> tuple[np.ndarray, np.ndarray]:
    """Band-limited random drifts of 0.04 m RMS in x and y (independent), and velocity."""
    rng = np.random.default_rng(7)
    sos = signal.butter(4, [0.3, 3.0], btype="band", fs=FS, output="sos")
    x = signal.sosfiltfilt(sos, rng.standard_normal((2, int(20 * FS))), axis=1)
    u = 0.04 * x / x.std(axis=1, keepdims=True)
    return u, np.gradient(u, 1.0 / FS, axis=1)


def _z_history(u: np.ndarray, coupled: bool, n_sub: int = 200) -> np.ndarray:
    """Hysteretic variables along ``u`` (2, nt): explicit Euler in fine path steps.

    Uncoupled: exponent 1, ``dz = du - b |du| z - b du |z|`` per direction, b = 1 / (2 uy).
    Coupled: exponent 2 with the cross terms of Eq. (10) of [004], b = 1 / (2 uy^2).
    """
    z = np.zeros(2)
    out = np.zeros_like(u)
    for i in range(1, u.shape[1]):
        h = (u[:, i] - u[:, i - 1]) / n_sub
        for _ in range(n_sub):
            if coupled:
                b = 0.5 / UY**2
                s = b * (abs(h[0] * z[0]) * z[0] + h[0] * z[0] * z[0]
                         + abs(h[1] * z[1]) * z[0] + h[1] * z[0] * z[1])
                t = b * (abs(h[1] * z[1]) * z[1] + h[1] * z[1] * z[1]
                         + abs(h[0] * z[0]) * z[1] + h[0] * z[0] * z[1])
                z = z + h - np.array([s, t])
            else:
                b = 0.5 / UY
                z = z + h - b * np.abs(h) * z - b * h * np.abs(z)
        out[:, i] = z
    return out


def damper_force(u: np.ndarray, v: np.ndarray, coupled: bool) -> np.ndarray:
    """``f = alpha k u + (1 - alpha) k z + c v`` per direction."""
    return K * (ALPHA * u + (1.0 - ALPHA) * _z_history(u, coupled)) + C_FRAC * C * v


def _screened(coupled: bool) -> dict[str, float]:
    u, v = drift()
    f = damper_force(u, v, coupled)
    scr = screen_components({"D": u}, {"D": f}, {"D": SPEC}, {"D": 0.0}, FS,
                            laws=("bouc_wen",))
    (bw,) = [s for s in scr if s.law == "bouc_wen"]
    return bw.params


def test_the_screening_starts_the_form_the_force_shows() -> None:
    assert _screened(coupled=False).get("uncoupled") == 1.0
    assert "uncoupled" not in _screened(coupled=True)


def test_the_transform_holds_the_form_and_counts_it_only_where_set() -> None:
    names, to_p, to_x, lo, hi = _transform("bouc_wen", {"uy": 0.01, "alpha": 0.1}, K)
    assert names == ["uy", "alpha", "k", "c_factor"]
    assert "uncoupled" not in to_p(to_x({"uy": 0.01, "alpha": 0.1}))
    names, to_p, to_x, lo, hi = _transform("bouc_wen", {"uy": 0.01, "alpha": 0.1,
                                                        "uncoupled": 1.0}, K)
    assert names[-1] == "uncoupled" and lo.size == 4
    assert to_p(np.clip(to_x({"uy": 0.01, "alpha": 0.1}), lo, hi))["uncoupled"] == 1.0


def _fit_error(u: np.ndarray, v: np.ndarray, f: np.ndarray, uncoupled: bool) -> float:
    start = {"uy": UY, "alpha": 0.1, "c_factor": 0.5, **({"uncoupled": 1.0} if uncoupled
                                                          else {})}
    _, to_p, to_x, lo, hi = _transform("bouc_wen", start, K)

    def residual(x: np.ndarray) -> np.ndarray:
        dev = effect_device(SPEC, "bouc_wen", to_p(x))
        return ((dev.respond(u, v).f - f) / f.std()).ravel()

    sol = least_squares(residual, np.clip(to_x(start), lo + 1e-9, hi - 1e-9),
                        bounds=(lo, hi), diff_step=1e-3, max_nfev=60)
    return float(np.sqrt(np.mean(sol.fun**2)))


def test_the_uncoupled_form_closes_most_of_the_gap_to_two_yielding_dampers() -> None:
    u, v = drift()
    f = damper_force(u, v, coupled=False)
    e_unc, e_cpl = _fit_error(u, v, f, True), _fit_error(u, v, f, False)
    # what is left to the uncoupled form is the knee's exponent (2 against the truth's 1)
    assert e_unc < 0.06
    assert e_unc < 0.4 * e_cpl
