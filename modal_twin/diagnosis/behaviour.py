r"""The family a fitted law belongs to, from what it does on the record, not from its name.

A law's name says little about what its fit does: a Bouc-Wen law whose fit has
``alpha = 0.999`` is a spring and a dashpot; a stick-slip slider whose elastic range is a
fifth of the drift yields like a steel damper; a cubic spring fitted to microslip is elastic
although the truth dissipates. So the family reported is read off the force the fitted law
produces along the record's own drift history, relative to the nominal linear law
(:math:`r = f - k u - c \dot u`, the residual restoring force of Eq. (20) of [003]):

1. **Linear** when a least-squares fit :math:`r \approx a u + b \dot u` explains 90 % of
   it and leaves less than 0.1 % of the law's own force (squared): *damping* when the
   velocity term carries more force (:math:`|b|\,\mathrm{RMS}(\dot u) >
   |a|\,\mathrm{RMS}(u)`), *stiffness* otherwise. (A law that replaces most of the nominal
   spring by a yielding element has a large linear :math:`r`, yet a loop of its own: a
   yield drift of a fifth of the drift leaves about 1 % of the law's force unexplained by
   any spring-dashpot, a Bouc-Wen that never yields 0.01 %.)
2. Otherwise the **cycles** of the drift (between turning points; reversals under 2 % of
   its range are ignored) give per cycle its amplitude :math:`A`, the energy the law
   dissipates, :math:`E = \oint \ell\,du`, and the half range :math:`F` of the loop
   :math:`\ell = r_s - a_s u`: :math:`r_s` is :math:`r`, or the law's force at zero
   velocity less the nominal spring (its rate-independent part: a yielding damper fitted
   with less dashpot than the nominal one still encloses its loop), whichever encloses
   more; :math:`a_s u` its stiffness change (least squares). The loss share
   :math:`\lambda = \sum E / \sum 4 A F` is 1 for a rigid-plastic loop (a rectangle),
   :math:`\pi/4` for an ellipse and 0 for an elastic law.
3. **Dissipative** (:math:`\lambda > 0.15`): *friction* when the force turns over within
   5 % of the amplitude after a reversal (a slider that sticks stiffly, then slips; the
   median over half cycles of the drift at which :math:`r_s` has covered half its change,
   over the amplitude), *hysteresis* when it turns over gradually (yielding, microslip).
4. **Elastic**: the secant stiffness of :math:`r` per cycle against amplitude: growing is
   *hardening* (a *gap* when the smallest cycles see less than a tenth of the largest
   ones' secant: nothing acts within a clearance, and a knee is seen: the best smooth
   power-law spring :math:`a u + b \dot u + c\,\mathrm{sgn}(u)|u|^q` leaves at least
   0.1 % of :math:`r` squared unexplained, the *knee share*), falling is *softening*.
   A power law's secant grows as :math:`A^{q-1}`, so over a record whose cycles span a
   decade of amplitude a cubic spring's smallest cycles see 1 % of the largest ones'
   secant: the secant ratio alone takes any stiff hardening for a gap. A clearance is a
   knee in the backbone (the force is nil inside it, then rises), which no power law has;
   a clearance at the foot of the drift that the record does not resolve (the force a
   power law gives within it is below what the law's fit can tell) leaves no knee, and
   the law behaves as a smooth hardening spring.

These are the families of the evidence (:mod:`.evidence`), so a fit and the evidence at its
place speak one vocabulary; the law's own name is reported beside the family.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.diagnosis.evidence import turning_points as evidence_turning_points

__all__ = ["BEHAVES_AS", "KIND_OF_FAMILY", "Behaviour", "behaviour_label", "classify_behaviour",
           "knee_share", "reported_family", "turning_points"]

LINEAR_R2 = 0.90
LINEAR_OWN = 0.001
DISSIPATIVE = 0.15
STICK_RATIO = 0.05
GAP_RATIO = 0.10
KNEE_SHARE = 0.001  # share of r^2 no power-law spring explains: a knee (a clearance)
POWERS = np.arange(1.25, 12.01, 0.25)  # exponents q of the power-law springs tried


@dataclass(frozen=True, slots=True)
class Behaviour:
    """What a law does along a drift history, and the family it reads as.

    Attributes
    ----------
    family : str
        ``nothing``, ``stiffness``, ``damping``, ``friction``, ``hysteresis``,
        ``hardening``, ``softening`` or ``gap``.
    linear_r2 : float
        Share of the residual force a linear ``a u + b v`` explains.
    loss_share : float
        Dissipated energy over that of a rectangle of the same amplitudes (module docstring).
    turnover : float
        Median drift (over the amplitude) at which the force has turned half-way after a
        reversal; ``nan`` when not computed.
    stiffness_slope : float
        Slope of the residual secant stiffness against log amplitude, over its mean.
    knee_share : float
        Of a hardening law: the share of its residual force (squared) that no smooth
        power-law spring explains (:func:`knee_share`); ``nan`` when not computed.
    """

    family: str
    linear_r2: float = float("nan")
    loss_share: float = float("nan")
    turnover: float = float("nan")
    stiffness_slope: float = float("nan")
    knee_share: float = float("nan")

    @property
    def smooth(self) -> bool:
        """Whether a smooth power-law spring reproduces the law (no knee, no clearance)."""
        return bool(self.knee_share < KNEE_SHARE)

    def text(self) -> str:
        """One line: the family and the figures that named it."""
        return f"{self.family} ({self.figures()})"

    def figures(self) -> str:
        """Return the figures that named the family, comma-separated."""
        parts = [f"R2 linear {self.linear_r2:.2f}"]
        if np.isfinite(self.loss_share):
            parts.append(f"loss share {self.loss_share:.2f}")
        if np.isfinite(self.turnover):
            parts.append(f"turn-over {100 * self.turnover:.1f} % of the amplitude")
        if np.isfinite(self.stiffness_slope):
            parts.append(f"secant slope {self.stiffness_slope:+.2f}")
        if np.isfinite(self.knee_share):
            parts.append(f"knee share {100 * self.knee_share:.3f} %")
        return ", ".join(parts)


KIND_OF_FAMILY: dict[str, str] = {
    "stiffness": "linear", "damping": "linear", "friction": "dissipative",
    "hysteresis": "dissipative", "hardening": "elastic", "softening": "elastic",
    "gap": "elastic",
}
"""Family -> its kind of behaviour: linear, dissipative (a loop) or elastic (no loop)."""

KIND_WORDS: dict[str, str] = {
    "linear": "a linear spring-dashpot", "dissipative": "a loop that dissipates energy",
    "elastic": "a nonlinear spring",
}

BEHAVES_AS: dict[str, str] = {
    "stiffness": "a spring", "damping": "a dashpot",
    "friction": "a slider that sticks, then slips", "hysteresis": "a yielding loop",
    "hardening": "a hardening spring", "softening": "a softening spring",
    "gap": "a stop beyond a clearance", "nothing": "the nominal law",
}
"""Family -> what a law of that behaviour acts as, in words."""


def reported_family(behaviour: Behaviour | None, own: str) -> str:
    """Return the family reported for a law of family ``own`` that behaves as ``behaviour``.

    The behaviour decides the kind (linear, dissipative, elastic: :data:`KIND_OF_FAMILY`)
    where it disagrees with the law's own family; within one kind the law's parameters
    name the family (the sign of a cubic term, a post-yield ratio, a slider's elastic range
    against the drift, the evidence at its place), except for a linear law, whose force says
    whether it is the spring or the dashpot that changed, and for a law of a clearance
    (``own`` gap) whose force a smooth power-law spring reproduces (no knee: the record
    does not resolve its clearance): it is reported as the hardening spring it acts as.
    """
    if behaviour is None or behaviour.family not in KIND_OF_FAMILY:
        return own
    if own == "gap" and behaviour.family == "hardening" and behaviour.smooth:
        return "hardening"
    kind = KIND_OF_FAMILY[behaviour.family]
    if KIND_OF_FAMILY.get(own) == kind and kind != "linear":
        return own
    return behaviour.family


def behaviour_label(law: str, params: Mapping[str, float], behaviour: Behaviour | None,
                    own: str) -> str:
    """Return the words beside a family: the law fitted, what it does, any disagreement.

    E.g. ``fitted law bouc_wen, alpha 0.999, ...: behaves as a dashpot (R2 linear 0.99);
    its law's own family is hysteresis, the behaviour wins``. ``own`` is the family the
    law's name (and parameters) would give; "" without a behaviour.
    """
    if behaviour is None:
        return ""
    values = ", ".join(f"{k} {v:.3g}" for k, v in params.items())
    text = f"fitted law {law}" + (f", {values}" if values else "")
    family = reported_family(behaviour, own)
    if behaviour.family == "nothing":
        return (f"{text}: does what the nominal law does ({behaviour.figures()}); "
                "reported as its law's own family")
    if family != behaviour.family:  # same kind: the law's parameters name the family
        return (f"{text}: behaves as {KIND_WORDS[KIND_OF_FAMILY[family]]} "
                f"({behaviour.figures()}); {family} by the law's parameters")
    text += f": behaves as {BEHAVES_AS[family]} ({behaviour.figures()})"
    if own and own != family:
        text += f"; its law's own family is {own}, the behaviour wins"
    return text


def turning_points(u: FloatArray, *, min_move: float = 0.02) -> np.ndarray:
    """Return the drift's reversals (moves under ``min_move`` of its range ignored).

    The reversals of :func:`.evidence.turning_points` without its leading first sample.
    """
    x = np.asarray(u, float)
    thr = min_move * float(np.ptp(x)) if x.size else 0.0
    if x.size < 3 or thr <= 0:
        return np.zeros(0, dtype=int)
    return evidence_turning_points(x, thr)[1:]


def _cycles(u: FloatArray, r: FloatArray, tp: np.ndarray
            ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Per full cycle (turning point j to j + 2): amplitude, energy, half range, secant."""
    amp, energy, half, secant = [], [], [], []
    for a, b in zip(tp[:-2], tp[2:], strict=True):
        uu, rr = u[a:b + 1], r[a:b + 1]
        lo, hi = int(np.argmin(uu)), int(np.argmax(uu))
        span = float(uu[hi] - uu[lo])
        if span <= 0:
            continue
        amp.append(span / 2)
        energy.append(float(np.sum(0.5 * (rr[1:] + rr[:-1]) * np.diff(uu))))
        half.append(float(np.ptp(rr)) / 2)
        secant.append(float(rr[hi] - rr[lo]) / span)
    return np.asarray(amp), np.asarray(energy), np.asarray(half), np.asarray(secant)


