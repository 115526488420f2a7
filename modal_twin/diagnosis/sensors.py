"""Sensor candidates: a channel whose error is its own reading scaled, turned or shifted.

A gain error ``g`` on a channel makes its residual ``y - y_hat = (g - 1) y_hat`` (plus
noise); a reversed polarity is ``g = -1`` (reported as ``sensor_polarity`` when the fitted
gain is within :data:`POLARITY_TOL` of -1); an orientation error ``a`` about z mixes in the
horizontal partner, ``y_x = cos(a) y_hat_x + sin(a) y_hat_y``; crossed cables of a
horizontal pair read ``y_x = y_hat_y`` and ``y_y = y_hat_x`` (``sensor_swap``, judged on
both channels); a time delay ``tau`` (a sensor or converter whose clock lags) reads
``y(t) = y_hat(t - tau)``; a zero that is off, or creeps (a charge amplifier's output
drifts with its input's leakage current after each reset; a displacement transducer
mounted off its zero), reads ``y = y_hat + b + r t`` with ``t`` from the record's first
sample (``sensor_offset``: ``r = 0``; ``sensor_drift``). The records are compared as
measured -- nothing detrends or high-passes them before the comparison (the NRMSE of
:mod:`.noise` keeps the mean) -- so a zero error is visible; a chain that AC-couples its
accelerometers removes it before it gets here, and then nothing is found, rightly.

Gain, orientation, swap, offset and drift are fitted in closed form (least squares on the
training record), the delay from the peak of the cross-correlation of measured and
predicted (parabolic interpolation between samples). They are kept as candidates only for
channels whose error is significant while the other channels at the same place are not --
a structural effect shows at every channel of a place, a sensor fault at one -- or at
several channels of one place when that place holds more than half of the significant
channels' residual (the residual concentrates on one sensor: a turned, late or crossed
sensor spoils several of its axes). An offset or a drift is tried only on a channel alone
at its place (a zero error is one channel's; a structure that yields leaves a permanent
set at every channel of a device).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import numpy as np
from scipy import signal

from modal_twin._types import FloatArray
from modal_twin.channels import device_channels
from modal_twin.diagnosis.effect_kind import Job, PlacedEffect, Round
from modal_twin.diagnosis.fitting import (
    FittedEffect,
    channel_scale,
    record_nmse,
    simulate_record,
)
from modal_twin.diagnosis.record import Record
from modal_twin.errors import OptionError
from modal_twin.models.effects import SENSOR_LAWS, EffectSpec
from modal_twin.models.loading import ModelFactory
from modal_twin.models.plant import DelayLine

__all__ = ["SENSOR", "SensorCandidate", "SensorKind", "delay_of", "fit_sensor", "screen_sensors"]

# law -> its one parameter (the others have none, or several: SensorCandidate.params)
_VALUE = {"sensor_gain": "gain", "sensor_angle": "angle_deg", "sensor_delay": "delay_s",
          "sensor_offset": "offset"}
POLARITY_TOL = 0.05  # a fitted gain within this of -1 is a reversed polarity
MARGIN = 0.1  # share of the residual a candidate with more freedom must remove beyond


@dataclass(frozen=True, slots=True)
class SensorCandidate:
    """A channel whose residual a sensor error explains (module docstring)."""

    channel: str
    law: str  # one of SENSOR_LAWS
    value: float  # gain, angle in degrees, delay in s, offset, drift rate per s; -1: polarity
    gain: float  # share of the channel's residual energy removed (training record)
    std: float = float("nan")  # 1-sigma of value (white residual assumed)
    params: dict[str, float] = field(default_factory=dict)  # every parameter (drift)
    stds: dict[str, float] = field(default_factory=dict)  # their 1-sigma

    def effect_params(self) -> dict[str, float]:
        """Return the parameters of the effect (none for a polarity or a swap)."""
        if self.params:
            return dict(self.params)
        key = _VALUE.get(self.law)
        return {key: self.value} if key else {}

    def text(self) -> str:
        """Return the parameters as ``name=value``, or what a swap exchanges."""
        if self.law == "sensor_swap":
            return f"reads {partner_of(self.channel)} and that channel reads it"
        return ", ".join(f"{k}={v:.4g}" for k, v in self.effect_params().items()) or (
            f"gain {self.value:.4g}")


def partner_of(channel: str) -> str:
    """Return the other horizontal axis of ``channel``'s sensor (``_x`` <-> ``_y``)."""
    stem, _, axis = channel.rpartition("_")
    return f"{stem}_{'y' if axis == 'x' else 'x'}"


