"""Automatic mode selection by clustering the poles, against records of known modes.

The truths are written here in other forms than the library's: a 5-DOF spring-mass chain
(its modes from ``scipy.linalg.eigh`` of K and M, its response by ``scipy.signal.dlsim``),
a modal superposition of resonators filtered from white noise (two modes 1 % apart), and
hand-made pole sweeps whose columns are known.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.signal as sig

from modal_twin.channels import ChannelSpec
from modal_twin.errors import OptionError
from modal_twin.identification.clustering import CUT_MIN, cluster_modes
from modal_twin.identification.modal_model import PoleSet, PoleSweep
from modal_twin.identification.record import IdentifyOptions, identify_record
from modal_twin.identification.stabilization import stabilization_diagram
from modal_twin.signal_block import SignalBlock

FS = 40.0


def _block(y: np.ndarray) -> tuple[SignalBlock, list[ChannelSpec]]:
    names = tuple(f"a{k}" for k in range(y.shape[0]))
    chans = [ChannelSpec(n, "acceleration", direction="x", role="output", node=f"n{k}")
             for k, n in enumerate(names)]
    return SignalBlock(names, FS, 0, y), chans


def chain(seed: int, harmonic_hz: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Accelerations of a 5-DOF chain (unit masses, springs 400 N/m, 1-2 % modal damping)
    under white forces at every mass, 5 % noise, 600 s; returns (y, exact f_hz)."""
    k = np.full(5, 400.0)
    K = np.diag(np.r_[k[:-1] + k[1:], k[-1]]) - np.diag(k[1:], 1) - np.diag(k[1:], -1)
    w2, V = sla.eigh(K)  # unit masses
    C = V @ np.diag(2 * np.array([0.01, 0.015, 0.015, 0.02, 0.02]) * np.sqrt(w2)) @ V.T
    A = np.block([[np.zeros((5, 5)), np.eye(5)], [-K, -C]])
    B = np.vstack([np.zeros((5, 5)), np.eye(5)])
    sysd = sig.cont2discrete((A, B, np.hstack([-K, -C]), np.eye(5)), 1 / FS)
    rng = np.random.default_rng(seed)
    n = int(FS * 600)
    _, y, _ = sig.dlsim((*sysd[:4], 1 / FS), rng.standard_normal((n, 5)))
    y = y.T + 0.05 * y.std(axis=0)[:, None] * rng.standard_normal((5, n))
    if harmonic_hz is not None:  # a rotating machine's line on every channel
        y += 0.3 * y.std(axis=1, keepdims=True) * np.sin(2 * np.pi * harmonic_hz
                                                          * np.arange(n) / FS)
    return y, np.sqrt(w2) / (2 * np.pi)


@pytest.mark.parametrize("seed", [3, 4])
def test_chain_every_mode_within_half_a_percent_and_nothing_else(seed: int) -> None:
    """Not a guarantee: of the seeds 1-4, 8, 9 tried, seed 8 adds one spurious cluster
    (5.66 Hz, 13 of 30 orders, zeta 2.5 %, MPC 0.93, its blocks' std 2 % of f); the
    others report the five modes within 0.3 % and nothing else."""
    y, f_true = chain(seed)
    rec = identify_record(*_block(y), IdentifyOptions(method="ssi-cov", f_min_hz=0.5))
    assert rec.modes.f_hz.size == 5, rec.modes.f_hz
    np.testing.assert_allclose(rec.modes.f_hz, f_true, rtol=0.005)
    np.testing.assert_allclose(rec.modes.zeta, [0.01, 0.015, 0.015, 0.02, 0.02], rtol=0.3)
    assert np.all(rec.modes.n_support >= 20)  # of 30 orders
    assert any("clustering the poles of 30 orders" in n for n in rec.notes)
    assert all(d.reason for d in rec.dropped)


def test_a_harmonic_column_is_dropped_with_its_reason() -> None:
    y, f_true = chain(5, harmonic_hz=3.3)
    rec = identify_record(*_block(y), IdentifyOptions(method="ssi-cov", f_min_hz=0.5))
    np.testing.assert_allclose(rec.modes.f_hz, f_true, rtol=0.005)
    line = [d for d in rec.dropped if abs(d.f_hz - 3.3) < 0.01]
    assert len(line) == 1, [d.describe() for d in rec.dropped]
    assert "outside (0.1, 20 %)" in line[0].reason and "harmonic" in line[0].reason
    assert line[0].n_poles >= 20  # a column over the orders, not scattered poles
    old = identify_record(*_block(y), IdentifyOptions(method="ssi-cov", f_min_hz=0.5,
                                                      selection="stability"))
    assert np.min(np.abs(old.modes.f_hz - 3.3)) < 0.01  # the [004] rule takes it for a mode


