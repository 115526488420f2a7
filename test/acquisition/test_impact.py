"""Hammer tests ([000]): hits found, double hits and overloads rejected, FRFs averaged.

Known answers: a single-degree-of-freedom oscillator's receptance in closed form, and the
pole shift an exponential window adds.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from modal_twin.acquisition.impact import (
    check_hit,
    exponential_damping,
    find_hits,
    impact_frf,
    roving_hammer_frf,
)
from modal_twin.errors import SignalError
from modal_twin.excitation.drive import ExcitationConfig, make_drive
from modal_twin.excitation.signals import hammer_pulse

FS = 1000.0
M, FN, ZETA = 2.0, 12.0, 0.01
WN = 2 * np.pi * FN
K, C = M * WN**2, 2 * ZETA * M * WN


def receptance(f_hz: np.ndarray, sigma: float | None = None) -> np.ndarray:
    """x / F of the oscillator; with ``sigma`` its pole's real part replaced (same w_d)."""
    s = 2j * np.pi * f_hz
    if sigma is None:
        return 1.0 / (M * s**2 + C * s + K)
    wd2 = WN**2 * (1 - ZETA**2)
    return 1.0 / (M * (s**2 + 2 * sigma * s + sigma**2 + wd2))


def respond(force: np.ndarray) -> np.ndarray:
    sys = signal.lti([1.0], [M, C, K])
    t = np.arange(force.size) / FS
    _, x, _ = signal.lsim(sys, force, t)
    return np.asarray(x)[None, :]


def hits(n_hits: int, spacing_s: float, *, peaks: list[float] | None = None,
         extra: dict[int, float] | None = None) -> np.ndarray:
    n = round(n_hits * spacing_s * FS)
    f = np.zeros(n)
    for i in range(n_hits):
        pk = (peaks or [100.0] * n_hits)[i]
        f += hammer_pulse(n, FS, peak_n=pk, tip_stiffness_n_m=2e4, hammer_mass_kg=0.3,
                          at_s=0.1 + i * spacing_s)
        if extra and i in extra:  # a second contact 30 ms later
            f += hammer_pulse(n, FS, peak_n=extra[i] * pk, tip_stiffness_n_m=2e4,
                              hammer_mass_kg=0.3, at_s=0.13 + i * spacing_s)
    return f


def test_pulse_lasts_pi_sqrt_m_over_k() -> None:
    f = hammer_pulse(4000, 100_000.0, peak_n=50.0, tip_stiffness_n_m=1e7, hammer_mass_kg=0.1)
    tc = np.pi * np.sqrt(0.1 / 1e7)
    assert np.count_nonzero(f) / 100_000.0 == pytest.approx(tc, rel=0.02)
    assert f.max() == pytest.approx(50.0, rel=1e-3)


def test_averaged_hits_give_the_closed_form_receptance() -> None:
    force = hits(4, 20.0)
    est = impact_frf(force, respond(force), FS, block_s=16.0)
    assert est.n_averages == 4
    band = (est.f_hz > 2.0) & (est.f_hz < 40.0)
    ref = receptance(est.f_hz[band])
    for h in (est.H1, est.H2, est.Hv):
        err = np.abs(h[0, band] - ref) / np.abs(ref)
        assert float(np.max(err)) < 0.01
    assert float(np.min(est.coherence[0, band])) > 0.999


def test_exponential_window_adds_the_damping_it_is_corrected_for() -> None:
    # a 2 s block: the oscillator has not decayed (exp(-zeta wn 2) = 0.22); the window with
    # tau = 0.3 s moves the pole by 1 / tau, which exponential_damping takes off again
    force = hits(6, 8.0)  # each hit has decayed before the next (exp(-6))
    tau = 0.3
    est = impact_frf(force, respond(force), FS, block_s=2.0, tau_s=tau)
    sigma = ZETA * WN + 1.0 / tau
    band = (est.f_hz > 4.0) & (est.f_hz < 40.0)
    ref = receptance(est.f_hz[band], sigma=sigma)
    err = np.abs(est.H1[0, band] - ref) / np.abs(ref)
    assert float(np.max(err)) < 0.03
    wd = WN * np.sqrt(1 - ZETA**2)
    w_id = np.hypot(wd, sigma)
    zeta_id = sigma / w_id
    assert exponential_damping(np.array([zeta_id]), np.array([w_id / (2 * np.pi)]),
                               tau)[0] == pytest.approx(ZETA, abs=2e-3)