def scaled(channel: str, y: FloatArray, p: FloatArray, e0: float) -> SensorCandidate:
    """Return a gain in closed form, ``g = y.p / p.p``; a reversed polarity when ``g`` is -1."""
    pp = float(p @ p)
    g = float(y @ p) / pp
    if g < 0 and abs(g + 1.0) <= POLARITY_TOL:
        return SensorCandidate(channel, "sensor_polarity", -1.0,
                               1.0 - float(np.sum((y + p) ** 2)) / e0)
    e1 = float(np.sum((y - g * p) ** 2))
    return SensorCandidate(channel, "sensor_gain", g, 1.0 - e1 / e0,
                           float(np.sqrt(e1 / max(y.size - 1, 1) / pp)))


def shifted_zero(channel: str, residual: FloatArray, fs_hz: float, t0_s: float = 0.0
                 ) -> tuple[SensorCandidate, SensorCandidate]:
    """Return an offset ``b`` and an offset with a drift ``b + r t`` fitted to a residual.

    ``t`` counts from the record's first sample (``t0_s`` is the time of ``residual[0]``:
    a record's unscored lead). Both are candidates: which one holds is decided on the
    other records (a drift found on a short record may be an offset of another).
    """
    r = np.asarray(residual, float)
    e0 = max(float(r @ r), 1e-300)
    n = r.size
    t = t0_s + np.arange(n) / fs_hz
    b0 = float(np.mean(r))
    e_off = float(np.sum((r - b0) ** 2))
    A = np.column_stack([np.ones(n), t])
    coef, *_ = np.linalg.lstsq(A, r, rcond=None)
    e_dr = float(np.sum((r - A @ coef) ** 2))
    sd = np.sqrt(np.diag(e_dr / max(n - 2, 1) * np.linalg.inv(A.T @ A)))
    return (SensorCandidate(channel, "sensor_offset", b0, 1.0 - e_off / e0,
                            float(np.sqrt(e_off / max(n - 1, 1) / n))),
            SensorCandidate(channel, "sensor_drift", float(coef[1]), 1.0 - e_dr / e0,
                            float(sd[1]), {"offset": float(coef[0]), "rate": float(coef[1])},
                            {"offset": float(sd[0]), "rate": float(sd[1])}))


def late(channel: str, y: FloatArray, p: FloatArray, fs_hz: float, e0: float
         ) -> SensorCandidate | None:
    """Return the time delay of :func:`delay_of` as a candidate (None: no lag)."""
    tau = delay_of(y, p, fs_hz)
    if tau <= 0:
        return None
    shifted = DelayLine([(0, tau)], fs_hz).apply(p[None, :])[0]
    return SensorCandidate(channel, "sensor_delay", tau,
                           1.0 - float(np.sum((y - shifted) ** 2)) / e0)


def turned(channel: str, y: FloatArray, p: FloatArray, p_partner: FloatArray, e0: float
           ) -> SensorCandidate | None:
    """Return the orientation about z fitted in closed form (None: not a rotation).

    ``y_x = cos(a) p_x + sin(a) p_y`` (``y_y = cos(a) p_y - sin(a) p_x``), least squares
    in ``(cos a, sin a)``; a rotation only when their norm is 1 within 5 %.
    """
    axis = channel.rpartition("_")[2]
    A = np.column_stack([p, p_partner * (1.0 if axis == "x" else -1.0)])
    (c, s), *_ = np.linalg.lstsq(A, y, rcond=None)
    if abs(np.hypot(c, s) - 1.0) >= 0.05:
        return None
    sh = 1.0 - float(np.sum((y - A @ np.array([c, s])) ** 2)) / e0
    return SensorCandidate(channel, "sensor_angle", float(np.degrees(np.arctan2(s, c))), sh)


def swapped(channel: str, y: FloatArray, p: FloatArray, yq: FloatArray, pq: FloatArray
            ) -> SensorCandidate:
    """Return crossed cables of a horizontal pair as a candidate.

    Its share: that of the pair's residual energy reading ``pq`` for ``y`` and ``p`` for
    ``yq`` removes.
    """
    e0 = float(np.sum((y - p) ** 2) + np.sum((yq - pq) ** 2))
    e1 = float(np.sum((y - pq) ** 2) + np.sum((yq - p) ** 2))
    return SensorCandidate(channel, "sensor_swap", 0.0, 1.0 - e1 / max(e0, 1e-300))