def _resonator(f_hz: float, zeta: float, e: np.ndarray) -> np.ndarray:
    """Acceleration-like response of one mode to white noise: poles exp(lambda dt)."""
    lam = 2 * np.pi * f_hz * (-zeta + 1j * np.sqrt(1 - zeta**2))
    p = np.exp(lam / FS)
    return np.asarray(sig.lfilter([1.0, -1.0], [1.0, -2 * p.real, abs(p) ** 2], e))


def test_two_modes_one_percent_apart_are_both_reported() -> None:
    rng = np.random.default_rng(7)
    n = int(FS * 1200)
    f_true = np.array([2.0, 2.02, 4.0])
    phi = np.array([[1.0, 1.0, 1.0, 1.0], [1.0, -1.0, 1.0, -1.0], [1.0, 1.0, -1.0, -1.0]]).T
    q = np.array([_resonator(f, 0.01, rng.standard_normal(n)) for f in f_true])
    y = phi @ q
    y += 0.02 * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)
    rec = identify_record(*_block(y), IdentifyOptions(method="ssi-cov", f_min_hz=0.5))
    assert rec.modes.f_hz.size == 3, (rec.modes.f_hz, [d.describe() for d in rec.dropped])
    np.testing.assert_allclose(rec.modes.f_hz, f_true, rtol=0.005)
    macs = np.abs(rec.modes.shapes.conj().T @ phi) ** 2 / np.outer(
        np.sum(np.abs(rec.modes.shapes) ** 2, axis=0), np.sum(phi**2, axis=0))
    np.testing.assert_array_less(0.95, np.diag(macs))  # each close mode its own shape


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_mode_that_shifts_by_0_6_percent_is_reported_once(seed: int) -> None:
    """One mode whose frequency steps from 2.000 to 2.012 Hz halfway through a 1200 s
    record (a stiffness change: two near-duplicate resonances 0.6 % apart along one shape,
    closer than the 1 % of the close modes above) and a second mode at 4 Hz: each is
    reported once, the first between its two frequencies."""
    rng = np.random.default_rng(seed)
    n = int(FS * 1200)
    phi = np.array([[1.0, 1.0, 1.0, 1.0], [1.0, -1.0, 1.0, -1.0]]).T
    e = rng.standard_normal(n)
    q1 = np.r_[_resonator(2.0, 0.01, e)[: n // 2], _resonator(2.012, 0.01, e)[n // 2 :]]
    y = phi @ np.vstack([q1, _resonator(4.0, 0.01, rng.standard_normal(n))])
    y += 0.02 * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)
    rec = identify_record(*_block(y), IdentifyOptions(method="ssi-cov", f_min_hz=0.5))
    assert rec.modes.f_hz.size == 2, (rec.modes.f_hz, [d.describe() for d in rec.dropped])
    assert 2.0 * 0.999 <= rec.modes.f_hz[0] <= 2.012 * 1.001
    np.testing.assert_allclose(rec.modes.f_hz[1], 4.0, rtol=0.005)


SHAPES = np.array([[1, 1, 1, 1], [1, -1, 1, -1], [1, 1, -1, -1], [1, -1, -1, 1]],
                  dtype=complex).T


def _sweep(columns: list[tuple[float, float, np.ndarray, range]], n_orders: int = 20
           ) -> PoleSweep:
    """Poles of ``n_orders`` orders; each column (f, zeta, shape, order indices)."""
    sets = []
    for k in range(n_orders):
        here = [(f, z, s) for f, z, s, ks in columns if k in ks]
        f = np.array([c[0] for c in here])
        z = np.array([c[1] for c in here])
        S = np.stack([c[2] for c in here], axis=1) if here else np.zeros((4, 0), complex)
        nan = np.full(f.shape, np.nan)
        sets.append(PoleSet(2 * (k + 1), f, z, S, nan, nan))
    return PoleSweep("test", np.arange(2, 2 * n_orders + 1, 2), tuple(sets), np.zeros(0), 0)


def test_each_column_not_reported_has_its_reason() -> None:
    rng = np.random.default_rng(0)
    drift = np.linspace(0, 0.002, 20)  # 0.2 % over the orders: one column each
    scatter = rng.uniform(0.0012, 0.012, 20)  # damping 0.12-1.2 %, no value of its own
    noisy = np.exp(1j * np.pi * np.array([0, 0.5, 0.25, 0.75]))  # MPC 0: no line
    cols = [(1.0 * (1 + drift[k]), 0.02, SHAPES[:, 0], range(k, k + 1)) for k in range(20)]
    cols += [(2.0, 0.01 + 1e-4 * k, SHAPES[:, 1], range(k, k + 1)) for k in range(4, 20)]
    cols += [(3.0, 0.015, SHAPES[:, 2], range(15, 19)),  # four orders: three repeat
             (4.0, -0.01, SHAPES[:, 3], range(20)),  # negative damping everywhere
             (5.0, 0.03, noisy, range(20)),  # a shape like noise
             (2.036, 0.01, SHAPES[:, 1], range(10, 18))]  # 1.8 % from 2 Hz, its shape
    cols += [(6.0, scatter[k], SHAPES[:, 2], range(k, k + 1)) for k in range(20)]
    cm = cluster_modes(stabilization_diagram(_sweep(cols)), f_range_hz=(0.5, 5.5),
                       mpc_min=0.5)
    np.testing.assert_allclose(cm.modes.f_hz, [1.001, 2.0], rtol=1e-3)  # the medians
    np.testing.assert_allclose(cm.modes.zeta, [0.02, 0.01 + 1e-4 * 11.5], rtol=1e-9)
    assert cm.modes.n_support.tolist() == [20, 16]
    assert cm.cutoff == CUT_MIN and cm.n_min == 7  # 35 % of the largest cluster
    why = {round(d.f_hz, 1): d.reason for d in cm.dropped}
    assert why[3.0].startswith("too few poles: 3 of 20 orders")
    assert why[4.0].startswith("damping -1.00 % outside (0.1, 20 %) at 20 of its 20 poles")
    assert why[5.0].startswith("MPC") and "below 0.5" in why[5.0]
    assert why[2.0].startswith("duplicate of the reported 2.000 Hz (MAC 1.00")
    assert why[6.0] == "outside the band 0.5-5.5 Hz"
    assert len(cm.dropped) == 5


def test_damping_without_a_value_of_its_own_is_not_a_mode() -> None:
    rng = np.random.default_rng(1)
    z = rng.uniform(0.0011, 0.03, 20)
    z[:10] = 0.0012  # half the orders near the unit circle, the rest anywhere to 3 %
    cols = [(1.0, 0.02, SHAPES[:, 0], range(20))]
    cols += [(3.0, z[k], SHAPES[:, 2], range(k, k + 1)) for k in range(20)]
    cm = cluster_modes(stabilization_diagram(_sweep(cols)))
    assert cm.modes.f_hz.tolist() == [1.0]
    assert [d.reason.split(":")[0] for d in cm.dropped] == ["damping not determined"]


def test_bad_options_are_errors() -> None:
    d = stabilization_diagram(_sweep([(1.0, 0.02, SHAPES[:, 0], range(20))]))
    with pytest.raises(OptionError, match="zeta_min, zeta_max"):
        cluster_modes(d, zeta_max=0.0)
    with pytest.raises(OptionError, match="zeta_min, zeta_max"):
        cluster_modes(d, frac_orders=1.5)
    with pytest.raises(OptionError, match="selection: expected one of"):
        IdentifyOptions(selection="by-eye")


def test_the_building_isolation_modes_complex_and_0_9_percent_apart() -> None:
    """The demo's building (model of [004]) on its shaking table, N4SID as the report runs
    it: every mode below 20 Hz within 0.5 %, the two isolation modes 0.68 / 0.69 Hz
    (about 8 % damped by the isolators: complex shapes, MPC 0.3-0.5) among them."""
    from modal_twin.models.building import DEFAULT_BUILDING_YAML
    from modal_twin.models.loading import load_model
    from modal_twin.twin.simulator import simulate

    plant = load_model(DEFAULT_BUILDING_YAML, n_modes=16).plant()
    fs, n = 50.0, 10_000
    rng = np.random.default_rng(1)
    b, a = sig.butter(4, 20.0, fs=fs)
    ag = np.zeros((6, n))
    ag[:3] = sig.lfilter(b, a, rng.standard_normal((3, n)), axis=1)
    y = plant.measure(simulate(plant.system, ag, 1.0 / fs))[:42]
    y = y + 0.02 * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)
    names = ("u0", "u1", "u2", *(f"y{k}" for k in range(42)))
    chans = [ChannelSpec(c, "acceleration", role="input" if c[0] == "u" else "output")
             for c in names]
    rec = identify_record(SignalBlock(names, fs, 0, np.vstack([ag[:3], y])), chans,
                          IdentifyOptions(method="n4sid", orders=tuple(range(2, 41, 2)),
                                          f_max_hz=20.0))
    S = plant.system
    f_true = np.sqrt(np.abs(sla.eigh(S.K, S.M, eigvals_only=True))) / (2 * np.pi)
    f_true = f_true[f_true < 20.0]
    assert rec.modes.f_hz.size == f_true.size == 11
    np.testing.assert_allclose(rec.modes.f_hz, f_true, rtol=0.005)


