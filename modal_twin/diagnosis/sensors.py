"""Sensor candidates: a channel whose error is its own reading scaled, turned or late.

A gain error ``g`` on a channel makes its residual ``y - y_hat = (g - 1) y_hat`` (plus
noise; a polarity error is ``g = -1``); an orientation error ``a`` about z mixes in the
horizontal partner, ``y_x = cos(a) y_hat_x + sin(a) y_hat_y``; a time delay ``tau`` (a
sensor or converter whose clock lags) reads ``y(t) = y_hat(t - tau)``. Gain and orientation
are fitted in closed form (least squares on the training record), the delay from the peak
of the cross-correlation of measured and predicted (parabolic interpolation between
samples). They are kept as candidates only for channels whose error is significant while
the other channels at the same place are not -- a structural effect shows at every channel
of a place, a sensor fault at one -- or at several channels of one place when that place
holds more than half of the significant channels' residual (the residual concentrates on
one sensor: a turned or late sensor spoils all of its axes).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
from scipy import signal

from modal_twin._types import FloatArray
from modal_twin.diagnosis.effect_kind import Job, PlacedEffect, Round
from modal_twin.diagnosis.fitting import FittedEffect, record_nmse, simulate_record
from modal_twin.diagnosis.record import Record
from modal_twin.errors import OptionError
from modal_twin.models.effects import SENSOR_LAWS, EffectSpec
from modal_twin.models.loading import ModelFactory
from modal_twin.models.plant import DelayLine

__all__ = ["SENSOR", "SensorCandidate", "SensorKind", "delay_of", "fit_sensor", "screen_sensors"]

# law -> its one parameter
_VALUE = {"sensor_gain": "gain", "sensor_angle": "angle_deg", "sensor_delay": "delay_s"}


@dataclass(frozen=True, slots=True)
class SensorCandidate:
    """A channel whose residual a gain or an orientation explains."""

    channel: str
    law: str  # sensor_gain | sensor_angle | sensor_delay
    value: float  # gain, angle in degrees, or delay in seconds
    gain: float  # share of the channel's residual energy removed (training record)
    std: float = float("nan")  # 1-sigma of value (white residual assumed)


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
                   fs_hz: float | None = None) -> list[SensorCandidate]:
    """Sensor candidates among ``significant`` channels (module docstring), best first.

    With ``fs_hz`` a time delay is also tried on each channel.
    """
    idx = {n: i for i, n in enumerate(names)}
    sig = set(significant)
    one_sensor = _concentrated(names, measured, predicted, significant)
    out: list[SensorCandidate] = []
    for ch in significant:
        place = ch.rpartition("_")[0]
        mates = [n for n in names if n != ch and n.rpartition("_")[0] == place]
        if any(m in sig for m in mates) and place not in one_sensor:
            continue  # the place is off with others: structural, not one sensor
        i = idx[ch]
        y, p = measured[i], predicted[i]
        e0 = float(np.sum((y - p) ** 2))
        pp = float(p @ p)
        if e0 <= 0 or pp <= 0:
            continue
        g = float(y @ p) / pp
        e1 = float(np.sum((y - g * p) ** 2))
        share = 1.0 - e1 / e0
        best = SensorCandidate(ch, "sensor_gain", g, share,
                               float(np.sqrt(e1 / max(y.size - 1, 1) / pp)))
        stem, _, axis = ch.rpartition("_")
        partner = f"{stem}_{'y' if axis == 'x' else 'x'}"
        if axis in ("x", "y") and partner in idx:
            q = predicted[idx[partner]] * (1.0 if axis == "x" else -1.0)
            A = np.column_stack([p, q])
            (c, s), *_ = np.linalg.lstsq(A, y, rcond=None)
            ang = float(np.degrees(np.arctan2(s, c)))
            sh = 1.0 - float(np.sum((y - A @ np.array([c, s])) ** 2)) / e0
            if sh > share + 0.1 and abs(np.hypot(c, s) - 1.0) < 0.05:
                best = SensorCandidate(ch, "sensor_angle", ang, sh)
        if fs_hz is not None:
            tau = delay_of(y, p, fs_hz)
            if tau > 0:
                late = DelayLine([(0, tau)], fs_hz).apply(p[None, :])[0]
                sh = 1.0 - float(np.sum((y - late) ** 2)) / e0
                if sh > best.gain + 0.1:
                    best = SensorCandidate(ch, "sensor_delay", tau, sh)
        if best.gain >= min_share:
            out.append(best)
    return sorted(out, key=lambda c: -c.gain)


def fit_sensor(factory: ModelFactory, cand: SensorCandidate, train: Record, test: Record
               ) -> FittedEffect:
    """Return the sensor effect of ``cand`` as a fitted candidate (errors on both records)."""
    t0 = time.perf_counter()
    key = _VALUE[cand.law]
    effect = EffectSpec(cand.channel, cand.law, {key: cand.value})
    plant, nominal = factory.plant([effect]), factory.plant()
    pred_train = simulate_record(plant, train)
    scale = np.maximum(np.std(train.scored, axis=1), 1e-300)[:, None]
    fun = ((pred_train[:, train.skip:] - train.scored) / scale)[:, ::5].ravel()
    n = fun.size
    sse = float(fun @ fun)
    return FittedEffect(
        effect, 1, float(np.mean(record_nmse(pred_train, train))),
        float(np.mean(record_nmse(simulate_record(plant, test), test))),
        float(np.mean(record_nmse(simulate_record(nominal, test), test))),
        float(n * np.log(max(sse, 1e-300) / n) + np.log(n)), 3, time.perf_counter() - t0,
        "closed form", {key: cand.std})


class SensorKind(PlacedEffect):
    """Effect kind ``sensor``: one channel reads its quantity scaled or turned."""

    name = "sensor"
    families: tuple[str, ...] = ("sensor",)

    def owns(self, law: str) -> bool:
        """One of :data:`~modal_twin.models.effects.SENSOR_LAWS`."""
        return law in SENSOR_LAWS

    def laws(self) -> tuple[str, ...]:
        """:data:`~modal_twin.models.effects.SENSOR_LAWS`."""
        return SENSOR_LAWS

    def screen(self, rnd: Round) -> tuple[SensorCandidate, ...]:
        """:func:`screen_sensors` among the significant channels of the training record."""
        train = rnd.train
        return tuple(screen_sensors(train.channel_names, train.scored,
                                    simulate_record(rnd.nominal, train)[:, train.skip:],
                                    rnd.significant, fs_hz=train.fs_hz))

    def jobs(self, rnd: Round, candidates: tuple[Any, ...]) -> list[Job]:
        """Return the best ``n_fit`` (closed form, on the training record)."""
        return [(f"{sc.law} at {sc.channel}", partial(fit_sensor, rnd.factory, sc, rnd.train,
                                                      rnd.test))
                for sc in candidates[:rnd.n_fit]]

    def report(self, candidates: tuple[Any, ...]) -> list[str]:
        """One line for each of the best four."""
        return [f"  {sc.channel:<12} {sc.law:<14} removes {100 * sc.gain:6.2f} % of its "
                f"residual ({sc.value:.4g})" for sc in candidates[:4]]

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


SENSOR = SensorKind()