def delay_of(measured: FloatArray, predicted: FloatArray, fs_hz: float, *,
             max_s: float = 0.1) -> float:
    """Delay of ``measured`` behind ``predicted`` in seconds (cross-correlation peak).

    Only lags in ``[0, max_s]`` are searched (a sensor reports late, not early); the peak is
    refined by a parabola through it and its two neighbours.
    """
    y = np.asarray(measured, float) - np.mean(measured)
    p = np.asarray(predicted, float) - np.mean(predicted)
    xc = signal.correlate(y, p, mode="full", method="fft")
    lag = signal.correlation_lags(y.size, p.size, mode="full")
    zero = int(np.flatnonzero(lag == 0)[0])
    lags = int(min(max(2, round(max_s * fs_hz)), y.size - 2))
    k = int(np.argmax(xc[zero:zero + lags + 1]))
    lo, mid, hi = xc[zero + k - 1], xc[zero + k], xc[zero + k + 1]
    den = lo - 2 * mid + hi
    frac = float(np.clip(0.5 * (lo - hi) / den, -0.5, 0.5)) if den < 0 else 0.0
    return max(0.0, (k + frac) / fs_hz)


def _concentrated(names: Sequence[str], measured: FloatArray, predicted: FloatArray,
                  significant: Sequence[str], share: float = 0.5) -> set[str]:
    """Places (sensors) holding more than ``share`` of the significant channels' residual.

    The residual of each channel is taken relative to its own RMS (NRMSE squared); a
    structural effect spreads it over many places, a faulty sensor concentrates it on the
    channels of one.
    """
    idx = {n: i for i, n in enumerate(names)}
    energy: dict[str, float] = {}
    for ch in significant:
        y, p = measured[idx[ch]], predicted[idx[ch]]
        e = float(np.sum((y - p) ** 2)) / max(float(np.sum(y**2)), 1e-300)
        place = ch.rpartition("_")[0]
        energy[place] = energy.get(place, 0.0) + e
    total = sum(energy.values())
    return {pl for pl, e in energy.items() if total > 0 and e > share * total}


def screen_sensors(names: Sequence[str], measured: FloatArray, predicted: FloatArray,
                   significant: Sequence[str], *, min_share: float = 0.6,
                   fs_hz: float | None = None, t0_s: float = 0.0) -> list[SensorCandidate]:
    """Sensor candidates among ``significant`` channels (module docstring), best first.

    With ``fs_hz`` a time delay is also tried on each channel, and an offset or a drift
    on a channel alone at its place (``t0_s``: the time of the first sample given, from
    the record's start).
    """
    idx = {n: i for i, n in enumerate(names)}
    sig = set(significant)
    one_sensor = _concentrated(names, measured, predicted, significant)
    out: list[SensorCandidate] = []
    for ch in significant:
        place = ch.rpartition("_")[0]
        mates = [n for n in names if n != ch and n.rpartition("_")[0] == place]
        alone = not any(m in sig for m in mates)
        if not alone and place not in one_sensor:
            continue  # the place is off with others: structural, not one sensor
        i = idx[ch]
        y, p = measured[i], predicted[i]
        e0 = float(np.sum((y - p) ** 2))
        if e0 <= 0 or float(p @ p) <= 0:
            continue
        best = scaled(ch, y, p, e0)
        axis = ch.rpartition("_")[2]
        partner = partner_of(ch)
        if axis in ("x", "y") and partner in idx:
            turn = turned(ch, y, p, predicted[idx[partner]], e0)
            if turn is not None and turn.gain > best.gain + MARGIN:
                best = turn
        slow = late(ch, y, p, fs_hz, e0) if fs_hz is not None else None
        if slow is not None and slow.gain > best.gain + MARGIN:
            best = slow
        if best.gain >= min_share:
            out.append(best)
        if fs_hz is not None and alone:  # beside the best of the others, not instead
            out += [z for z in shifted_zero(ch, y - p, fs_hz, t0_s)
                    if z.gain >= min_share and z.gain > best.gain + MARGIN]
        if axis == "x" and partner in sig:  # once per pair, both channels off
            j = idx[partner]
            cross = swapped(ch, y, p, measured[j], predicted[j])
            if cross.gain >= min_share:
                out.append(cross)
    return sorted(out, key=lambda c: -c.gain)