def test_a_harmonic_is_told_from_a_lightly_damped_mode_by_its_kurtosis() -> None:
    """Brincker et al. (2000): a sine band-passed keeps kurtosis 1.5, a randomly driven
    mode's narrow-band response is Gaussian (3), however lightly damped."""
    import scipy.signal as sig

    from modal_twin.identification.clustering import is_harmonic

    fs, n = 400.0, 80_000
    rng = np.random.default_rng(5)
    t = np.arange(n) / fs
    sine = np.sin(2 * np.pi * 37.0 * t) + 0.3 * rng.standard_normal(n)
    assert is_harmonic(sine[None, :], fs, 37.0)
    # an SDOF at 37 Hz, 0.05 % damped, driven by white noise (exact discretisation)
    w, z = 2 * np.pi * 37.0, 0.0005
    sysd = sig.cont2discrete(([1.0], [1.0, 2 * z * w, w * w]), 1 / fs, method="zoh")
    mode = sig.lfilter(np.ravel(sysd[0]), sysd[1], rng.standard_normal(n))
    noisy = mode + 0.05 * np.std(mode) * rng.standard_normal(n)
    assert not is_harmonic(np.vstack([0.01 * noisy, noisy]), fs, 37.0)


def test_a_short_record_of_a_random_mode_is_not_read_as_a_harmonic() -> None:
    """The kurtosis of a band-passed Gaussian response estimated from N = T x B independent
    envelope samples scatters by about 3 / sqrt(N) about 3 (delta method on the envelope
    power, exponential); on a 65 s record (an earthquake's length) at 2.5 Hz, N is about 3,
    and a fixed threshold of 2.2 reads a third of randomly driven modes as harmonics. With
    the threshold two such deviations below 3 none is; a sine over 600 s still is."""
    from scipy.stats import kurtosis

    from modal_twin.identification.clustering import HARMONIC_KURTOSIS, is_harmonic

    fs, n, f0 = 100.0, 6500, 2.53
    w, z = 2 * np.pi * f0, 0.01  # half-power width 2 z f0: the test's band
    sysd = sig.cont2discrete(([1.0], [1.0, 2 * z * w, w * w]), 1 / fs, method="zoh")
    sos = sig.butter(4, [0.99 * f0, 1.01 * f0], btype="bandpass", fs=fs, output="sos")
    fixed = 0
    for seed in range(20):
        e = np.random.default_rng(seed).standard_normal(n + 5000)
        mode = sig.lfilter(np.ravel(sysd[0]), sysd[1], e)[5000:]
        assert not is_harmonic(mode[None, :], fs, f0), seed
        yb = sig.sosfiltfilt(sos, mode)[n // 10: n - n // 10]
        fixed += int(kurtosis(yb, fisher=False) <= HARMONIC_KURTOSIS)
    assert fixed >= 3  # the fixed threshold's false calls on the same records
    t = np.arange(60_000) / fs
    sine = np.sin(2 * np.pi * f0 * t) + 0.3 * np.random.default_rng(1).standard_normal(t.size)
    assert is_harmonic(sine[None, :], fs, f0)


def test_a_column_with_no_peak_in_the_spectrum_is_not_a_mode() -> None:
    """Two modes (2 and 4 Hz, 1 %) in a 600 s response and three stable columns of
    poles: at 2 and 4 Hz along their shapes, and at 3 Hz along a third shape, where the
    response has no mode (a model pole fitting noise). The spectrum along each shape
    (enhanced FDD) peaks at 2 and 4 Hz only: the 3 Hz column is dropped and said, and
    a heavily damped column at 4.6 Hz on the 4 Hz mode's flank has no peak of its own."""
    from modal_twin.identification.clustering import spectral_peak

    rng = np.random.default_rng(3)
    n = int(FS * 600)
    q = np.array([_resonator(f, 0.01, rng.standard_normal(n)) for f in (2.0, 4.0)])
    y = SHAPES[:, :2].real @ q
    y += 0.05 * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)
    peak = spectral_peak(y, FS)
    assert peak(2.0, 0.01, SHAPES[:, 0]) and peak(4.0, 0.01, SHAPES[:, 1])
    assert not peak(3.0, 0.01, SHAPES[:, 2]) and not peak(4.6, 0.06, SHAPES[:, 1])
    cols = [(2.0, 0.01, SHAPES[:, 0], range(20)), (4.0, 0.01, SHAPES[:, 1], range(20)),
            (3.0, 0.01, SHAPES[:, 2], range(20))]
    d = stabilization_diagram(_sweep(cols))
    assert cluster_modes(d).modes.f_hz.tolist() == [2.0, 3.0, 4.0]  # without the record
    cm = cluster_modes(d, spectrum=peak)
    assert cm.modes.f_hz.tolist() == [2.0, 4.0]
    assert [round(c.f_hz, 1) for c in cm.dropped] == [3.0]
    assert cm.dropped[0].reason.startswith("no peak of its own in the spectrum")


