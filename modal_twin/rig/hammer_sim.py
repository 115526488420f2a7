r"""A simulated roving-hammer test of a matrix model: hits, responses, sensor noise.

The hammer hits each point ``hits_per_point`` times (every ``spacing_s``), then roves to
the next; each hit is a half-sine pulse of the tip's contact time
(:func:`~modal_twin.excitation.signals.hammer_pulse`), every ``double_hit_every``-th one
bouncing. The structure's response is the modal superposition of its modes below
``f_max_hz`` with modal damping ``zeta``,

.. math::
   \ddot q_r + 2 \zeta \omega_r \dot q_r + \omega_r^2 q_r = \phi_r^T f(t), \qquad
   \ddot x = \Phi \ddot q,

integrated exactly for a force linear between samples (``scipy.signal.lsim``). Gaussian
noise of ``noise`` x each channel's RMS (over the test) is added to the responses and of
``force_noise_n`` to the forces, from a seeded generator.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import linalg, signal

from modal_twin._types import FloatArray
from modal_twin.errors import OptionError
from modal_twin.excitation.signals import hammer_pulse

__all__ = ["HammerTestPlan", "simulate_roving_hammer"]


@dataclass(frozen=True, slots=True)
class HammerTestPlan:
    """How the simulated test is run (SI units)."""

    fs_hz: float = 4096.0
    hits_per_point: int = 4
    spacing_s: float = 5.0
    peak_n: float = 200.0
    tip_stiffness_n_m: float = 2.0e6
    hammer_mass_kg: float = 0.3
    double_hit_every: int = 0
    zeta: float = 0.015
    noise: float = 0.01
    force_noise_n: float = 0.05
    f_max_hz: float = 1500.0
    seed: int = 0


def simulate_roving_hammer(M: FloatArray, K: FloatArray, hit_dofs: Sequence[int],
                           response_dofs: Sequence[int], plan: HammerTestPlan
                           ) -> tuple[FloatArray, FloatArray]:
    """Return the forces ``(n_points, nt)`` (N) and accelerations ``(n_responses, nt)``.

    Raises
    ------
    OptionError
        No mode below ``f_max_hz``, or a plan outside its ranges.
    """
    p = plan
    if not (p.fs_hz > 0 and p.hits_per_point >= 1 and p.spacing_s > 0 and p.zeta > 0
            and p.noise >= 0 and p.force_noise_n >= 0 and p.double_hit_every >= 0):
        msg = f"hammer test plan: a value outside its range in {p}"
        raise OptionError(msg)
    w2, phi = linalg.eigh(K, M)
    keep = np.sqrt(np.clip(w2, 0.0, None)) / (2 * np.pi) < min(p.f_max_hz, 0.45 * p.fs_hz)
    if not keep.any():
        msg = f"hammer test: no mode below {p.f_max_hz} Hz"
        raise OptionError(msg)
    wn, ph = np.sqrt(w2[keep]), phi[:, keep]  # mass-normalised
    nm = wn.size
    a = np.block([[np.zeros((nm, nm)), np.eye(nm)],
                  [-np.diag(wn**2), -np.diag(2 * p.zeta * wn)]])
    b = np.vstack([np.zeros((nm, len(hit_dofs))), ph[list(hit_dofs)].T])
    out = ph[list(response_dofs)]
    c, d = out @ a[nm:], out @ b[nm:]
    n_pts = len(hit_dofs)
    nt = round(n_pts * p.hits_per_point * p.spacing_s * p.fs_hz)
    forces = np.zeros((n_pts, nt))
    kw = {"tip_stiffness_n_m": p.tip_stiffness_n_m, "hammer_mass_kg": p.hammer_mass_kg}
    k = 0
    for i in range(n_pts):
        for h in range(p.hits_per_point):
            at = 0.2 + (i * p.hits_per_point + h) * p.spacing_s
            forces[i] += hammer_pulse(nt, p.fs_hz, peak_n=p.peak_n, at_s=at, **kw)
            k += 1
            if p.double_hit_every and k % p.double_hit_every == 0:
                forces[i] += hammer_pulse(nt, p.fs_hz, peak_n=0.4 * p.peak_n,
                                          at_s=at + 0.03, **kw)
    t = np.arange(nt) / p.fs_hz
    _, acc, _ = signal.lsim(signal.StateSpace(a, b, c, d), forces.T, t)
    acc = np.atleast_2d(np.asarray(acc).T)
    rng = np.random.default_rng(p.seed)
    rms = np.sqrt(np.mean(acc**2, axis=1, keepdims=True))
    acc = acc + p.noise * rms * rng.standard_normal(acc.shape)
    forces = forces + p.force_noise_n * rng.standard_normal(forces.shape)
    return forces, acc
