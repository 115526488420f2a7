"""PolyMAX on a simulated 5-DOF chain with known modes: output-only and input-output.

The truth is the chain's own eigenproblem (undamped frequencies, modal damping set per
mode), simulated by exact discretisation of its state space; it shares no code with the
identification. Output-only: every mass driven by white noise, the forces left out, PolyMAX on the
positive half-spectra of the correlations. Input-output: the same record with the forces
measured, PolyMAX on H1. Either way every mode within 0.5 % and nothing else.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.signal as sig

from modal_twin.channels import ChannelSpec
from modal_twin.identification.record import IdentifyOptions, identify_record
from modal_twin.signal_block import SignalBlock

MASS = np.array([1.0, 1.2, 0.9, 1.1, 0.8])
K = np.array([3.0e3, 2.6e3, 2.2e3, 1.8e3, 1.4e3])
ZETA = np.array([0.010, 0.012, 0.015, 0.015, 0.020])
FS, SECONDS = 60.0, 300.0


def _chain() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Mass, stiffness, damping matrices and the undamped frequencies (Hz)."""
    k = np.r_[K, 0.0]
    Kk = np.diag(k[:-1] + k[1:]) - np.diag(K[1:], 1) - np.diag(K[1:], -1)
    M = np.diag(MASS)
    w2, V = sla.eigh(Kk, M)  # V^T M V = I
    C = M @ V @ np.diag(2 * ZETA * np.sqrt(w2)) @ V.T @ M
    return M, Kk, C, np.sqrt(w2) / (2 * np.pi)


def _record(forces: np.ndarray, seed: int) -> np.ndarray:
    """Accelerations of the five masses under ``forces`` (5, n), with 2 % noise."""
    M, Kk, C, _ = _chain()
    Mi = np.linalg.inv(M)
    A = np.block([[np.zeros((5, 5)), np.eye(5)], [-Mi @ Kk, -Mi @ C]])
    B = np.vstack([np.zeros((5, 5)), Mi])
    Cy = np.hstack([-Mi @ Kk, -Mi @ C])
    sysd = sig.cont2discrete((A, B, Cy, Mi), 1 / FS, method="zoh")
    _, y, _ = sig.dlsim((*sysd[:4], 1 / FS), forces.T)
    rng = np.random.default_rng(seed)
    return np.asarray(y.T + 0.02 * y.std(axis=0)[:, None] * rng.standard_normal(y.T.shape))


def _block(data: np.ndarray, roles: list[str]) -> tuple[SignalBlock, list[ChannelSpec]]:
    names = tuple(f"c{k}" for k in range(data.shape[0]))
    chans = [ChannelSpec(n, "force" if r == "input" else "acceleration", direction="x",
                         role=r, node=f"n{k}") for k, (n, r) in enumerate(zip(names, roles,
                                                                              strict=True))]
    return SignalBlock(names, FS, 0, data, source="chain"), chans


def _check(rec_f: np.ndarray, rec_zeta: np.ndarray, zeta_rtol: float) -> None:
    f_true = _chain()[3]
    assert rec_f.size == f_true.size, (rec_f, f_true)  # every mode and nothing else
    np.testing.assert_allclose(rec_f, f_true, rtol=0.005)
    np.testing.assert_allclose(rec_zeta, ZETA, rtol=zeta_rtol)


@pytest.fixture(scope="module")
def record() -> tuple[np.ndarray, np.ndarray]:
    """Five measured white-noise forces, one per mass, and the five accelerations."""
    f = _chain()[3]
    assert f[0] > 2.0 and f[-1] < 15.0  # the modes sit well inside a 20 Hz band
    rng = np.random.default_rng(3)
    force = rng.standard_normal((5, int(FS * SECONDS)))
    return force, _record(force, seed=4)


def test_output_only_polymax_finds_every_mode(record: tuple[np.ndarray, np.ndarray]) -> None:
    force, y = record
    block, chans = _block(np.vstack([force, y]), ["input"] * 5 + ["output"] * 5)
    rec = identify_record(block, chans, IdentifyOptions(method="polymax", inputs=(),
                                                        f_max_hz=20.0))
    assert rec.inputs == () and any("positive half-spectra" in n for n in rec.notes)
    # 300 s, output-only: frequencies within 0.2 %, damping 0.86-0.96 x the truth
    _check(rec.modes.f_hz, rec.modes.zeta, zeta_rtol=0.5)
    # a channel called an input that does not drive the chain: no H1, output-only, said
    u = np.random.default_rng(5).standard_normal((1, y.shape[1]))
    block, chans = _block(np.vstack([u, y]), ["input"] + ["output"] * 5)
    oo = identify_record(block, chans, IdentifyOptions(method="polymax", f_max_hz=20.0))
    assert oo.inputs == () and any("PolyMAX output-only: 1 driven inputs" in n
                                   for n in oo.notes)
    np.testing.assert_allclose(oo.modes.f_hz, rec.modes.f_hz)


def test_input_output_polymax_finds_every_mode(record: tuple[np.ndarray, np.ndarray]) -> None:
    force, y = record
    block, chans = _block(np.vstack([force, y]), ["input"] * 5 + ["output"] * 5)
    rec = identify_record(block, chans, IdentifyOptions(method="polymax", f_max_hz=20.0))
    assert [c.name for c in rec.inputs] == ["c0", "c1", "c2", "c3", "c4"]
    assert any("PolyMAX on H1" in n for n in rec.notes)
    # input-output: frequencies within 0.07 %, damping 0.98-1.23 x the truth
    _check(rec.modes.f_hz, rec.modes.zeta, zeta_rtol=0.3)
