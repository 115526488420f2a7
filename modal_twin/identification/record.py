"""Modes of a record: the one call of the ``identify`` command, the node and a campaign.

:func:`identify_record` takes a :class:`~modal_twin.signal_block.SignalBlock` and its
channel map and does, in this order and for every caller alike:

1. **Channels by role** (:mod:`modal_twin.channels`): inputs are the channels of role
   ``input``, outputs those of role ``output`` (a map's role, else the one the name
   implies); ``inputs`` / ``outputs`` name channels instead, ``directions`` keeps the
   channels of those directions only. An input that never moves (an undriven table axis)
   is left out, and said.
2. **Method**: ``n4sid`` (input-output, Eqs. (1)-(4) of [004]), ``ssi-cov``
   (output-only) or ``polymax`` (pLSCF on H1 FRFs, Eqs. (1)-(4) of [002]); by default
   ``n4sid`` when the record has driven inputs, else ``ssi-cov``.
3. **Settings** (:func:`~modal_twin.identification.auto.choose_settings`): band,
   decimation, block rows and orders from the record, each one replaced by a given
   option.
4. **Selection** (:mod:`~modal_twin.identification.stabilization`): stability with the
   default thresholds of [004] (1 % frequency, 5 % damping, MAC 0.95); when they give no
   mode, once more with relaxed ones (2 %, 20 %, 0.9; short or weak records), and said.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.acquisition.decimation import decimate
from modal_twin.channels import ChannelSpec
from modal_twin.errors import OptionError, SignalError
from modal_twin.identification.auto import AutoSettings, choose_settings, rms_spread
from modal_twin.identification.modal_model import ModalModel, PoleSweep, StabilizationDiagram
from modal_twin.identification.n4sid import n4sid
from modal_twin.identification.polymax import polymax
from modal_twin.identification.ssi_cov import ssi_cov
from modal_twin.identification.stabilization import select_modes, stabilization_diagram
from modal_twin.signal_block import SignalBlock

__all__ = [
    "METHODS",
    "OUTPUT_ONLY",
    "RELAXED",
    "STRICT",
    "IdentifyOptions",
    "RecordModes",
    "identify_record",
    "polymax_orders",
    "record_channels",
]

METHODS = ("n4sid", "ssi-cov", "polymax")
"""The methods, as every caller spells them."""
OUTPUT_ONLY = ("ssi-cov",)
"""The methods that use no input."""
STRICT = {"rel_tol_f": 0.01, "rel_tol_zeta": 0.05, "mac_min": 0.95}
"""Stability thresholds of sec. 3 of [004]."""
RELAXED = {"rel_tol_f": 0.02, "rel_tol_zeta": 0.2, "mac_min": 0.9}
"""Thresholds of the second try when the default ones give no mode."""
NONSTATIONARY = 4.0
"""Largest / smallest window RMS above which output-only SSI is warned about."""


@dataclass(frozen=True, slots=True)
class IdentifyOptions:
    """What a caller may choose; ``None`` means "from the record" (module docstring).

    Attributes
    ----------
    method : str, optional
        One of :data:`METHODS`; default from the record.
    inputs, outputs : tuple of str, optional
        Channel names replacing the roles.
    directions : tuple of str, optional
        Keep only channels of these directions.
    f_max_hz, f_min_hz : float, optional
        Band edges.
    fs_target_hz : float, optional
        Decimate to about this rate (factor ``round(fs / fs_target)`` when
        ``fs > 1.5 fs_target``).
    block_rows : int, optional
    orders : tuple of int, optional
    thresholds : dict, optional
        ``rel_tol_f``, ``rel_tol_zeta``, ``mac_min`` of the first try (default
        :data:`STRICT`).
    relax : bool
        Try :data:`RELAXED` thresholds when the first ones give no mode.
    zeta_max : float
        Poles damped above this are not physical.
    n_blocks_std : int
        Blocks of the subspace methods' standard deviations (0: none).
    """

    method: str | None = None
    inputs: tuple[str, ...] | None = None
    outputs: tuple[str, ...] | None = None
    directions: tuple[str, ...] | None = None
    f_max_hz: float | None = None
    f_min_hz: float | None = None
    fs_target_hz: float | None = None
    block_rows: int | None = None
    orders: tuple[int, ...] | None = None
    thresholds: dict[str, float] = field(default_factory=lambda: dict(STRICT))
    relax: bool = True
    zeta_max: float = 0.2
    n_blocks_std: int = 4

    def __post_init__(self) -> None:
        if self.method is not None and self.method not in METHODS:
            msg = f"method: expected one of {list(METHODS)}, got {self.method!r}"
            raise OptionError(msg)
        if self.fs_target_hz is not None and not (math.isfinite(self.fs_target_hz)
                                                  and self.fs_target_hz > 0):
            msg = f"fs_target_hz: expected a positive rate, got {self.fs_target_hz!r}"
            raise OptionError(msg)
        if self.orders is not None and (len(self.orders) < 2 or min(self.orders) < 1):
            msg = f"orders: expected at least two orders >= 1, got {list(self.orders)}"
            raise OptionError(msg)
        unknown = sorted(set(self.thresholds) - set(STRICT))
        if unknown:
            msg = f"thresholds: unknown keys {unknown}; expected {sorted(STRICT)}"
            raise OptionError(msg)


@dataclass(frozen=True, slots=True)
class RecordModes:
    """What :func:`identify_record` found and how.

    Attributes
    ----------
    method : str
    inputs, outputs : tuple of ChannelSpec
        The channels used (the shapes' rows are ``outputs``).
    settings : AutoSettings
        Band, decimation, block rows and orders.
    sweep : PoleSweep
    diagram : StabilizationDiagram
    modes : ModalModel
    relaxed : bool
        The relaxed thresholds were needed.
    notes : tuple of str
        What was chosen for the caller, one line each (printed or logged).
    warnings : tuple of str
        What the caller should be warned about.
    """

    method: str
    inputs: tuple[ChannelSpec, ...]
    outputs: tuple[ChannelSpec, ...]
    settings: AutoSettings
    sweep: PoleSweep
    diagram: StabilizationDiagram
    modes: ModalModel
    relaxed: bool
    notes: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()

    @property
    def output_names(self) -> tuple[str, ...]:
        """Names of the shapes' rows."""
        return tuple(c.name for c in self.outputs)


def _pick(channels: Sequence[ChannelSpec], role: str, names: tuple[str, ...] | None,
          dirs: tuple[str, ...] | None) -> list[ChannelSpec]:
    if names is not None:
        by = {c.name: c for c in channels}
        missing = [n for n in names if n not in by]
        if missing:
            msg = f"{role}s: channels {missing} not in the record (it has {sorted(by)})"
            raise OptionError(msg)
        return [by[n] for n in names]
    out = [c for c in channels if c.effective_role == role]
    return [c for c in out if dirs is None or c.direction in dirs]


def record_channels(block: SignalBlock, channels: Sequence[ChannelSpec] | None
                    ) -> list[ChannelSpec]:
    """Return the record's channel map, or one from the names (roles by name) if none.

    Raises
    ------
    SignalError
        A map that does not list the block's channels.
    """
    if channels is None:
        return [ChannelSpec(n, "acceleration") for n in block.channel_names]
    by = {c.name: c for c in channels}
    missing = [n for n in block.channel_names if n not in by]
    if missing:
        msg = f"channel map: expected every channel of the record, missing {missing}"
        raise SignalError(msg)
    return [by[n] for n in block.channel_names]


def _corners(channels: Sequence[ChannelSpec]) -> tuple[float, float]:
    """Highest stated high-pass and lowest stated low-pass corner (NaN when none)."""
    lo, hi = [], []
    for c in channels:
        f = dict(c.meta).get("filter_hz")
        if f and len(f) == 2:
            lo.append(f[0] if f[0] is not None else math.nan)
            hi.append(f[1] if f[1] is not None else math.nan)
    lo_v = max((v for v in lo if math.isfinite(v)), default=math.nan)
    hi_v = min((v for v in hi if math.isfinite(v)), default=math.nan)
    return lo_v, hi_v


def _settings(y: FloatArray, fs: float, n_in: int, opts: IdentifyOptions,
              corners: tuple[float, float]) -> AutoSettings:
    factor = None
    if opts.fs_target_hz is not None:
        factor = round(fs / opts.fs_target_hz) if fs > 1.5 * opts.fs_target_hz else 1
    return choose_settings(y, fs, n_in, f_max_hz=opts.f_max_hz, f_min_hz=opts.f_min_hz,
                           factor=factor, block_rows=opts.block_rows, orders=opts.orders,
                           corners_hz=corners)


def polymax_orders(s: AutoSettings, n_in: int) -> int:
    """Highest PolyMAX polynomial order: as many poles as the subspace methods' top order."""
    return max(4, math.ceil(s.orders[-1] / max(n_in, 1)))


def _sweep(method: str, u: FloatArray, y: FloatArray, s: AutoSettings, nb: int) -> PoleSweep:
    from modal_twin.acquisition.frf import frf

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # fewer std blocks on short records
        try:
            if method == "n4sid":
                return n4sid(u, y, s.fs_hz, orders=s.orders, block_rows=s.block_rows,
                             n_blocks_std=nb)
            if method == "ssi-cov":
                return ssi_cov(y, s.fs_hz, orders=s.orders, block_rows=s.block_rows,
                               n_blocks_std=nb)
            est = frf(u, y, s.fs_hz, nperseg=min(y.shape[1], max(256, y.shape[1] // 8)))
            return polymax(est.H1, est.f_hz, orders=range(2, polymax_orders(s, u.shape[0]) + 1),
                           band_hz=s.band_hz)
        except np.linalg.LinAlgError as err:
            msg = (f"{method}: the data are rank-deficient at these settings ({err}); "
                   f"noise-free or duplicated channels? Try fewer channels or a lower f_max")
            raise SignalError(msg) from err


def _select(sweep: PoleSweep, opts: IdentifyOptions, band: tuple[float, float]
            ) -> tuple[StabilizationDiagram, ModalModel, bool]:
    tries = [opts.thresholds] + ([RELAXED] if opts.relax and opts.thresholds != RELAXED
                                 else [])
    for k, th in enumerate(tries):
        diag = stabilization_diagram(sweep, **th)
        mm = select_modes(diag, zeta_max=opts.zeta_max, f_range_hz=band)
        if mm.f_hz.size:
            return diag, mm, k > 0
    return diag, mm, len(tries) > 1


def identify_record(block: SignalBlock, channels: Sequence[ChannelSpec] | None = None,
                    options: IdentifyOptions | None = None) -> RecordModes:
    """Modes of a record (module docstring): channels, method, settings, selection.

    Parameters
    ----------
    block : SignalBlock
        The record (all its channels).
    channels : sequence of ChannelSpec, optional
        Its channel map (roles); default: roles from the names.
    options : IdentifyOptions, optional

    Returns
    -------
    RecordModes
        The modes may be empty (no stable cluster); the caller says so.

    Raises
    ------
    OptionError
        Unknown channel names, no outputs, a method that needs inputs on a record
        without, a band outside what the record allows.
    SignalError
        Rank-deficient or otherwise unusable data.
    """
    opts = options or IdentifyOptions()
    chans = record_channels(block, channels)
    outs = _pick(chans, "output", opts.outputs, opts.directions)
    if not outs:
        msg = (f"{block.source or 'record'}: no channel with role 'output' (channels "
               f"{list(block.channel_names)}); give the outputs or a channel map")
        raise OptionError(msg)
    notes: list[str] = []
    ins = _pick(chans, "input", opts.inputs, opts.directions)
    if ins:
        still = [c for c in ins if np.std(block.select((c.name,)).data) == 0]
        if still:
            notes.append(f"inputs {[c.name for c in still]} never move; left out")
            ins = [c for c in ins if c not in still]
    method = opts.method or ("n4sid" if ins else "ssi-cov")
    if opts.method is None:
        notes.append(f"method {method}: " + (f"{len(ins)} driven inputs" if ins else
                                              "no driven input, output-only"))
    if method in OUTPUT_ONLY:
        ins = []
    elif not ins:
        msg = (f"{block.source or 'record'}: method {method} needs input channels (role "
               f"'input'), the record has none driven; use ssi-cov (output-only) or name "
               f"the inputs")
        raise OptionError(msg)
    y = block.select(tuple(c.name for c in outs)).data
    u = block.select(tuple(c.name for c in ins)).data if ins else np.zeros((0, y.shape[1]))
    s = _settings(y, block.fs_hz, len(ins), opts, _corners(outs + ins))
    warn: list[str] = []
    if method == "ssi-cov" and (r := rms_spread(y)) > NONSTATIONARY:
        warn.append(f"output-only SSI on a non-stationary record: window RMS varies by "
                    f"x{r:.1f} (> x{NONSTATIONARY:g}); its modes assume stationary "
                    f"excitation -- use n4sid with the measured inputs if there are any")
    if s.factor > 1:
        yq = decimate(y, block.fs_hz, s.factor).x
        uq = decimate(u, block.fs_hz, s.factor).x if ins else u[:, :: s.factor]
    else:
        yq, uq = y, u
    sweep = _sweep(method, uq, yq, s, opts.n_blocks_std)
    diag, mm, relaxed = _select(sweep, opts, s.band_hz)
    if relaxed:
        notes.append(f"no mode with the stability thresholds {opts.thresholds}; relaxed "
                     f"to {RELAXED}")
    return RecordModes(method, tuple(ins), tuple(outs), s, sweep, diag, mm, relaxed,
                       tuple(notes), tuple(warn))
