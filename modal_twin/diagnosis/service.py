"""What the diagnosis node does, without ROS: keep a window of frames, diagnose, add effects.

The node (:mod:`modal_twin.diagnosis.node`) only converts messages to blocks and results to
messages; every decision lives here and is tested without a ROS graph.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

from modal_twin.acquisition.continuity import BlockVerdict, StreamMonitor
from modal_twin.block_window import BlockWindow
from modal_twin.channels import ChannelSpec
from modal_twin.diagnosis.fitting import warm_up_kernels
from modal_twin.diagnosis.live import live_diagnosis
from modal_twin.diagnosis.pipeline import Diagnosis
from modal_twin.diagnosis.record import Record, record_from_blocks
from modal_twin.diagnosis.workflow import add_diagnosed, add_effect, choose_start, diagnose_model
from modal_twin.errors import ModalTwinError
from modal_twin.models.loading import load_model
from modal_twin.models.versions import ModelVersion
from modal_twin.signal_block import SignalBlock
from modal_twin.validation import check_field

__all__ = ["DiagnosisService"]


class DiagnosisService:
    """A diagnosis over the last ``buffer_s`` of frames.

    Parameters
    ----------
    model_file : path
        Nominal model (structure or version file), resolved.
    versions_dir : path
        Where added effects write model versions.
    buffer_s : float
        Frames (and twin residuals) kept, s.
    train_fraction : float
        Share of the window that trains; the rest is held out.
    n_fit : int
        Candidates fitted by simulation per round.
    """

    def __init__(self, model_file: str | Path, versions_dir: str | Path, *, buffer_s: float,
                 train_fraction: float, n_fit: int) -> None:
        self.model_file = Path(model_file)
        self.versions_dir = Path(versions_dir)
        self.train_fraction = float(train_fraction)
        self.n_fit = int(n_fit)
        self.frames = BlockWindow(buffer_s, "measurement frames")
        self.residuals = BlockWindow(buffer_s, "twin residuals")
        self.monitor = StreamMonitor()
        self.last: Diagnosis | None = None
        self.nominal = load_model(self.model_file).plant()
        self.channels: Mapping[str, ChannelSpec] = {c.name: c for c in self.nominal.channels}

    def warm_up(self) -> float:
        """Compile the kernels a diagnosis of the model runs (:func:`.fitting.warm_up_kernels`).

        The node calls it before it says ready, so that its first ``~/run`` does not wait
        for a compiler; returns the seconds it took.
        """
        return warm_up_kernels(self.nominal)

    def add_frame(self, block: SignalBlock) -> BlockVerdict:
        """Keep a measured block (a gap or a restart starts a new record); return the check."""
        v = self.monitor.check(block)
        if v.block is not None:
            self.frames.add(v.block)
        return v

    def add_residual(self, block: SignalBlock) -> None:
        """Keep a block of the twin's residual (for the live where-it-fails)."""
        self.residuals.add(block)

    def records(self, window_s: float) -> tuple[Record, Record]:
        """(training, held-out) records of the last ``window_s`` (0: the whole window)."""
        last_s = check_field(window_s, "window_s", "window_s")
        rec = record_from_blocks([self.frames.joined(last_s)], source="/measurement/frames")
        cut = round(self.train_fraction * rec.n_samples)
        return rec.segment(0, cut), rec.segment(cut, rec.n_samples, warmup=True)

    def diagnose(self, window_s: float,
                 progress: Callable[[str], None] | None = None) -> Diagnosis:
        """Diagnose the model on the last ``window_s`` of frames (remembered for adding).

        ``progress`` is told each step (the node shows it on its status).
        """
        train, test = self.records(window_s)
        self.last = diagnose_model(self.model_file, train, test, n_fit=self.n_fit,
                                   progress=progress)
        return self.last

    def live(self) -> Diagnosis:
        """Where the model fails now, from the frames and the twin's residuals."""
        return live_diagnosis(list(self.frames.blocks), list(self.residuals.blocks),
                              self.channels)

    def add(self, effect: str = "", component: str = "") -> ModelVersion:
        """Write model version n+1 with an effect.

        The named one (started as the CLI starts it), or every effect the diagnosis found
        (accepted, unflagged) when ``effect`` or ``component`` is empty.

        Raises
        ------
        ModalTwinError
            Nothing to add (the diagnosis's summary says why), or a fit that is refused.
        """
        train, test = self.records(0.0)
        if effect and component:
            start = choose_start(load_model(self.model_file), component, effect, train)
            mv, _ = add_effect(self.model_file, component, effect, start, train, test,
                               self.versions_dir)
            return mv
        d = self.last or self.diagnose(0.0)
        written = add_diagnosed(self.model_file, d, test, self.versions_dir)
        if written is None:
            msg = f"nothing to add: {d.summary}"
            raise ModalTwinError(msg)
        return written