def _turnover(u: FloatArray, r: FloatArray, tp: np.ndarray) -> float:
    """Median drift after a reversal at which ``r`` has turned half-way, over the amplitude."""
    ratios = []
    for a, b in itertools.pairwise(tp):
        uu, rr = u[a:b + 1], r[a:b + 1]
        du = abs(float(uu[-1] - uu[0]))
        dr = float(rr[-1] - rr[0])
        if du <= 0 or dr == 0:
            continue
        covered = (rr - rr[0]) / dr
        k = int(np.argmax(covered >= 0.5))
        ratios.append(abs(float(uu[k] - uu[0])) / (du / 2))
    return float(np.median(ratios)) if ratios else float("nan")


def _loss_share(u: FloatArray, rs: FloatArray, tp: np.ndarray) -> float:
    """Loss share of the loop ``rs - a u`` (its stiffness change removed), module docstring."""
    loop = rs - float(np.dot(rs, u) / max(float(np.dot(u, u)), 1e-300)) * u
    amp, energy, half, _ = _cycles(u, loop, tp)
    return float(np.sum(energy) / max(float(np.sum(4 * amp * np.maximum(half, 1e-300))),
                                      1e-300))


def classify_behaviour(u: FloatArray, v: FloatArray, f: FloatArray, *, k: float, c: float,
                       f_static: FloatArray | None = None) -> Behaviour:
    """Family of a law's force ``f`` along drift ``u`` / velocity ``v`` (module docstring).

    Parameters
    ----------
    u, v, f : (nt,) arrays
        Drift, its velocity and the law's force along them (one direction).
    k, c : float
        The nominal linear law's stiffness and damping the behaviour is relative to.
    f_static : (nt,) array, optional
        The law's force along the same drift at zero velocity (its rate-independent part):
        the loop is then read without the law's own dashpot (a yielding damper fitted with
        less viscous damping than the nominal one still encloses its loop).
    """
    u = np.asarray(u, float).ravel()
    v = np.asarray(v, float).ravel()
    f = np.asarray(f, float).ravel()
    r = f - k * u - c * v
    if float(np.sqrt(np.mean(r**2))) <= 0.01 * float(np.sqrt(np.mean(f**2))):
        return Behaviour("nothing", 1.0)
    basis = np.column_stack([u, v])
    coef, *_ = np.linalg.lstsq(basis, r, rcond=None)
    sse = float(np.sum((r - basis @ coef) ** 2))
    r2 = 1.0 - sse / float(np.sum(r**2))
    if r2 >= LINEAR_R2 and sse <= LINEAR_OWN * float(np.sum(f**2)):
        velocity = abs(coef[1]) * float(np.std(v)) > abs(coef[0]) * float(np.std(u))
        return Behaviour("damping" if velocity else "stiffness", r2)
    tp = turning_points(u)
    amp, _, _, secant = _cycles(u, r, tp)
    if amp.size < 3:
        return Behaviour("nothing", r2)
    # the loop beside the change of stiffness, with the law's dashpot and without it
    tries = [r] if f_static is None else [r, np.asarray(f_static, float).ravel() - k * u]
    shares = [_loss_share(u, x, tp) for x in tries]
    loss, rs = max(shares), tries[int(np.argmax(shares))]
    if loss > DISSIPATIVE:
        turn = _turnover(u, rs, tp)
        fam = "friction" if turn < STICK_RATIO else "hysteresis"
        return Behaviour(fam, r2, loss, turn)
    order = np.argsort(amp)
    slope = float(np.polyfit(np.log(amp), secant, 1)[0]) / max(float(np.mean(np.abs(secant))),
                                                              1e-300)
    if slope > 0:
        q = max(1, amp.size // 4)
        small = float(np.median(secant[order[:q]]))
        large = float(np.median(secant[order[-q:]]))
        knee = knee_share(u, v, r)
        gap = large > 0 and abs(small) < GAP_RATIO * large and knee >= KNEE_SHARE
        return Behaviour("gap" if gap else "hardening", r2, loss, float("nan"), slope, knee)
    return Behaviour("softening", r2, loss, float("nan"), slope)


def knee_share(u: FloatArray, v: FloatArray, r: FloatArray) -> float:
    r"""Share of ``r`` (squared) that no smooth power-law spring along ``u`` explains.

    The least-squares fit :math:`r \approx a u + b \dot u + c\,\mathrm{sgn}(u)|u|^q`
    (a stiffness and a damping change beside one power, Eq. (20) of [003]'s residual
    restoring force) at the best exponent ``q`` of :data:`POWERS`; its residual sum of
    squares over that of ``r``. A cubic or any power-law spring leaves ~0; a clearance
    (nothing inside it, a stop beyond) leaves its knee.
    """
    u = np.asarray(u, float).ravel()
    v = np.asarray(v, float).ravel()
    r = np.asarray(r, float).ravel()
    total = float(np.dot(r, r))
    scale = float(np.max(np.abs(u))) if u.size else 0.0
    if total <= 0 or scale <= 0:
        return float("nan")
    x = np.abs(u) / scale
    best = total
    for q in POWERS:
        basis = np.column_stack([u, v, np.sign(u) * x**q])
        coef, *_ = np.linalg.lstsq(basis, r, rcond=None)
        best = min(best, float(np.sum((r - basis @ coef) ** 2)))
    return best / total
