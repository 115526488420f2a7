"""Simulated records with known modes for the identification benchmark (no ROS, no peers).

A generic multi-DOF structure given directly in modal form: N modes with natural
frequencies :math:`f_r`, damping ratios :math:`\\zeta_r`, real shapes :math:`\\phi_r` at
the l output sensors and input participations :math:`b_r` for the m inputs. Each modal
coordinate obeys :math:`\\ddot q_r + 2 \\zeta_r \\omega_r \\dot q_r + \\omega_r^2 q_r =
b_r^T u` and the outputs are accelerations :math:`y = \\sum_r \\phi_r \\ddot q_r`. Time
records use the exact zero-order-hold discretisation (``scipy.signal.cont2discrete``) with
white-noise inputs and 20 dB white output noise; FRFs (accelerance) are evaluated in closed
form with complex noise of the same relative level.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.signal as sig

from modal_twin._types import ComplexArray, FloatArray

__all__ = ["ModalTruth", "TimeRecord", "chain_earthquake", "frf_record", "modal_truth",
           "time_record"]


@dataclass(frozen=True, slots=True)
class ModalTruth:
    """Known modes: f_hz (N,), zeta (N,), shapes (l, N), participation (m, N)."""

    f_hz: FloatArray
    zeta: FloatArray
    shapes: FloatArray
    participation: FloatArray


@dataclass(frozen=True, slots=True)
class TimeRecord:
    """Inputs u (m, n), noisy outputs y (l, n), sample rate and the truth."""

    u: FloatArray
    y: FloatArray
    fs_hz: float
    truth: ModalTruth


def modal_truth(
    f_hz: list[float], zeta: list[float], n_out: int, n_in: int, seed: int = 0
) -> ModalTruth:
    """Smooth, distinct real shapes (sines plus 30 % seeded scatter) and participations."""
    rng = np.random.default_rng(seed)
    x = (np.arange(n_out) + 0.5) / n_out
    r = np.arange(1, len(f_hz) + 1)
    shapes = np.sin(np.pi * np.outer(x, r)) + 0.3 * rng.standard_normal((n_out, len(f_hz)))
    shapes /= np.abs(shapes).max(axis=0)
    part = rng.uniform(0.5, 1.5, (n_in, len(f_hz))) * rng.choice([-1.0, 1.0], (n_in, len(f_hz)))
    return ModalTruth(np.asarray(f_hz, float), np.asarray(zeta, float), shapes, part)


def _state_space(t: ModalTruth) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    w = 2 * np.pi * t.f_hz
    n = w.size
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-np.diag(w**2), -np.diag(2 * t.zeta * w)]])
    B = np.vstack([np.zeros((n, t.participation.shape[0])), t.participation.T])
    C = t.shapes @ A[n:]  # y = phi qdd = phi (-w^2 q - 2 zeta w qd + b^T u)
    D = t.shapes @ t.participation.T
    return A, B, C, D


def time_record(
    truth: ModalTruth, fs_hz: float, n_samples: int, *, snr_db: float = 20.0, seed: int = 1
) -> TimeRecord:
    """Acceleration response to white-noise inputs with white output noise at ``snr_db``."""
    rng = np.random.default_rng(seed)
    A, B, C, D = _state_space(truth)
    Ad, Bd, Cd, Dd, _ = sig.cont2discrete((A, B, C, D), 1.0 / fs_hz)
    u = rng.standard_normal((B.shape[1], n_samples))
    x = np.zeros((A.shape[0], n_samples))
    xk = np.zeros(A.shape[0])
    Bu = Bd @ u
    for k in range(n_samples - 1):  # modal states: cheap even for 20k samples
        xk = Ad @ xk + Bu[:, k]
        x[:, k + 1] = xk
    y = Cd @ x + Dd @ u
    noise = rng.standard_normal(y.shape) * y.std(axis=1, keepdims=True) * 10 ** (-snr_db / 20)
    return TimeRecord(u, y + noise, float(fs_hz), truth)


def frf_record(
    truth: ModalTruth, f_hz: FloatArray, *, snr_db: float = 30.0, seed: int = 2
) -> ComplexArray:
    """Accelerance FRFs H (l, m, n_f) in closed form with complex noise at ``snr_db``."""
    rng = np.random.default_rng(seed)
    w = 2 * np.pi * np.asarray(f_hz, float)
    wr = 2 * np.pi * truth.f_hz
    den = wr[:, None] ** 2 - w[None, :] ** 2 + 2j * truth.zeta[:, None] * wr[:, None] * w
    q = -(w[None, :] ** 2) / den  # (N, n_f)
    H = np.einsum("or,ir,rk->oik", truth.shapes, truth.participation, q)
    lvl = np.sqrt(np.mean(np.abs(H) ** 2, axis=-1, keepdims=True)) * 10 ** (-snr_db / 20)
    noise = (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)) / np.sqrt(2)
    out: ComplexArray = H + noise * lvl
    return out


def chain_earthquake(seconds: float = 60.0, fs_hz: float = 100.0, *, seed: int = 1,
                     zeta: float = 0.02, snr_db: float = 26.0
                     ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Absolute floor accelerations (5, n) of a 5-DOF shear chain shaken at its base.

    Equal storey masses (1) and stiffnesses k = (2 pi 4)^2 as a column of springs fixed
    at the ground: modes at 1.139, 3.323, 5.239, 6.730, 7.676 Hz (the fixed-free chain,
    ``f_r = (2 / 2 pi) sqrt(k) sin((2r - 1) pi / 22)``), each ``zeta``
    damped (modal damping). The ground acceleration is band-limited noise (0.25-10 Hz,
    Butterworth 2nd order) under a build-up (15 % of the record), strong-motion (to
    50 %) and exponential-decay envelope, as an earthquake record; white output noise
    at ``snr_db``. Simulated in modal coordinates with the exact zero-order-hold
    discretisation.

    Returns
    -------
    (y, f_hz, zeta) : outputs (5, n), the true frequencies (5,) and damping ratios (5,)
    """
    rng = np.random.default_rng(seed)
    n_dof, k = 5, (2 * np.pi * 4.0) ** 2
    K = k * (2 * np.eye(n_dof) - np.eye(n_dof, k=1) - np.eye(n_dof, k=-1))
    K[-1, -1] = k  # free top
    w2, V = np.linalg.eigh(K)  # unit masses: the eigenvectors are mass-normalised
    w = np.sqrt(w2)
    gam = V.T @ np.ones(n_dof)  # participation of a uniform base acceleration
    nt = round(seconds * fs_hz)
    t = np.arange(nt) / fs_hz
    sos = sig.butter(2, [0.25, 10.0], btype="band", fs=fs_hz, output="sos")
    ag = sig.sosfiltfilt(sos, rng.standard_normal(nt))
    t1, t2 = 0.15 * seconds, 0.5 * seconds
    ag *= np.where(t < t1, (t / t1) ** 2, np.where(t < t2, 1.0, np.exp(-4.0 * (t - t2) / seconds)))
    y = np.zeros((n_dof, nt))
    for r in range(n_dof):  # q'' + 2 zeta w q' + w^2 q = -gam a_g; absolute acceleration
        # (the base's included, V gam = 1): V (-(2 zeta w q' + w^2 q))
        A = np.array([[0.0, 1.0], [-w2[r], -2 * zeta * w[r]]])
        B = np.array([[0.0], [-gam[r]]])
        C = np.array([[-w2[r], -2 * zeta * w[r]]])
        Ad, Bd, Cd, Dd, _ = sig.cont2discrete((A, B, C, np.zeros((1, 1))), 1.0 / fs_hz)
        _, yr, _ = sig.dlsim((Ad, Bd, Cd, Dd, 1.0 / fs_hz), ag)
        y += np.outer(V[:, r], yr[:, 0])
    y += rng.standard_normal(y.shape) * y.std(axis=1, keepdims=True) * 10 ** (-snr_db / 20)
    return y, w / (2 * np.pi), np.full(n_dof, zeta)
