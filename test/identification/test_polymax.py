from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.signal as sig

from modal_twin.acquisition.frf import frf
from modal_twin.errors import OptionError, ShapeError, SignalError
from modal_twin.identification.metrics import mac
from modal_twin.identification.polymax import polymax
from modal_twin.identification.stabilization import select_modes, stabilization_diagram


def _chain() -> tuple:
    n = 5
    k = np.linspace(1.0, 0.6, n) * 1e3
    K = np.diag(k + np.r_[k[1:], 0.0]) - np.diag(k[1:], 1) - np.diag(k[1:], -1)
    w2, Phi = sla.eigh(K)
    w = np.sqrt(w2)
    C = Phi @ np.diag(2 * 0.02 * w) @ Phi.T
    return np.eye(n), C, K, w / (2 * np.pi), np.full(n, 0.02), Phi


def _analytic_frf(M, C, K, f_hz, in_dofs) -> np.ndarray:
    w = 2 * np.pi * f_hz
    Z = -(w**2)[:, None, None] * M + 1j * w[:, None, None] * C + K
    return np.moveaxis(np.linalg.inv(Z)[:, :, in_dofs], 0, -1)  # receptance


def test_analytic_frf_exact_poles() -> None:
    M, C, K, f, z, Phi = _chain()
    fl = np.linspace(0.5, 10.0, 800)
    H = _analytic_frf(M, C, K, fl, [0, 4])
    mm = select_modes(stabilization_diagram(polymax(H, fl, orders=range(4, 21))))
    np.testing.assert_allclose(mm.f_hz, f, rtol=1e-4)
    np.testing.assert_allclose(mm.zeta, z, rtol=1e-2)
    assert np.diag(mac(mm.shapes, Phi)).min() > 0.9999
    assert np.all(np.isnan(mm.std_f_hz))


def test_chain_20db_frf_from_simulation() -> None:
    _M, C, K, f, z, Phi = _chain()
    n = 5
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-K, -C]])
    B = np.vstack([np.zeros((n, 2)), np.eye(n)[:, [0, 4]]])
    fs = 4.0 * f.max()
    sysd = sig.cont2discrete((A, B, A[n:], np.eye(n)[:, [0, 4]]), 1 / fs)
    rng = np.random.default_rng(0)
    u = rng.standard_normal((2, 40000))
    _, y, _ = sig.dlsim(sig.dlti(*sysd[:4], dt=1 / fs), u.T)
    y = y.T + rng.standard_normal((n, 40000)) * y.T.std(axis=1, keepdims=True) * 0.1  # 20 dB
    est = frf(u, y, fs, nperseg=2048)
    sweep = polymax(est.H1, est.f_hz, orders=range(2, 31), band_hz=(0.5, 0.45 * fs))
    assert sweep.method == "polymax"
    mm = select_modes(stabilization_diagram(sweep))
    assert mm.f_hz.size == 5
    np.testing.assert_allclose(mm.f_hz, f, rtol=3e-3)
    np.testing.assert_allclose(mm.zeta, z, rtol=0.10)
    assert np.diag(mac(mm.shapes, Phi)).min() > 0.99


def test_civil_scale_sdof() -> None:
    lam = 2 * np.pi * 0.7 * (-0.05 + 1j * np.sqrt(1 - 0.05**2))
    fl = np.linspace(0.2, 2.0, 300)
    s = 2j * np.pi * fl
    H = (1 / (s - lam) + 1 / (s - np.conj(lam)))[None, None, :]
    p = polymax(H, fl, orders=[8]).poles[0]
    k = np.argmin(np.abs(p.f_hz - 0.7))
    assert p.f_hz[k] == pytest.approx(0.7, rel=1e-4)
    assert p.zeta[k] == pytest.approx(0.05, rel=1e-3)


def test_bad_input() -> None:
    fl = np.linspace(1.0, 10.0, 100)
    H = np.ones((2, 1, 100), complex)
    with pytest.raises(ShapeError, match=r"expected \(n_out, n_in, n_f\) and \(n_f,\)"):
        polymax(H, fl[:-1], orders=[4])
    with pytest.raises(OptionError, match="band_hz: expected 0 <= f_lo < f_hi"):
        polymax(H, fl, orders=[4], band_hz=(5.0, 2.0))
    Hn = H.copy()
    Hn[0, 0, 50] = np.nan
    with pytest.raises(SignalError, match="finite FRF lines in the band"):
        polymax(Hn, fl, orders=[4])
    with pytest.raises(ShapeError, match="expected at least 42 lines"):
        polymax(H, fl, orders=[20], band_hz=(1.0, 3.0))
    with pytest.raises(OptionError, match="orders: expected orders <="):
        polymax(H, fl, orders=[200])
    with pytest.raises(SignalError, match="non-zero FRF"):
        polymax(np.zeros_like(H), fl, orders=[4])


def test_numerator_shapes_then_lsfd_for_selected_modes() -> None:
    from modal_twin.identification.lsfd import lsfd, lsfd_modes

    M, C, K, f, z, Phi = _chain()
    fl = np.linspace(0.5, 10.0, 800)
    H = _analytic_frf(M, C, K, fl, [0, 4])
    full = select_modes(stabilization_diagram(polymax(H, fl, orders=range(4, 21))))
    fast = select_modes(
        stabilization_diagram(polymax(H, fl, orders=range(4, 21), shapes="numerator"))
    )
    # same poles either way (shapes only enter the MAC criterion), exact shapes from B(z_r) v_r
    np.testing.assert_allclose(fast.f_hz, f, rtol=1e-4)
    np.testing.assert_allclose(fast.zeta, z, rtol=1e-2)
    assert np.diag(mac(fast.shapes, Phi)).min() > 0.9999
    ref = lsfd_modes(fast, H, fl)
    assert np.diag(mac(ref.shapes, Phi)).min() > 0.9999
    lam = 2 * np.pi * fast.f_hz * (-fast.zeta + 1j * np.sqrt(1 - fast.zeta**2))
    np.testing.assert_allclose(ref.shapes, lsfd(H, fl, lam).shapes, rtol=1e-12)
    assert np.diag(mac(full.shapes, ref.shapes)).min() > 0.9999
    with pytest.raises(OptionError, match=r"shapes: expected one of \['lsfd', 'numerator'\]"):
        polymax(H, fl, orders=[4], shapes="svd")  # type: ignore[arg-type]


def test_poles_without_participation_are_the_same() -> None:
    from modal_twin.identification.polymax import polymax_poles

    M, C, K, *_ = _chain()
    fl = np.linspace(0.5, 10.0, 400)
    H = _analytic_frf(M, C, K, fl, [0, 4])
    a = polymax_poles(H, fl, [6, 9], 1 / 20.0)
    b = polymax_poles(H, fl, [6, 9], 1 / 20.0, participation=False)
    for (pa, la, La), (pb, lb, Lb) in zip(a, b, strict=True):
        assert pa == pb
        assert La.shape == (2, la.size)
        assert Lb.shape == (2, 0)
        np.testing.assert_allclose(np.sort_complex(la), np.sort_complex(lb), rtol=1e-9)
