"""The live twin: run the nominal plant on the measured inputs, beside the measurements."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modal_twin.errors import SignalError
from modal_twin.models.plant import Plant
from modal_twin.signal_block import SignalBlock
from modal_twin.twin.metrics import ChannelMetrics, SlidingMetrics
from modal_twin.twin.simulator import Simulator

__all__ = ["TwinRunner", "TwinStep"]


@dataclass(frozen=True, slots=True)
class TwinStep:
    """One frame through the twin: prediction and residual (prediction - measurement)."""

    prediction: SignalBlock
    residual: SignalBlock


class TwinRunner:
    """Feed measured frames to the nominal plant; keep per-channel Eq. (8) metrics.

    Frames hold the table inputs ``table_<input>`` and the response channels; the metrics
    are over a sliding window.

    Parameters
    ----------
    plant : Plant
        The nominal model.
    fs_hz : float
        Frame sample rate.
    window_s : float
        Metrics window.
    """

    def __init__(self, plant: Plant, fs_hz: float, *, window_s: float = 10.0) -> None:
        self.plant = plant
        self.fs_hz = fs_hz
        self.sim = Simulator(plant.system, 1.0 / fs_hz, modal_histories=False)
        self.inputs = [f"table_{n}" for n in plant.input_names]
        self.compare: list[str] | None = None
        self.metrics_window = SlidingMetrics(0, 1)
        self.window_s = window_s

    def _setup(self, frame: SignalBlock) -> None:
        missing = [c for c in self.inputs if c not in frame.channel_names]
        if missing:
            msg = (f"frame lacks the input channels {missing}; it has "
                   f"{list(frame.channel_names)}")
            raise SignalError(msg)
        self.compare = [c for c in self.plant.channel_names if c in frame.channel_names]
        if not self.compare:
            msg = (f"frame shares no channel with the model {self.plant.name!r}; model "
                   f"channels start {list(self.plant.channel_names[:5])}")
            raise SignalError(msg)
        self._rows = [self.plant.channel_names.index(c) for c in self.compare]
        self.metrics_window = SlidingMetrics(len(self.compare),
                                             max(1, round(self.window_s * self.fs_hz)))

    def step(self, frame: SignalBlock) -> TwinStep:
        """Simulate the frame's inputs and compare with its response channels."""
        if frame.fs_hz != self.fs_hz:
            msg = f"frame rate {frame.fs_hz} Hz differs from the twin's {self.fs_hz} Hz"
            raise SignalError(msg)
        if self.compare is None:
            self._setup(frame)
        assert self.compare is not None
        ag = frame.select(self.inputs).data
        res = self.sim.step_block(ag)
        pred = self.plant.measure(res)[self._rows]
        meas = frame.select(self.compare).data
        self.metrics_window.push(pred, meas)
        names = tuple(self.compare)
        return TwinStep(
            SignalBlock(names, frame.fs_hz, frame.first_index, pred, frame.stamp_ns, "twin"),
            SignalBlock(names, frame.fs_hz, frame.first_index, pred - meas, frame.stamp_ns,
                        "twin"),
        )

    def metrics(self) -> ChannelMetrics | None:
        """Eq. (8) metrics over the window (None before the first frame)."""
        return self.metrics_window.metrics()

    def error_table(self, top: int | None = None) -> str:
        """Per-channel table sorted by Eq. (8) error, largest first."""
        m = self.metrics()
        if m is None or self.compare is None:
            return "no frames yet"
        order = np.argsort(-np.nan_to_num(m.residual_pct, nan=-1.0))
        if top is not None:
            order = order[:top]
        w = max([14, *(len(self.compare[i]) + 1 for i in order)])
        lines = [f"{'channel':<{w}}{'RMS meas':>12}{'RMS model':>12}{'Eq.8 err %':>12}"
                 f"{'resid %':>10}"]
        for i in order:
            lines.append(f"{self.compare[i]:<{w}}{m.rms_measured[i]:12.4g}"
                         f"{m.rms_predicted[i]:12.4g}{m.rms_error_pct[i]:12.2f}"
                         f"{m.residual_pct[i]:10.2f}")
        return "\n".join(lines)