def test_double_hits_and_overloads_are_rejected_and_said() -> None:
    force = hits(5, 20.0, extra={1: 0.5})  # hit 2 bounces
    clipped = force.copy()
    third = slice(round(40.1 * FS), round(40.2 * FS))
    clipped[third] = np.minimum(clipped[third], 80.0)  # hit 3 clipped at 80 N
    est = impact_frf(clipped, respond(force), FS, block_s=16.0)
    verdicts = [h.accepted for h in est.hits]
    assert verdicts == [True, False, False, True, True]
    reasons = est.rejected()
    assert "double hit" in reasons[0] and "50 %" in reasons[0]
    assert "overload" in reasons[1]
    band = (est.f_hz > 2.0) & (est.f_hz < 40.0)
    ref = receptance(est.f_hz[band])
    assert float(np.max(np.abs(est.H1[0, band] - ref) / np.abs(ref))) < 0.01
    # a force range names the overload without a flat top
    chk = check_hit(force[: 16000], respond(force)[:, :16000], FS, force_range=100.0)
    assert not chk.accepted and "range" in chk.reason


def test_no_accepted_hit_is_an_error_naming_why() -> None:
    force = hits(2, 20.0, extra={0: 0.5, 1: 0.5})
    with pytest.raises(SignalError, match="double hit"):
        impact_frf(force, respond(force), FS, block_s=16.0)


def test_find_hits_skips_a_block_running_past_the_end() -> None:
    force = hits(3, 10.0)
    assert find_hits(force, FS, block_s=9.0) == [96, 10096, 20096]
    assert find_hits(force, FS, block_s=12.0) == [96, 10096]


def test_noise_on_the_response_biases_h2_not_h1() -> None:
    rng = np.random.default_rng(4)
    force = hits(30, 8.0)
    y = respond(force)
    y = y + 0.2 * np.std(y) * rng.standard_normal(y.shape)
    est = impact_frf(force, y, FS, block_s=2.5, tau_s=0.5)
    sigma = ZETA * WN + 1.0 / 0.5
    hi = (est.f_hz > 40.0) & (est.f_hz < 70.0)  # little response: noise dominates y there
    ref = np.abs(receptance(est.f_hz[hi], sigma=sigma))
    r1 = float(np.median(np.abs(est.H1[0, hi]) / ref))
    r2 = float(np.median(np.abs(est.H2[0, hi]) / ref))
    rv = float(np.median(np.abs(est.Hv[0, hi]) / ref))
    assert abs(r1 - 1) < 0.05 and r2 > 1.5
    # Hv weighs force and response noise alike in their own units: with forces of 100 N and
    # responses of micrometres it stays by H1
    assert 0.99 * r1 <= rv <= r2


def test_the_excitation_drives_roving_hits_with_bounces_and_clipping() -> None:
    cfg = ExcitationConfig(kind="impact", channels=("F1", "F2"), fs_hz=FS, duration_s=20.0,
                           rms=(100.0, 50.0), impact_spacing_s=4.0, hits_per_point=3,
                           double_hit_every=2, overload_n=90.0, tip_stiffness_n_m=2e4)
    drive = make_drive(cfg)
    starts = [find_hits(drive[i], FS, block_s=3.0) for i in range(2)]
    assert starts == [[496, 4496, 8496], [12496, 16496]]  # hits 1-3 on F1, 4-5 on F2
    # F1: clipped at 90 N (overload, flat top); F2: hit 4 bounces, hit 5 is clean
    c1 = check_hit(drive[0, 496:3496], np.zeros((1, 3000)), FS)
    assert "overload" in c1.reason
    c4 = check_hit(drive[1, 12496:15496], np.zeros((1, 3000)), FS)
    c5 = check_hit(drive[1, 16496:19496], np.zeros((1, 3000)), FS)
    assert "double hit" in c4.reason and c5.accepted
    assert float(drive[1].max()) == pytest.approx(50.0, rel=1e-3)


