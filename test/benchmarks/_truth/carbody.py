"""Truth carbody of the updating benchmark: a simulated modal test of a car whose zones are off.

The truth is **built**, not parametrised: the carbody of :mod:`modal_twin.models.carbody3d`
with its zone table rewritten (moduli and densities times known factors) and assembled anew,
its modes from a dense-free shift-invert solve of its own matrices, and its FRFs
(accelerance, m/s^2/N) by modal superposition with modal damping, written here::

    H_ij(w) = sum_r  -w^2 phi_ir phi_jr / (w_r^2 - w^2 + 2 j zeta_r w_r w)

(rigid modes: the mass line ``phi_ir phi_jr``), plus complex Gaussian noise proportional
to each FRF's RMS. The library's updating sees only the FRFs.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse.linalg as spla

from modal_twin.models.carbody3d import CarbodyFE, CarbodyParams, build_carbody

TRUTH_FACTORS: dict[str, float] = {
    "E_underframe": 1.10,
    "E_side_wall": 0.88,
    "rho_roof": 1.08,
    "E_roof": 0.94,
    "rho_underframe": 0.96,
}
"""Known zone errors of the truth: -12 % side-wall E, +8 % roof rho, ..."""


@dataclass(frozen=True, slots=True)
class CarbodyTest:
    """A simulated modal test: FRFs, the truth's modes, its carbody."""

    f_hz: np.ndarray  # (n_f,) frequency lines
    H: np.ndarray  # (n_out, n_in, n_f) complex accelerance with noise
    H_clean: np.ndarray
    f_true: np.ndarray  # (n_modes,) flexible frequencies of the truth, Hz
    zeta_true: np.ndarray
    car: CarbodyFE


def truth_params(base: CarbodyParams, factors: dict[str, float]) -> CarbodyParams:
    """Return ``base`` with zone moduli / densities multiplied by ``factors``."""
    zones = dict(base.zones)
    for key, fac in factors.items():
        kind, zone = key.split("_", 1)
        z = zones[zone]
        if kind == "E":
            zones[zone] = replace(z, E=z.E * fac, E_service=None if z.E_service is None
                                  else z.E_service * fac)
        else:
            zones[zone] = replace(z, rho=z.rho * fac)
    return replace(base, zones=zones)


def modal_test(base: CarbodyParams, outputs: list, inputs: list, *,
               factors: dict[str, float] | None = None, n_modes: int = 40,
               df_hz: float = 0.0625, f_max_hz: float = 32.0, noise: float = 0.01,
               seed: int = 7) -> CarbodyTest:
    """Simulate the FRFs of the truth carbody between ``inputs`` and ``outputs``.

    ``outputs`` / ``inputs``: (node, dof) pairs (node ids are the same in every build of
    the same mesh). Damping ``zeta = 1.5 % + 0.05 % per mode``; noise: complex Gaussian of
    ``noise`` times each FRF's RMS on every line.
    """
    car = build_carbody(truth_params(base, TRUTH_FACTORS if factors is None else factors))
    K, M = car.asm.K.tocsc(), car.asm.M.tocsc()
    v0 = np.random.default_rng(0).standard_normal(K.shape[0])  # same FRFs on every run
    lam, Phi = spla.eigsh(K, k=n_modes, M=M, sigma=-40.0, which="LM", v0=v0)
    order = np.argsort(lam)
    lam, Phi = np.clip(lam[order], 0.0, None), Phi[:, order]
    Phi = Phi / np.sqrt(np.einsum("ij,ij->j", Phi, M @ Phi))
    out = [car.asm.dof_index(n, d) for n, d in outputs]
    inp = [car.asm.dof_index(n, d) for n, d in inputs]
    wr = np.sqrt(lam)
    zeta = 0.015 + 0.0005 * np.arange(n_modes)
    zeta[wr < 1.0] = 0.0
    f = np.arange(0.0, f_max_hz + 1e-9, df_hz)
    w = 2 * np.pi * f
    H = np.zeros((len(out), len(inp), f.size), dtype=complex)
    for r in range(n_modes):
        A = np.outer(Phi[out, r], Phi[inp, r])
        if wr[r] < 1.0:  # rigid: mass line
            H += A[:, :, None]
        else:
            H += A[:, :, None] * (-w**2 / (wr[r] ** 2 - w**2 + 2j * zeta[r] * wr[r] * w))
    rng = np.random.default_rng(seed)
    rms = np.sqrt(np.mean(np.abs(H[..., 1:]) ** 2, axis=-1, keepdims=True))
    Hn = H + noise * rms * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape))
    Hn[..., 0] = 0.0
    flex = wr >= 1.0
    return CarbodyTest(f, Hn, H, wr[flex] / (2 * np.pi), zeta[flex], car)