def fit_sensor(factory: ModelFactory, cand: SensorCandidate, train: Record, test: Record
               ) -> FittedEffect:
    """Return the sensor effect of ``cand`` as a fitted candidate (errors on both records)."""
    t0 = time.perf_counter()
    key = _VALUE.get(cand.law)
    effect = EffectSpec(cand.channel, cand.law, cand.effect_params())
    std = cand.stds or ({key: cand.std} if key else {})
    n_par = max(len(effect.params), 1)  # a polarity or a swap: one discrete choice
    plant, nominal = factory.plant([effect]), factory.plant()
    pred_train = simulate_record(plant, train)
    scale = channel_scale(train)
    fun = ((pred_train[:, train.skip:] - train.scored) / scale)[:, ::5].ravel()
    n = fun.size
    sse = float(fun @ fun)
    return FittedEffect(
        effect, n_par, float(np.mean(record_nmse(pred_train, train))),
        float(np.mean(record_nmse(simulate_record(plant, test), test))),
        float(np.mean(record_nmse(simulate_record(nominal, test), test))),
        float(n * np.log(max(sse, 1e-300) / n) + n_par * np.log(n)), 3,
        time.perf_counter() - t0, f"closed form: {cand.text()}", std)


class SensorKind(PlacedEffect):
    """Effect kind ``sensor``: a channel reads its quantity scaled, turned, late or shifted.

    Or reversed, or crossed with its horizontal partner's (module docstring).
    """

    name = "sensor"
    families: tuple[str, ...] = ("sensor",)

    def owns(self, law: str) -> bool:
        """One of :data:`~modal_twin.models.effects.SENSOR_LAWS`."""
        return law in SENSOR_LAWS

    def laws(self) -> tuple[str, ...]:
        """:data:`~modal_twin.models.effects.SENSOR_LAWS`."""
        return SENSOR_LAWS

    def screen(self, rnd: Round) -> tuple[SensorCandidate, ...]:
        """:func:`screen_sensors` among the significant channels of the training record.

        Not the drift and force channels of a device whose law an earlier round fitted
        (:func:`_fitted_through`): that law was fitted through them, and a gain there
        trades off with its stiffness (it stood in for what a law of another form left).
        """
        train = rnd.train
        held = _fitted_through(rnd)
        return tuple(screen_sensors(train.channel_names, train.scored,
                                    simulate_record(rnd.nominal, train)[:, train.skip:],
                                    [c for c in rnd.significant if c not in held],
                                    fs_hz=train.fs_hz, t0_s=train.skip / train.fs_hz))

    def jobs(self, rnd: Round, candidates: tuple[Any, ...]) -> list[Job]:
        """Return the best ``n_fit`` (closed form, on the training record)."""
        return [(f"{sc.law} at {sc.channel}", partial(fit_sensor, rnd.factory, sc, rnd.train,
                                                      rnd.test))
                for sc in candidates[:rnd.n_fit]]

    def report(self, candidates: tuple[Any, ...]) -> list[str]:
        """One line for each of the best four."""
        return [f"  {sc.channel:<12} {sc.law:<15} removes {100 * sc.gain:6.2f} % of its "
                f"residual ({sc.text()})" for sc in candidates[:4]]

    def start(self, factory: ModelFactory, component: str, law: str, train: Record
              ) -> dict[str, float]:
        """Refuse: a sensor effect is found by the diagnosis in closed form."""
        raise OptionError(self._refusal(law, component))

    def fit(self, factory: ModelFactory, component: str, law: str, start: dict[str, float],
            train: Record, test: Record) -> FittedEffect:
        """Refuse: a sensor effect is found by the diagnosis in closed form."""
        raise OptionError(self._refusal(law, component))

    @staticmethod
    def _refusal(law: str, component: str) -> str:
        return (f"{law} at {component}: a sensor effect is found by the diagnosis, not "
                "fitted from a start (modal-twin diagnose, or effects add --auto)")


def _fitted_through(rnd: Round) -> set[str]:
    """Return the drift and force channels of the sites whose device law the model holds."""
    chans = rnd.nominal.channels
    sites = {e.component for e in rnd.factory.base_effects if e.component in rnd.factory.sites}
    return {c for site in sites for role in ("device_drift", "device_force")
            for c in device_channels(chans, site, role)}


SENSOR = SensorKind()