def test_every_nth_hit_struck_too_hard_is_the_one_overload() -> None:
    cfg = ExcitationConfig(kind="impact", channels=("F1",), fs_hz=FS, duration_s=12.0,
                           rms=(60.0,), impact_spacing_s=4.0, hits_per_point=3,
                           overload_every=2, overload_n=90.0, tip_stiffness_n_m=2e4)
    drive = make_drive(cfg)
    starts = find_hits(drive[0], FS, block_s=3.0)
    verdicts = [check_hit(drive[0, s:s + 3000], np.zeros((1, 3000)), FS) for s in starts]
    # hit 2 at twice 60 N clips at 90 N; hits 1 and 3 at 60 N stay clean
    assert [v.accepted for v in verdicts] == [True, False, True]
    assert "overload" in verdicts[1].reason
    assert float(drive[0].max()) == pytest.approx(90.0)
    assert verdicts[0].peak_n == pytest.approx(60.0, rel=1e-3)


def test_a_roving_hammer_test_of_a_three_mass_chain_identified_by_polymax(tmp_path) -> None:
    """Hits at each of three masses, accelerometers on all three: the FRF matrix, written as
    UFF 58 and read back, gives the chain's eigenfrequencies and modes by PolyMAX."""
    import pyuff
    from scipy import linalg

    from modal_twin.identification.polymax import polymax
    from modal_twin.io.uff import write_uff58_frf

    m = np.diag([2.0, 1.5, 1.0])
    k1, k2, k3 = 4e4, 3e4, 2e4
    kk = np.array([[k1 + k2, -k2, 0], [-k2, k2 + k3, -k3], [0, -k3, k3]])
    w2, phi = linalg.eigh(kk, m)
    fn = np.sqrt(w2) / (2 * np.pi)
    cc = 2 * 0.02 * m @ phi @ np.diag(np.sqrt(w2)) @ phi.T @ m  # 2 % modal damping
    a = np.block([[np.zeros((3, 3)), np.eye(3)],
                  [-np.linalg.solve(m, kk), -np.linalg.solve(m, cc)]])
    b = np.vstack([np.zeros((3, 3)), np.linalg.inv(m)])
    c_acc, d_acc = a[3:], b[3:]  # accelerations
    n_hits, spacing = 3, 6.0
    nt = round(3 * n_hits * spacing * FS)
    forces = np.zeros((3, nt))
    for i in range(3):
        for h in range(n_hits):
            forces[i] += hammer_pulse(nt, FS, peak_n=50.0, tip_stiffness_n_m=2e4,
                                      hammer_mass_kg=0.3,
                                      at_s=0.2 + (i * n_hits + h) * spacing)
    t = np.arange(nt) / FS
    _, acc, _ = signal.lsim(signal.StateSpace(a, b, c_acc, d_acc), forces.T, t)
    H, f, coh, points = roving_hammer_frf(forces, acc.T, FS, block_s=5.0)
    assert [p.n_averages for p in points] == [3, 3, 3]
    band = (f > 2.0) & (f < 40.0)
    assert float(np.min(coh[:, :, band])) > 0.99  # noise-free: every line coherent
    path = write_uff58_frf(tmp_path / "frf.uff", f[band], H[:, :, band],
                           [(j + 1, 1) for j in range(3)], [(j + 1, 1) for j in range(3)])
    back = pyuff.UFF(str(path)).read_sets()
    Hr = np.array([[back[o * 3 + i]["data"] for i in range(3)] for o in range(3)])
    np.testing.assert_allclose(Hr, H[:, :, band], rtol=1e-5)
    sweep = polymax(Hr, f[band], orders=[8])
    found = sweep.poles[0]
    for r in range(3):
        j = int(np.argmin(np.abs(found.f_hz - fn[r])))
        assert found.f_hz[j] == pytest.approx(fn[r], rel=0.005)
        assert found.zeta[j] == pytest.approx(0.02, abs=0.004)
        shape = found.shapes[:, j]
        mac = abs(np.vdot(shape, phi[:, r])) ** 2 / (np.vdot(shape, shape).real
                                                    * float(phi[:, r] @ phi[:, r]))
        assert mac > 0.99
