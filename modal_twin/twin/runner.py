"""The live twin: run the nominal plant on the measured inputs, beside the measurements."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from modal_twin.channels import ChannelSpec
from modal_twin.errors import SignalError
from modal_twin.models.plant import Plant
from modal_twin.models.sensors import ChannelRoute, route_channels
from modal_twin.signal_block import SignalBlock
from modal_twin.twin.metrics import ChannelMetrics, SlidingMetrics, StreamMetrics
from modal_twin.twin.simulator import Simulator

__all__ = ["TwinRunner", "TwinStep"]


@dataclass(frozen=True, slots=True)
class TwinStep:
    """One frame through the twin: prediction and residual (prediction - measurement)."""

    prediction: SignalBlock
    residual: SignalBlock
    first: bool = False  # the first frame of a stream (the routing was set up on it)


class TwinRunner:
    """Feed measured frames to the nominal plant; keep per-channel Eq. (8) metrics.

    Which frame channels drive which model input and which are compared with which model
    channel comes from the channels' roles (:func:`~modal_twin.models.sensors.route_channels`):
    with a channel map (an imported record's, or the ``/measurement/channels`` of the
    acquisition) by the roles, else ``table_<input>`` drives ``<input>``. Any subset of the
    model's inputs may be measured; the others are zero (:attr:`zero_inputs`). The metrics
    are over a sliding window, or (``window_s`` 0) over every sample since the stream's
    first; :attr:`first_index` / :attr:`next_index` say which samples were compared.
    Prediction and residual carry the model's channel names.

    Parameters
    ----------
    plant : Plant
        The nominal model.
    fs_hz : float
        Frame sample rate.
    window_s : float
        Metrics window, s; 0 = the whole stream (a replayed record: first to last sample).
    channels : sequence of ChannelSpec, optional
        The channel map of the measured stream.
    """

    def __init__(self, plant: Plant, fs_hz: float, *, window_s: float = 10.0,
                 channels: Sequence[ChannelSpec] | None = None) -> None:
        self.plant = plant
        self.fs_hz = fs_hz
        self.channels = None if channels is None else tuple(channels)
        self.sim = Simulator(plant.system, 1.0 / fs_hz, modal_histories=False)
        self.line = plant.delay_line(fs_hz)
        self.compare: list[str] | None = None
        self.route = ChannelRoute((), ())
        self.zero_inputs: tuple[str, ...] = ()
        self.metrics_window: SlidingMetrics | StreamMetrics = StreamMetrics(0)
        self.window_s = window_s
        self.first_index: int | None = None  # first sample compared
        self.next_index: int | None = None  # one past the last sample compared

    def _setup(self, frame: SignalBlock) -> None:
        p = self.plant
        route = route_channels(frame.channel_names, self.channels, p.input_names, p.channels,
                               source=f"frames of {frame.source or 'the stream'}")
        if not route.inputs:
            msg = (f"frame has no channel that drives the model's inputs {list(p.input_names)} "
                   f"(table_<input> or role input in the channel map); it has "
                   f"{list(frame.channel_names)[:8]}")
            raise SignalError(msg)
        model = {c: i for i, c in enumerate(p.channel_names)}
        outs = [(n, m) for n, m in route.outputs if m in model]
        if not outs:
            msg = (f"frame shares no channel with the model {p.name!r}; model "
                   f"channels start {list(p.channel_names[:5])}")
            raise SignalError(msg)
        self.route = ChannelRoute(route.inputs, tuple(outs))
        driven = {m for _, m in route.inputs}
        self.zero_inputs = tuple(n for n in p.input_names if n not in driven)
        self._in_frame = [n for n, _ in route.inputs]
        self._in_model = [m for _, m in route.inputs]
        self._out_frame = [n for n, _ in outs]
        self.compare = [m for _, m in outs]
        self._rows = [model[m] for m in self.compare]
        n = len(self.compare)
        self.metrics_window = (StreamMetrics(n) if self.window_s <= 0 else
                               SlidingMetrics(n, max(1, round(self.window_s * self.fs_hz))))

    def step(self, frame: SignalBlock) -> TwinStep:
        """Simulate the frame's inputs and compare with its response channels."""
        if frame.fs_hz != self.fs_hz:
            msg = f"frame rate {frame.fs_hz} Hz differs from the twin's {self.fs_hz} Hz"
            raise SignalError(msg)
        first = self.compare is None
        if first:
            self._setup(frame)
        assert self.compare is not None
        ag = self.plant.input_matrix(self._in_model, frame.select(self._in_frame).data)
        res = self.sim.step_block(ag)
        pred = self.plant.measure(res, self.line)[self._rows]
        meas = frame.select(self._out_frame).data
        self.metrics_window.push(pred, meas)
        if self.first_index is None:
            self.first_index = frame.first_index
        self.next_index = frame.next_index
        names = tuple(self.compare)
        return TwinStep(
            SignalBlock(names, frame.fs_hz, frame.first_index, pred, frame.stamp_ns, "twin"),
            SignalBlock(names, frame.fs_hz, frame.first_index, pred - meas, frame.stamp_ns,
                        "twin"),
            first,
        )

    def describe_route(self) -> str:
        """One line: which channels drive which inputs, how many are compared, which are zero."""
        if self.compare is None:
            return "no frames yet"
        ins = ", ".join(f"{n} -> {m}" for n, m in self.route.inputs)
        zero = f"; not measured, held at zero: {', '.join(self.zero_inputs)}"
        return (f"inputs {ins}; {len(self.compare)} channels compared"
                + (zero if self.zero_inputs else ""))

    def metrics(self) -> ChannelMetrics | None:
        """Eq. (8) metrics over the window (None before the first frame)."""
        return self.metrics_window.metrics()

    def window_range(self) -> tuple[int, int] | None:
        """Sample indices (first, last) the metrics span (None before the first frame).

        With a whole-stream window, from the stream's first sample compared; with a
        sliding one, the last ``samples`` before :attr:`next_index`. Samples missing in
        between (gaps) make the span longer than the metrics' ``samples``.
        """
        m = self.metrics()
        if m is None or self.first_index is None or self.next_index is None:
            return None
        if isinstance(self.metrics_window, StreamMetrics):
            return self.first_index, self.next_index - 1
        return self.next_index - m.samples, self.next_index - 1

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
