r"""Impact (hammer) testing as [000] runs it: hits checked, windowed, averaged into FRFs.

A hammer test records, per hit, the force of the tip and the responses. Each hit is

1. **found** in the force channel (the force rises above a trigger level; a pre-trigger
   keeps the rise);
2. **checked**: a *double hit* (the force rises again after the pulse has ended, above a
   share of the first peak) and an *overload* (samples at the range of the force or of a
   response channel, or a flat top of several samples at the peak) reject the hit, with the
   reason said;
3. **windowed**: a force window (rectangular over the pulse, a cosine taper after it, zero
   beyond: the noise of the force channel between hits is cut) and an exponential window
   :math:`w(t) = e^{-t/\tau}` on the responses when they have not decayed within the block.
   The exponential window adds a known damping: a pole :math:`s_r` becomes
   :math:`s_r - 1/\tau`, so an identified modal damping ratio is corrected by
   :math:`\zeta_r = \zeta_{r,id} - 1/(\tau\,\omega_r)` (:func:`exponential_damping`);
4. **averaged** over the accepted hits into the auto- and cross-spectra and the estimators
   (one input)

   .. math::
      H_1 = \frac{S_{yx}}{S_{xx}}, \qquad H_2 = \frac{S_{yy}}{S_{xy}}, \qquad
      H_v = \frac{S_{yy} - S_{xx} + \sqrt{(S_{xx} - S_{yy})^2 + 4 |S_{yx}|^2}}{2 S_{xy}},

   with the ordinary coherence :math:`\gamma^2 = |S_{yx}|^2 / (S_{xx} S_{yy})`. ``H1`` is
   unbiased by noise on the responses, ``H2`` by noise on the force, ``Hv`` (total least
   squares, the eigenvector of the smallest eigenvalue of the 2 x 2 spectral matrix) lies
   between them and is the usual choice near resonances of lightly damped structures. It
   weighs the noise of force and response alike in their own units, so scale the channels
   to comparable noise first if that is what you want (with forces of newtons and responses
   of micrometres it stays by ``H1``).

The hammer's pulse (:func:`modal_twin.excitation.signals.hammer_pulse`) is a half sine
whose duration is fixed by the tip: a hammer of mass :math:`m_h` on a tip of contact
stiffness :math:`k_t` stays in contact half a period, :math:`T_c = \pi \sqrt{m_h / k_t}`;
its spectrum is flat to about :math:`1/T_c` and falls to its first zero at
:math:`1.5/T_c`, so a harder tip excites a wider band.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from modal_twin._types import ComplexArray, FloatArray
from modal_twin.errors import OptionError, ShapeError, SignalError

__all__ = ["HitCheck", "ImpactFRF", "check_hit", "exponential_damping", "exponential_window",
           "find_hits", "force_window", "impact_frf", "roving_hammer_frf"]

Estimator = Literal["H1", "H2", "Hv"]


def find_hits(force: FloatArray, fs_hz: float, *, trigger: float = 0.1,
              pretrigger_s: float = 0.005, block_s: float, min_gap_s: float | None = None
              ) -> list[int]:
    """Start samples of the hits in a force record (rise above ``trigger`` x its peak).

    A hit starts ``pretrigger_s`` before the force first exceeds the trigger level; the next
    hit is looked for ``min_gap_s`` later (default: a quarter of a second, or the block if
    shorter), so a bounce of the hammer stays inside the block of its first pulse, where
    :func:`check_hit` finds it; hits closer than a block are both returned, and the first
    one's block then holds the second pulse (a double hit). Hits whose block would run past
    the end of the record are not returned.
    """
    f = np.asarray(force, float).ravel()
    if f.size == 0 or not np.all(np.isfinite(f)):
        msg = "force: expected finite samples"
        raise SignalError(msg)
    level = trigger * float(np.max(np.abs(f)))
    if level <= 0:
        return []
    block, pre = round(block_s * fs_hz), round(pretrigger_s * fs_hz)
    gap = round((min(block_s, 0.25) if min_gap_s is None else min_gap_s) * fs_hz)
    above = np.flatnonzero(np.abs(f) > level)
    starts: list[int] = []
    nxt = 0
    for i in above:
        if i < nxt:
            continue
        s = max(0, int(i) - pre)
        if s + block <= f.size:
            starts.append(s)
        nxt = int(i) + gap
    return starts


@dataclass(frozen=True, slots=True)
class HitCheck:
    """The verdict on one hit: accepted, or the reason it is not."""

    start: int
    accepted: bool
    reason: str = ""
    peak_n: float = 0.0
    pulse_s: float = 0.0  # contact duration seen (force above 5 % of the peak)


def check_hit(force: FloatArray, responses: FloatArray, fs_hz: float, *, start: int = 0,
              double_hit: float = 0.1, force_range: float | None = None,
              response_range: Sequence[float] | None = None) -> HitCheck:
    """Check one hit's block for a double hit and an overload.

    Parameters
    ----------
    force : (n,) array
        The force of the block (it starts before the pulse).
    responses : (n_out, n) array
    double_hit : float
        A second rise of the force above this share of the first peak, after the first
        pulse has ended, is a double hit.
    force_range, response_range : float, optional
        Ranges of the force and response channels: a sample at 99.5 % of its range or more
        is an overload. Without a range, a flat top (three or more samples equal to the
        peak) of the force counts as a clipped, overloaded pulse.
    """
    f = np.asarray(force, float)
    y = np.atleast_2d(np.asarray(responses, float))
    peak = float(np.max(np.abs(f)))
    i_pk = int(np.argmax(np.abs(f)))
    small = np.abs(f) < 0.05 * peak
    after = np.flatnonzero(small[i_pk:])
    end = i_pk + (int(after[0]) if after.size else f.size - i_pk)
    before = np.flatnonzero(small[:i_pk])
    begin = int(before[-1]) + 1 if before.size else 0
    pulse_s = (end - begin) / fs_hz
    if peak <= 0:
        return HitCheck(start, False, "no force in the block")
    second = np.abs(f[end:])
    if second.size and float(second.max()) > double_hit * peak:
        at = (end + int(np.argmax(second))) / fs_hz
        return HitCheck(start, False, f"double hit: a second pulse of "
                        f"{100 * float(second.max()) / peak:.0f} % of the peak "
                        f"{at:.4f} s into the block", peak, pulse_s)
    if force_range is not None and peak >= 0.995 * force_range:
        return HitCheck(start, False, f"overload: force {peak:.4g} N at the range "
                        f"{force_range:.4g} N", peak, pulse_s)
    if force_range is None and int(np.sum(np.abs(f) >= peak * (1 - 1e-9))) >= 3:
        return HitCheck(start, False, "overload: the force pulse is clipped (flat top)",
                        peak, pulse_s)
    if response_range is not None:
        rng = np.asarray(response_range, float)
        over = np.max(np.abs(y), axis=1) >= 0.995 * rng
        if np.any(over):
            return HitCheck(start, False, f"overload: response channel(s) "
                            f"{np.flatnonzero(over).tolist()} at their range", peak, pulse_s)
    return HitCheck(start, True, "", peak, pulse_s)


def force_window(n: int, fs_hz: float, *, pulse_end_s: float, taper_s: float) -> FloatArray:
    """1 up to the end of the pulse, a half-cosine taper over ``taper_s``, then 0."""
    t = np.arange(n) / fs_hz
    w = np.zeros(n)
    w[t <= pulse_end_s] = 1.0
    ramp = (t > pulse_end_s) & (t < pulse_end_s + taper_s)
    w[ramp] = 0.5 * (1 + np.cos(np.pi * (t[ramp] - pulse_end_s) / taper_s))
    return w


def exponential_window(n: int, fs_hz: float, *, tau_s: float, t0_s: float = 0.0
                       ) -> FloatArray:
    r""":math:`w(t) = e^{-(t - t_0)/\tau}` (1 before ``t0_s``, the start of the pulse)."""
    if not tau_s > 0:
        msg = f"tau_s: expected > 0, got {tau_s}"
        raise OptionError(msg)
    t = np.arange(n) / fs_hz - t0_s
    return np.exp(-np.clip(t, 0.0, None) / tau_s)


def exponential_damping(zeta_identified: FloatArray, f_hz: FloatArray, tau_s: float
                        ) -> FloatArray:
    r"""Remove the damping an exponential window of ``tau_s`` adds: ``zeta - 1/(tau w)``.

    The window multiplies a decaying mode :math:`e^{s_r t}` by :math:`e^{-t/\tau}`: the
    pole moves to :math:`s_r - 1/\tau`, its real part by :math:`1/\tau`; with
    :math:`\Re(s_r) = -\zeta_r \omega_r` (light damping) the ratio grows by
    :math:`1/(\tau \omega_r)`.
    """
    return np.asarray(zeta_identified, float) - 1.0 / (tau_s * 2 * np.pi
                                                       * np.asarray(f_hz, float))


@dataclass(frozen=True, slots=True)
class ImpactFRF:
    """FRFs of one driving point from averaged hits.

    Attributes
    ----------
    f_hz : (n_f,) array
    H : (n_out, n_f) complex array
        The chosen estimator, response unit per N.
    H1, H2, Hv : (n_out, n_f) complex arrays
    coherence : (n_out, n_f) array in [0, 1]
    hits : tuple of HitCheck
        Every hit with its verdict; ``n_averages`` of them were accepted.
    tau_s : float or None
        Time constant of the exponential window on the responses (None: not used).
    """

    f_hz: FloatArray
    H: ComplexArray
    H1: ComplexArray
    H2: ComplexArray
    Hv: ComplexArray
    coherence: FloatArray
    estimator: str
    n_averages: int
    tau_s: float | None
    hits: tuple[HitCheck, ...] = field(default=())

    def rejected(self) -> list[str]:
        """One line per rejected hit: where and why."""
        return [f"hit at sample {h.start}: {h.reason}" for h in self.hits if not h.accepted]


def impact_frf(force: FloatArray, responses: FloatArray, fs_hz: float, *, block_s: float,
               estimator: Estimator = "H1", tau_s: float | None = None,
               taper_s: float | None = None, trigger: float = 0.1,
               pretrigger_s: float = 0.005, double_hit: float = 0.1,
               force_range: float | None = None,
               response_range: Sequence[float] | None = None) -> ImpactFRF:
    """FRFs of a roving-accelerometer or fixed-point hammer record: hits found, checked, averaged.

    Parameters
    ----------
    force : (n,) array
        Hammer force over the whole record (N).
    responses : (n_out, n) array
        Responses over the same samples.
    block_s : float
        Length of one hit's block (sets the frequency resolution ``1 / block_s``).
    estimator : {"H1", "H2", "Hv"}
        The one returned as ``H`` (all three are returned).
    tau_s : float, optional
        Exponential window on the responses (and the force) from the start of the pulse;
        identified damping must then be corrected (:func:`exponential_damping`).
    taper_s : float, optional
        Taper of the force window after the pulse (default: the pulse's own duration).

    Raises
    ------
    SignalError
        No hit accepted (each rejection is named).
    """
    if estimator not in ("H1", "H2", "Hv"):
        msg = f"estimator: expected one of H1, H2, Hv, got {estimator!r}"
        raise OptionError(msg)
    f = np.asarray(force, float).ravel()
    y = np.atleast_2d(np.asarray(responses, float))
    if y.shape[-1] != f.size:
        msg = f"responses: expected {f.size} samples like the force, got {y.shape[-1]}"
        raise ShapeError(msg)
    n = round(block_s * fs_hz)
    checks: list[HitCheck] = []
    X, Y = [], []
    for s in find_hits(f, fs_hz, trigger=trigger, pretrigger_s=pretrigger_s, block_s=block_s):
        fb, yb = f[s:s + n], y[:, s:s + n]
        chk = check_hit(fb, yb, fs_hz, start=s, double_hit=double_hit,
                        force_range=force_range, response_range=response_range)
        checks.append(chk)
        if not chk.accepted:
            continue
        t_pk = int(np.argmax(np.abs(fb)))
        t0 = max(0.0, t_pk / fs_hz - chk.pulse_s / 2)
        wf = force_window(n, fs_hz, pulse_end_s=t0 + chk.pulse_s,
                          taper_s=taper_s if taper_s is not None else chk.pulse_s)
        we = (exponential_window(n, fs_hz, tau_s=tau_s, t0_s=t0) if tau_s is not None
              else np.ones(n))
        X.append(np.fft.rfft(fb * wf * we))
        Y.append(np.fft.rfft(yb * we, axis=-1))
    if not X:
        why = "; ".join(c.reason for c in checks) or "no force above the trigger"
        msg = f"impact: no hit accepted ({why})"
        raise SignalError(msg)
    Xa, Ya = np.array(X), np.array(Y)  # (hits, f), (hits, out, f)
    sxx = np.mean(np.abs(Xa) ** 2, axis=0)
    syx = np.mean(Ya * Xa.conj()[:, None, :], axis=0)
    syy = np.mean(np.abs(Ya) ** 2, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        h1 = syx / sxx
        h2 = syy / syx.conj()
        hv = (syy - sxx + np.sqrt((sxx - syy) ** 2 + 4 * np.abs(syx) ** 2)) / (2 * syx.conj())
        coh = np.clip(np.abs(syx) ** 2 / (sxx * syy), 0.0, 1.0)
    pick = {"H1": h1, "H2": h2, "Hv": hv}[estimator]
    fr = np.asarray(np.fft.rfftfreq(n, 1.0 / fs_hz), dtype=np.float64)
    return ImpactFRF(fr, pick, h1, h2, hv, np.nan_to_num(coh), estimator, len(X), tau_s,
                     tuple(checks))


def roving_hammer_frf(forces: FloatArray, responses: FloatArray, fs_hz: float, *,
                      block_s: float, estimator: Estimator = "H1",
                      tau_s: float | None = None, **checks: float | None
                      ) -> tuple[ComplexArray, FloatArray, FloatArray, tuple[ImpactFRF, ...]]:
    """FRF matrix of a roving-hammer test: one force channel per hit point, hit in turn.

    Parameters
    ----------
    forces : (n_in, nt) array
        The force measured at each hit point (zero while the hammer is elsewhere).
    responses : (n_out, nt) array
        The fixed accelerometers.
    checks
        ``double_hit``, ``force_range``, ``trigger`` ... as :func:`impact_frf`.

    Returns
    -------
    H : (n_out, n_in, n_f) complex array
        Column ``i``: the FRFs of the hits at point ``i`` (the chosen estimator).
    f_hz : (n_f,) array
    coherence : (n_out, n_in, n_f) array
    per_point : tuple of ImpactFRF
        Each point's estimate with its hits and their verdicts.
    """
    fa = np.atleast_2d(np.asarray(forces, float))
    per_point = tuple(impact_frf(fa[i], responses, fs_hz, block_s=block_s,
                                 estimator=estimator, tau_s=tau_s, **checks)  # type: ignore[arg-type]
                      for i in range(fa.shape[0]))
    H = np.stack([p.H for p in per_point], axis=1)
    coh = np.stack([p.coherence for p in per_point], axis=1)
    return H, per_point[0].f_hz, coh, per_point
