"""PolyMAX on a sub-band whose z-domain basis is too ill-conditioned for normal equations.

Output-only PolyMAX fits the half-spectra octave by octave, each octave with its own basis
:math:`\\Delta t = 1 / 2 f_{\\max}` (Eq. (3) of [002]); an octave then covers only part of
the unit circle, where the powers of :math:`Z` are nearly dependent and the Cholesky factor
of :math:`R = \\mathrm{Re}(X^H X)` fails (condition number beyond 1e16 at order 20 over
8.6-15 Hz). Known answers:

1. a closed-form FRF of three modes (two of them 3.7 % apart) fitted over 8.6-15 Hz:
   every order from 10 to 20 returns the three frequencies to 1e-4 and damping ratios to
   1 % (noise-free; the z-domain model of a continuous FRF is exact only in the limit) with
   numerator shapes, through the QR of the basis (``polymax._orthogonal_rows``); the earlier
   pseudo-root of R gave wrong reduced normal equations below the top order (frequencies
   1-2.5 % off at orders 10-13) and no shapes at all;
2. a 3-DOF system with close modes (its own eigenproblem, exact discretisation), every mass
   driven by white noise for 120 s and read output-only with a 15 Hz band: PolyMAX finds
   the three modes within 0.5 % (before the QR: none) and their damping within -50 / +20 %
   (output-only PolyMAX's damping is biased low on short records: 0.56-0.89 x the truth
   over four seeds).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.signal as sig

from modal_twin.channels import ChannelSpec
from modal_twin.identification.polymax import polymax
from modal_twin.identification.record import IdentifyOptions, identify_record
from modal_twin.signal_block import SignalBlock

F_MODES = np.array([10.0, 10.37, 13.3])
Z_MODES = np.array([0.01, 0.012, 0.015])


def test_ill_conditioned_sub_band_gives_the_poles_at_every_order() -> None:
    band = (8.6, 15.0)
    f = np.arange(8.6, 15.0, 0.01)
    s = 2j * np.pi * f
    lam = 2 * np.pi * F_MODES * (-Z_MODES + 1j * np.sqrt(1 - Z_MODES**2))
    res = np.array([[1.0, 0.6, -0.4], [0.5, -1.0, 0.8]])  # (n_out, modes), real residues
    H = sum(res[:, [r]] / (s - lam[r]) + res[:, [r]] / (s - lam[r].conj())
            for r in range(3))[:, None, :]
    # the basis of this band is beyond what a Cholesky factor of R can take
    th = np.pi * f / band[1]
    q = np.arange(21)
    R = np.cos(np.subtract.outer(q, q)[..., None] * th).sum(axis=-1)
    with pytest.raises(np.linalg.LinAlgError):
        sla.cholesky(R, lower=True)
    sw = polymax(H, f, orders=range(10, 21), band_hz=band, shapes="numerator")
    for p in sw.poles:
        for fr, zr in zip(F_MODES, Z_MODES, strict=True):
            k = int(np.argmin(np.abs(p.f_hz - fr)))
            assert p.f_hz[k] == pytest.approx(fr, rel=1e-4), (p.order, p.f_hz)
            assert p.zeta[k] == pytest.approx(zr, rel=1e-2), (p.order, p.zeta)
        assert np.all(np.isfinite(p.shapes)), p.order  # numerator shapes at every order


FS = 50.0
MASS = np.eye(3)
STIFF = np.array([[5320.0, -80.0, 0.0], [-80.0, 5824.8, -400.0], [0.0, -400.0, 6880.0]])
ZETA = np.array([0.010, 0.012, 0.015])


def _truth() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Damping matrix (modal damping ZETA) and the undamped frequencies (Hz), ascending."""
    w2, V = sla.eigh(STIFF, MASS)  # V^T M V = I
    C = MASS @ V @ np.diag(2 * ZETA * np.sqrt(w2)) @ V.T @ MASS
    return C, np.sqrt(w2) / (2 * np.pi), w2


@pytest.mark.parametrize("seed", [0, 1])
def test_output_only_polymax_finds_close_modes_of_a_3dof_system(seed: int) -> None:
    C, f_true, _ = _truth()
    assert 1.03 < f_true[1] / f_true[0] < 1.04  # two modes 3.7 % apart
    A = np.block([[np.zeros((3, 3)), np.eye(3)], [-STIFF, -C]])  # M = I
    B = np.vstack([np.zeros((3, 3)), np.eye(3)])
    Cy = np.hstack([-STIFF, -C])  # accelerations
    sysd = sig.cont2discrete((A, B, Cy, np.eye(3)), 1 / FS, method="zoh")
    rng = np.random.default_rng(seed)
    force = rng.standard_normal((3, int(FS * 120)))
    _, y, _ = sig.dlsim((*sysd[:4], 1 / FS), force.T)
    y = y.T + 0.02 * y.std(axis=0)[:, None] * rng.standard_normal(y.T.shape)
    names = ("a1", "a2", "a3")
    block = SignalBlock(names, FS, 0, y, source="3dof")
    chans = [ChannelSpec(n, "acceleration", direction="x", role="output", node=f"n{k}")
             for k, n in enumerate(names)]
    rec = identify_record(block, chans, IdentifyOptions(method="polymax", f_max_hz=15.0))
    assert any("positive half-spectra" in n for n in rec.notes)
    assert rec.modes.f_hz.size == 3, rec.modes.f_hz  # every mode and nothing else
    np.testing.assert_allclose(rec.modes.f_hz, f_true, rtol=0.005)
    ratio = rec.modes.zeta / ZETA
    assert np.all((ratio > 0.5) & (ratio < 1.2)), ratio