def _split_column(z_high: float, f_low: float = 3.72) -> list[tuple[float, float, np.ndarray,
                                                                    range]]:
    """Two full columns (1 and 2 Hz) and a 3.806 Hz mode whose column breaks by the order:
    orders 1-4 under-fitted (``f_low``, 2.1 % damping, a shape of MAC 0.94 with the
    mode's), orders 17-20 converged (3.806 Hz, ``z_high``), as Hayward 2021-11-17's
    3.80 Hz mode under SSI-cov (3.725 / 3.808 Hz, 4 poles each)."""
    drift = 1e-4 * np.arange(20)
    bent = SHAPES[:, 2] + 0.25 * SHAPES[:, 1]
    cols = [(1.0 * (1 + drift[k]), 0.02, SHAPES[:, 0], range(k, k + 1)) for k in range(20)]
    cols += [(2.0 * (1 + drift[k]), 0.01, SHAPES[:, 1], range(k, k + 1)) for k in range(20)]
    cols += [(f_low * (1 + drift[k]), 0.021, bent, range(k, k + 1)) for k in range(4)]
    cols += [(3.806 * (1 + drift[k]), z_high, SHAPES[:, 2], range(k, k + 1))
             for k in range(16, 20)]
    return cols


def test_a_column_split_by_the_order_is_one_mode_at_its_converged_poles() -> None:
    cm = cluster_modes(stabilization_diagram(_sweep(_split_column(0.006))))
    assert cm.n_min == 7  # each part (4 poles) too short on its own
    np.testing.assert_allclose(cm.modes.f_hz, [1.00095, 2.0019, 3.806 * 1.00175], rtol=1e-9)
    assert cm.modes.n_support.tolist() == [20, 20, 7]  # 3 + 4: order 4 has no next pole
    assert cm.modes.zeta[2] == pytest.approx(0.006)  # the high-order part's
    assert cm.dropped == ()


@pytest.mark.parametrize(("z_high", "f_low"), [(0.03, 3.72), (0.006, 3.60)])
def test_a_split_column_is_not_joined_when_the_parts_disagree(z_high: float,
                                                              f_low: float) -> None:
    # high-order part more damped than the low one; or 5.4 % apart, beyond 2 x 2.1 %
    cm = cluster_modes(stabilization_diagram(_sweep(_split_column(z_high, f_low))))
    np.testing.assert_allclose(cm.modes.f_hz, [1.00095, 2.0019], rtol=1e-9)
    assert [d.reason.split(":")[0] for d in cm.dropped] == ["too few poles"] * 2
