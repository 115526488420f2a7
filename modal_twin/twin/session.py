"""What the twin node does, without ROS: run the model on frames, switch model versions.

The node (:mod:`modal_twin.twin.node`) only converts messages; a restart of the measured
stream, a new model version and the per-channel error table are handled here.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

from modal_twin.acquisition.continuity import BlockVerdict, StreamMonitor, Verdict
from modal_twin.channels import ChannelSpec
from modal_twin.models.loading import load_model
from modal_twin.models.plant import Plant
from modal_twin.models.versions import read_version
from modal_twin.paths import request_roots, resolve_config
from modal_twin.signal_block import SignalBlock
from modal_twin.twin.runner import TwinRunner, TwinStep
from modal_twin.validation import check_request_path

__all__ = ["TwinSession"]


class TwinSession:
    """The twin beside a measured stream.

    Parameters
    ----------
    model_file : str
        Structure or model version file (as configured; resolved here).
    fs_hz : float
        Frame rate the twin runs at, Hz.
    window_s : float
        Metrics window, s.
    versions_dir : path
        Folder of the model versions a parameter message may name (besides ``runs/``, the
        model's folder and the model folders of the configuration,
        :func:`modal_twin.paths.request_roots`); a version names its structure, which must
        lie inside them too.

    The stream's channel map (roles) comes with :meth:`set_channels`; until then the
    ``table_<input>`` naming rule routes the frames.
    """

    def __init__(self, model_file: str, fs_hz: float, window_s: float,
                 versions_dir: str | Path) -> None:
        self.model_file = model_file
        self.channels: tuple[ChannelSpec, ...] | None = None
        self.fs_hz, self.window_s = float(fs_hz), float(window_s)
        self.plant = load_model(resolve_config(model_file)).plant()
        self.version = self.plant.name
        self.roots: Sequence[Path] = request_roots(
            versions_dir, resolve_config(model_file).resolve().parent)
        self.runner = self._runner(self.plant)
        self.monitor = StreamMonitor()

    def _runner(self, plant: Plant) -> TwinRunner:
        return TwinRunner(plant, self.fs_hz, window_s=self.window_s, channels=self.channels)

    def set_channels(self, channels: Sequence[ChannelSpec]) -> bool:
        """Take the stream's channel map (roles); return True when it changed the routing.

        A new map restarts the twin from rest (a map arrives with a new stream).
        """
        new = tuple(channels)
        if new == self.channels:
            return False
        self.channels = new
        self.runner = self._runner(self.plant)
        return True

    def frame(self, block: SignalBlock) -> tuple[BlockVerdict, TwinStep | None]:
        """Check a measured block and run the twin on it (None when the block is dropped).

        A restart of the stream (a new run) starts the structure from rest.
        """
        v = self.monitor.check(block)
        if v.block is None:
            return v, None
        if v.verdict is Verdict.RESTART:
            self.runner = self._runner(self.plant)
        return v, self.runner.step(v.block)

    def coverage(self) -> str:
        """One line: the samples the metrics span, and every block dropped or cut on the way.

        A block the stream monitor dropped (a repeat, a layout change, non-finite samples)
        or a gap is counted here and never shifts the span silently.
        """
        span = self.runner.window_range()
        m = self.runner.metrics()
        if span is None or m is None:
            return "no samples compared yet"
        c = self.monitor.counts
        dropped = {v.value: c[v] for v in (Verdict.REPEAT, Verdict.LAYOUT, Verdict.NONFINITE,
                                           Verdict.EMPTY) if c[v]}
        return (f"samples {span[0]}..{span[1]}: {m.samples} compared, "
                f"{span[1] - span[0] + 1 - m.samples} missing; blocks dropped "
                f"{sum(dropped.values())}" + (f" ({dropped})" if dropped else "")
                + f", gaps {c[Verdict.GAP]}, trimmed {c[Verdict.OVERLAP]}, "
                f"restarts {c[Verdict.RESTART]}")

    def load_version(self, model_file: str, theta: Mapping[str, float], label: str) -> str:
        """Run another model version from now on; return its label.

        Raises
        ------
        ModalTwinError
            A path outside the allowed folders, or a model that does not load (the running
            one stays).
        """
        path = self.model_file
        if model_file:
            path = str(check_request_path(model_file, "ModelParameters.model_file",
                                          self.roots))
            check_request_path(str(read_version(path).structure),  # the file it names too
                               "ModelParameters.model_file: structure", self.roots)
        plant = load_model(resolve_config(path), theta=dict(theta)).plant()
        self.plant, self.version = plant, label or plant.name
        self.runner = self._runner(plant)
        return self.version
