"""Modes of a record: the one call of the ``identify`` command, the node and a campaign.

:func:`identify_record` takes a :class:`~modal_twin.signal_block.SignalBlock` and its
channel map and does, in this order and for every caller alike:

1. **Channels by role** (:mod:`modal_twin.channels`): inputs are the channels of role
   ``input``, outputs those of role ``output`` (a map's role, else the one the name
   implies); ``inputs`` / ``outputs`` name channels instead, ``directions`` keeps the
   channels of those directions only. An input that never moves (an undriven table axis)
   is left out, and said.
2. **Method**: ``n4sid`` (input-output, Eqs. (1)-(4) of [004]), ``ssi-cov``
   (output-only) or ``polymax`` (pLSCF, Eqs. (1)-(4) of [002]: on H1 FRFs when inputs are
   known and coherent, else on the outputs' positive half-spectra from their correlation
   functions; LSFD shapes, Eq. (5), for the selected modes). By default ``n4sid`` when
   the record has
   driven inputs whose mean multiple coherence with the outputs in the band (debiased for
   the number of averages: the share of the output power the inputs explain) is at least
   :data:`COHERENT` and, on a transient record, that the outputs do not feed back
   (:mod:`~modal_twin.identification.feedback`), else ``ssi-cov``; PolyMAX uses the
   map's inputs by the same rules and only where its H1 lines resolve a
   :data:`H1_ZETA`-damped mode at the band's centre (named inputs always); the choice and
   its reason are said. On the real records of ../shared/realdata this rule makes
   PolyMAX output-only (Hayward: coherence 0.64-0.66; Berkeley, Rio Dell: coherent but
   fed back 20 % / 17 %, and H1 lines of 0.31 / 0.2 Hz). ``n4sid`` asked for where the
   inputs explain less than :data:`COHERENT` runs covariance-driven (past outputs as
   references, :func:`_n4sid_form`), with SSI-cov's output scales and the spectral-peak
   test of output-only selection; where they fail the test it warns that its modes are
   the input-output system's (fixed at the measured points).
3. **Settings** (:func:`~modal_twin.identification.auto.choose_settings`): band,
   decimation, block rows and orders from the record, each one replaced by a given
   option; a given option the record cannot support is an error naming the limit. The
   H1 segments (PolyMAX) are the longest power of two with ``max(2 n_in + 2, 8)``
   averages (:func:`welch_segment`). Output-only PolyMAX: correlations over a quarter of
   the record (the exponential window to 1 % adds a decay of 4 ln(100) / T, taken back
   out of the poles), fitted two octaves at a time
   (:func:`~modal_twin.identification.polymax_oma.polymax_banded`). SSI-cov scales the
   output channels of one quantity jointly unless their RMS spread exceeds
   :data:`JOINT_SCALE`, then each to unit RMS (:func:`scale_groups`), and says which.
4. **Selection**: by default (``selection="clusters"``; PolyMAX on H1 keeps the rule of
   [004] unless asked) hierarchical clustering of the
   poles of every order (:mod:`~modal_twin.identification.clustering`, Magalhaes et al.
   2009 with a cut-off from the data): each cluster's median reported with its size,
   every cluster not reported with its reason (too few poles, damping out of range, MPC
   below :data:`MPC_MIN`, output-only no peak of its own in the output spectrum along its
   shape, :func:`~modal_twin.identification.clustering.spectral_peak`, a duplicate).
   ``selection="stability"`` is the earlier rule
   (:mod:`~modal_twin.identification.stabilization`): stability with the thresholds of
   [004] (1 % frequency, 5 % damping, MAC 0.95), relaxed (2 %, 20 %, 0.9) when they give
   no mode, and said; its dropped columns from
   :func:`~modal_twin.identification.stabilization.dropped_columns`. The stabilization
   diagram (flags of [004]) and the singular values of the output PSD matrix (CMIF) come
   with the modes either way. Output-only PolyMAX then keeps the selected modes that stand
   on a peak of the half-spectra they were fitted to
   (:func:`~modal_twin.identification.polymax_oma.spectral_support`: prominence above two
   standard errors of the lag-window PSD, within the pole's half-power width); the others
   are listed as not reported, with that reason.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.signal as sig

from modal_twin._types import ComplexArray, FloatArray
from modal_twin.acquisition.decimation import decimate
from modal_twin.channels import ChannelSpec
from modal_twin.errors import OptionError, SignalError
from modal_twin.identification.auto import AutoSettings, choose_settings, rms_spread
from modal_twin.identification.clustering import (
    ZETA_MIN,
    cluster_modes,
    is_harmonic,
    spectral_peak,
)
from modal_twin.identification.feedback import FEEDBACK, input_feedback
from modal_twin.identification.modal_model import ModalModel, PoleSweep, StabilizationDiagram
from modal_twin.identification.n4sid import n4sid
from modal_twin.identification.polymax import polymax
from modal_twin.identification.polymax_oma import half_spectra_support, polymax_banded
from modal_twin.identification.ssi_cov import correlations, ssi_cov
from modal_twin.identification.stabilization import (
    REL_SUPPORT,
    DroppedColumn,
    dropped_columns,
    select_modes,
    stabilization_diagram,
)
from modal_twin.method_names import METHODS, OUTPUT_ONLY, SELECTIONS
from modal_twin.signal_block import SignalBlock

__all__ = [
    "JOINT_SCALE",
    "METHODS",
    "MPC_MIN",
    "OUTPUT_ONLY",
    "RELAXED",
    "SELECTIONS",
    "STRICT",
    "IdentifyOptions",
    "RecordModes",
    "cmif",
    "debiased_coherence",
    "half_spectra",
    "identify_record",
    "polymax_orders",
    "record_channels",
    "scale_groups",
    "welch_segment",
]

MPC_MIN = 0.2
"""Smallest median MPC of a reported cluster: below it the shape's entries scatter almost
evenly round the complex plane, like noise. Low on purpose: a non-proportionally damped
mode is complex (the demo building's isolation modes at 0.68 Hz, about 8 % damped, have
MPC 0.28-0.45)."""
STRICT = {"rel_tol_f": 0.01, "rel_tol_zeta": 0.05, "mac_min": 0.95}
"""Stability thresholds of sec. 3 of [004]."""
RELAXED = {"rel_tol_f": 0.02, "rel_tol_zeta": 0.2, "mac_min": 0.9}
"""Thresholds of the second try when the default ones give no mode."""
H1_ZETA = 0.01
"""Damping of the mode whose half-power width (:math:`2 \\zeta f` at the band's centre)
the H1 lines of input-output PolyMAX must resolve; coarser lines (short records with many
inputs: Berkeley's 6 ground channels, 0.31 Hz lines; Rio Dell's 9, 0.2 Hz) bias the poles
by leakage, and PolyMAX runs output-only on the half-spectra instead."""
JOINT_SCALE = 10.0
"""Largest ratio of the strongest to the weakest RMS among the output channels of one
quantity for which output-only SSI scales them jointly (:func:`scale_groups`): a channel
more than 20 dB below the strongest adds under 1 % of the power to the jointly scaled
correlations, as good as unused, so beyond it each channel gets its own scale."""
NONSTATIONARY = 4.0
"""Largest / smallest window RMS above which output-only SSI is warned about."""
COHERENT = 0.8
"""Mean multiple coherence of the outputs with the inputs in the band (debiased for the
number of averages) from which the measured inputs explain most of the response and the
default method is input-output (N4SID). Below it unmeasured excitation carries a large
share of the response: on the Hayward bridge's earthquake records (debiased coherence
0.64-0.66: six ground channels at the supports, spatially varying input) N4SID's poles sit
0.4-2 % off and it reports 1-2 of the 8-10 modes FDD and SSI-cov agree on (PO-MOESP; the
covariance-driven form ``--method n4sid`` runs there since session 13: 3 and 3), SSI-cov
(output-only) most of them (``test/benchmarks/bench_real_modes.py``)."""


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
        Try :data:`RELAXED` thresholds when the first ones give no mode (``stability``).
    selection : str, optional
        One of :data:`SELECTIONS`; default ``clusters`` for the subspace methods and
        output-only PolyMAX, ``stability`` for PolyMAX on H1 (its few-channel H1 fits
        give spurious columns as steady as the modes; the clustering has no shape to tell
        them apart).
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
    selection: str | None = None
    zeta_max: float = 0.2
    n_blocks_std: int = 4

    def __post_init__(self) -> None:
        if self.method is not None and self.method not in METHODS:
            msg = f"method: expected one of {list(METHODS)}, got {self.method!r}"
            raise OptionError(msg)
        if self.selection is not None and self.selection not in SELECTIONS:
            msg = f"selection: expected one of {list(SELECTIONS)}, got {self.selection!r}"
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
    dropped : tuple of DroppedColumn
        Columns of stable poles not reported, each with its reason.
    spectrum : (f_hz, s) arrays, optional
        Singular values of the output PSD matrix (CMIF; ``s`` (n_out, n_f)), drawn behind
        the stabilization diagram.
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
    dropped: tuple[DroppedColumn, ...] = ()
    spectrum: tuple[FloatArray, FloatArray] | None = None

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


def welch_segment(n: int, n_in: int, min_averages: int = 8) -> int:
    """Return the Welch segment length of a record of ``n`` samples.

    The longest power of two that still gives ``max(2 n_in + 2, min_averages)``
    half-overlapping averages (H1 needs more averages than inputs, and its variance falls
    with their number).
    """
    need = max(2 * n_in + 2, min_averages)
    seg = 2 ** math.floor(math.log2(max(2 * n / (need + 1), 16)))
    return min(seg, n)


def half_spectra(y: FloatArray, fs_hz: float, n_lags: int, *, decay: float = 0.01
                 ) -> tuple[FloatArray, ComplexArray, float]:
    r"""Positive half-spectra of the outputs from their correlation functions.

    :math:`S^+_{or}(\omega) = \tfrac12 R_0 + \sum_{k=1}^{L-1} w_k R_k e^{-j\omega k
    \Delta t}` with :math:`R_k = E[y_{s+k} y_{r,s}^T]` (every output a reference) and the
    exponential window :math:`w_k = e^{-\beta k}`, :math:`w_{L-1}` = ``decay``. Like an FRF
    :math:`S^+` is a sum of first-order modal terms (Peeters et al. 2004, sec. 3 of
    [002] for PolyMAX), each pole shifted by :math:`-\beta f_s` in its real part by the
    window; the caller adds it back.

    Returns
    -------
    f_hz : (n_f,) array
    S : (n_out, n_out, n_f) complex array
    sigma_w : float
        The window's added decay rate :math:`\beta f_s` (1/s).
    """
    R = correlations(y, y, n_lags)  # (L, out, ref), unbiased
    beta = -math.log(decay) / max(n_lags - 1, 1)
    w = np.exp(-beta * np.arange(n_lags))
    w[0] = 0.5
    Rw = R * w[:, None, None]
    S = np.fft.rfft(Rw, n=2 * n_lags, axis=0)  # sum_k R_k w_k e^{-j w k dt}
    f = np.asarray(np.fft.rfftfreq(2 * n_lags, 1.0 / fs_hz), dtype=np.float64)
    return f, np.ascontiguousarray(np.moveaxis(S, 0, -1)), beta * fs_hz


def _undo_window(sweep: PoleSweep, sigma_w: float) -> PoleSweep:
    """Poles of a windowed half-spectrum with the window's decay added back."""
    sets = []
    for p in sweep.poles:
        w = 2 * np.pi * p.f_hz
        lam = w * (-p.zeta + 1j * np.sqrt(np.clip(1 - p.zeta**2, 0.0, None))) + sigma_w
        wn = np.abs(lam)
        sets.append(replace(p, f_hz=wn / (2 * np.pi),
                            zeta=-lam.real / np.where(wn > 0, wn, 1.0)))
    return replace(sweep, poles=tuple(sets))


def polymax_orders(s: AutoSettings, n_ref: int, n_lines: int, n_out: int) -> int:
    """Highest PolyMAX polynomial order for the record.

    At least 16 and as many poles as the subspace methods' top order
    (``ceil(n_max / n_ref)``), at most what the lines in the band determine
    (``n_lines >= 2 p + 2`` and ``n_lines n_out >= (p + 1)(n_ref + 1)``).
    """
    want = max(16, math.ceil(s.orders[-1] / max(n_ref, 1)))
    cap = min((n_lines - 2) // 2, (n_lines * n_out) // (n_ref + 1) - 2)
    if cap < 2:
        msg = (f"polymax: {n_lines} spectral lines in the band {s.band_hz[0]:.3g}-"
               f"{s.band_hz[1]:.3g} Hz are too few for a polynomial of order 2 with "
               f"{n_ref} references; use a longer record or a wider band")
        raise SignalError(msg)
    return min(want, cap)


_Spectra = tuple[ComplexArray, FloatArray, float]


def _polymax(u: FloatArray, y: FloatArray, s: AutoSettings, notes: list[str],
             keep: list[_Spectra]) -> PoleSweep:
    from modal_twin.acquisition.frf import frf

    n = y.shape[1]
    if u.shape[0]:
        seg = welch_segment(n, u.shape[0])
        est = frf(u, y, s.fs_hz, nperseg=seg)
        H, f, m = est.H1, est.f_hz, u.shape[0]
        notes.append(f"PolyMAX on H1: {seg}-sample segments ({s.fs_hz / seg:.3g} Hz lines), "
                     f"{est.n_averages} averages (>= max(2 x {m} inputs + 2, 8))")
        shift = 0.0
    else:
        lags = max(16, n // 4)
        f, H, shift = half_spectra(y, s.fs_hz, lags)
        m = y.shape[0]
        notes.append(f"PolyMAX on positive half-spectra: {lags} correlation lags "
                     f"({s.fs_hz / (2 * lags):.3g} Hz lines), {m} references, exponential "
                     f"window to 1 % (its damping {shift:.3g} 1/s added back)")
    lines = int(np.count_nonzero((f >= s.band_hz[0]) & (f <= s.band_hz[1]) & (f > 0)))
    p_max = polymax_orders(s, m, lines, y.shape[0])
    if shift:  # half-spectra: fitted per sub-band (polymax_oma.polymax_banded)
        sweep, cores = polymax_banded(H, f, list(range(2, p_max + 1)), s.band_hz)
        notes.append(f"PolyMAX fitted per sub-band ({len(cores)}: "
                     + ", ".join(f"{a:.3g}-{b:.3g}" for a, b in cores) + " Hz)")
    else:
        sweep = polymax(H, f, orders=range(2, p_max + 1), band_hz=s.band_hz,
                        shapes="numerator")
    keep.append((H, f, shift))
    sweep = replace(sweep, poles=tuple(replace(p, shapes=np.nan_to_num(p.shapes))
                                       for p in sweep.poles))  # no numerator: MAC 0
    return _undo_window(sweep, shift) if shift else sweep


def _lsfd_shapes(mm: ModalModel, spectra: _Spectra, band: tuple[float, float]) -> ModalModel:
    """Return the selected PolyMAX modes with LSFD shapes (Eq. (5) of [002]) in the band.

    The poles are those of the fitted spectra: for half-spectra, with the window's decay.
    """
    from modal_twin.identification.lsfd import lsfd

    if mm.f_hz.size == 0:
        return mm
    H, f, shift = spectra
    sel = (f >= band[0]) & (f <= band[1]) & (f > 0) & np.all(np.isfinite(H), axis=(0, 1))
    w = 2 * np.pi * mm.f_hz
    lam = w * (-mm.zeta + 1j * np.sqrt(np.clip(1 - mm.zeta**2, 0.0, None))) - shift
    return replace(mm, shapes=lsfd(H[..., sel], f[sel], lam).shapes)


def scale_groups(y: FloatArray, quantities: Sequence[str]) -> tuple[list[str], str]:
    """Channel scales of output-only SSI: one per quantity unless its RMS spread is large.

    The output channels of one quantity share one scale, their joint RMS, so that a weak,
    noise-dominated channel is not raised to the level of the strong ones (the textbook
    SSI-cov of Peeters & De Roeck 1999 on data of one unit); where the strongest channel
    of a quantity has more than :data:`JOINT_SCALE` times the RMS of its weakest, joint
    scaling would leave the weak ones out, and each channel of that quantity is scaled
    to unit RMS.

    Returns
    -------
    (list of str, str)
        A label per channel (``ssi_cov(scale_groups=)``) and a note.
    """
    rms = np.std(y, axis=1)
    labels, said = [], []
    for q in dict.fromkeys(quantities):
        sel = [k for k, c in enumerate(quantities) if c == q]
        spread = float(rms[sel].max() / max(rms[sel].min(), 1e-300))
        joint = spread <= JOINT_SCALE
        said.append(f"{len(sel)} {q} channel{'s' * (len(sel) > 1)} "
                    + ("scaled jointly" if joint or len(sel) == 1 else "each to unit RMS")
                    + f" (RMS spread x{spread:.1f}, {'<=' if joint else '>'} x{JOINT_SCALE:g})")
    for k, q in enumerate(quantities):
        sel = [j for j, c in enumerate(quantities) if c == q]
        joint = rms[sel].max() <= JOINT_SCALE * rms[sel].min()
        labels.append(q if joint else f"{q}#{k}")
    return labels, "SSI-cov scales: " + "; ".join(said)


def _sweep(method: str, u: FloatArray, y: FloatArray, s: AutoSettings, nb: int,
           notes: list[str], keep: list[_Spectra], quantities: Sequence[str] = (),
           cov_io: bool = False) -> PoleSweep:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # fewer std blocks on short records
        try:
            if method == "n4sid" and cov_io:  # the output scales of SSI-cov
                groups, note = scale_groups(y, quantities or ["output"] * y.shape[0])
                notes.append("N4SID " + note.replace("SSI-cov ", ""))
                return n4sid(u, y, s.fs_hz, orders=s.orders, block_rows=s.block_rows,
                             n_blocks_std=nb, weighting="covariance", scale_groups=groups)
            if method == "n4sid":
                return n4sid(u, y, s.fs_hz, orders=s.orders, block_rows=s.block_rows,
                             n_blocks_std=nb)
            if method == "ssi-cov":
                groups, note = scale_groups(y, quantities or ["output"] * y.shape[0])
                notes.append(note)
                return ssi_cov(y, s.fs_hz, orders=s.orders, block_rows=s.block_rows,
                               n_blocks_std=nb, scale_groups=groups)
            return _polymax(u, y, s, notes, keep)
        except np.linalg.LinAlgError as err:
            msg = (f"{method}: the data are rank-deficient at these settings ({err}); "
                   f"noise-free or duplicated channels? Try fewer channels or a lower f_max")
            raise SignalError(msg) from err


def cmif(y: FloatArray, fs_hz: float) -> tuple[FloatArray, FloatArray]:
    """Singular values of the output PSD matrix per line (CMIF), Welch with Hann windows.

    Returns ``(f_hz, s)`` with ``s`` (min(n_out, 4), n_f), largest first.
    """
    seg = welch_segment(y.shape[1], 0, min_averages=16)
    y0 = y - y.mean(axis=1, keepdims=True)
    f, G = sig.csd(y0[:, None, :], y0[None, :, :], fs=fs_hz, nperseg=seg, axis=-1)
    sv = np.linalg.svd(np.moveaxis(G, -1, 0), compute_uv=False)  # (n_f, n_out)
    return np.asarray(f, dtype=float), np.asarray(sv.T[:4], dtype=float)


def _coherence(u: FloatArray, y: FloatArray, fs_hz: float, band: tuple[float, float]
               ) -> float:
    r"""Mean multiple coherence of the outputs with the inputs over the band, debiased.

    The estimate from :math:`n_d` averages with :math:`m` inputs is biased up by about
    :math:`b = m / n_d` (its expected value for inputs unrelated to the outputs; Bendat &
    Piersol, Random Data, sec. 9.3); the value returned is
    :math:`(\hat\gamma^2 - b) / (1 - b)`, clipped to [0, 1]: the share of the output
    power the measured inputs explain.
    """
    from modal_twin.acquisition.frf import frf

    est = frf(u, y, fs_hz, nperseg=welch_segment(y.shape[1], u.shape[0]))
    sel = (est.f_hz >= band[0]) & (est.f_hz <= band[1])
    if not sel.any():
        return 0.0
    return debiased_coherence(float(est.coherence[:, sel].mean()), u.shape[0], est.n_averages)


def debiased_coherence(mean: float, n_in: int, n_averages: int) -> float:
    r"""Return a mean multiple coherence of ``n_averages`` averages of ``n_in`` inputs, debiased.

    :math:`(\hat\gamma^2 - b) / (1 - b)` with :math:`b = m / n_d` (:func:`_coherence`),
    clipped to [0, 1].
    """
    b = min(n_in / max(n_averages, 1), 0.99)
    return float(np.clip((mean - b) / (1 - b), 0.0, 1.0))


def _select(sweep: PoleSweep, opts: IdentifyOptions, band: tuple[float, float],
            notes: list[str], harmonic: Callable[[float], bool] | None = None,
            io: bool = True,
            spectrum: Callable[[float, float, ComplexArray], bool] | None = None
            ) -> tuple[StabilizationDiagram, ModalModel, bool, list[DroppedColumn]]:
    rule = opts.selection or ("stability" if sweep.method == "polymax" and io else "clusters")
    if rule == "clusters":
        diag = stabilization_diagram(sweep, **opts.thresholds)
        cm = cluster_modes(diag, zeta_max=opts.zeta_max, f_range_hz=band, mpc_min=MPC_MIN,
                           harmonic=harmonic, spectrum=None if io else spectrum)
        notes.append(f"modes by clustering the poles of {len(sweep.orders)} orders: cut-off "
                     f"distance {cm.cutoff:.3f} from the data, a mode needs {cm.n_min} poles "
                     f"with damping in ({100 * ZETA_MIN:g}, {100 * opts.zeta_max:g} %) and MPC >= "
                     f"{MPC_MIN:g}")
        return diag, cm.modes, False, list(cm.dropped)
    tries = [opts.thresholds] + ([RELAXED] if opts.relax and opts.thresholds != RELAXED
                                 else [])
    k = 0
    for k, th in enumerate(tries):  # noqa: B007 (k: the try that gave the modes)
        diag = stabilization_diagram(sweep, **th)
        mm = select_modes(diag, zeta_max=opts.zeta_max, f_range_hz=band,
                          rel_support=REL_SUPPORT)
        if mm.f_hz.size:
            break
    relaxed = k > 0
    if relaxed:
        notes.append(f"no mode with the stability thresholds {opts.thresholds}; relaxed "
                     f"to {RELAXED}")
    drop = dropped_columns(diag, mm, zeta_max=opts.zeta_max, f_range_hz=band)
    return diag, mm, relaxed, drop


def _choose_method(u: FloatArray, y: FloatArray, fs_hz: float, opts: IdentifyOptions,
                   corners: tuple[float, float], notes: list[str]
                   ) -> tuple[str, float, bool, bool, str]:
    """Return the method, the input coherence, whether to use inputs, whether fed back.

    The coherence is debiased (NaN: not needed). The last item is why the inputs fail
    the test below ('' when they pass or were not tested); ``--method n4sid`` runs the
    covariance-driven form when they fail (:func:`identify_record`).

    The default method and PolyMAX with the inputs of the channel map (not named) use the
    inputs only when their debiased coherence is at least :data:`COHERENT` and, on a
    transient record (window RMS spread above :data:`NONSTATIONARY`: an earthquake's
    ground motion), the outputs do not feed back into them
    (:func:`~modal_twin.identification.feedback.input_feedback` below
    :data:`~modal_twin.identification.feedback.FEEDBACK`: inputs that move with the
    structure, such as a foundation on soil, make the input-output model the fixed-base
    structure, not the system whose modes the response shows); PolyMAX also only when
    the H1 lines (:func:`welch_segment`) resolve a mode damped :data:`H1_ZETA` at the
    band's centre.
    """
    method = opts.method
    coh = math.nan
    n_in = u.shape[0]
    why_not = ""  # why the map's inputs are not used ('' when they are)
    fb = math.nan  # NaN: not tested (a stationary record, or incoherent inputs)
    if n_in and (method in (None, "n4sid") or (method == "polymax" and opts.inputs is None)):
        s0 = _settings(y, fs_hz, n_in, opts, corners)
        yd = decimate(y, fs_hz, s0.factor).x
        ud = decimate(u, fs_hz, s0.factor).x
        coh = _coherence(ud, yd, s0.fs_hz, s0.band_hz)
        # the feedback test on transient records only (ground motions: broadband, and where
        # a foundation on soil feeds back); a stationary drive is a rig's, prescribed, and
        # often band-limited, which Granger's finite-lag test misreads as fed back. At a
        # rate whose anti-alias edge (0.8 x Nyquist) lies at twice the band or more: a
        # decimation filter cutting close above the modes misleads it the same way
        qf = max(1, int(fs_hz // (5 * s0.band_hz[1])))
        fb = (input_feedback(decimate(u, fs_hz, qf).x, decimate(y, fs_hz, qf).x)
              if coh >= COHERENT and rms_spread(y) > NONSTATIONARY else math.nan)
        why_not = (f"mean coherence {coh:.2f} with the outputs in the band (debiased) "
                   f"(< {COHERENT:g}: the inputs explain too little of the response)"
                   if coh < COHERENT else
                   f"mean coherence {coh:.2f} with the outputs (debiased), but the outputs' "
                   f"past explains {100 * fb:.0f} % of the inputs' prediction error (>= "
                   f"{100 * FEEDBACK:g} %: the inputs move with the structure, fed back as a "
                   f"foundation on soil; input-output would give the fixed-base system)"
                   if fb >= FEEDBACK else "")
    if method == "polymax" and n_in and opts.inputs is None:
        df = s0.fs_hz / welch_segment(yd.shape[1], n_in)
        fc = 0.5 * (s0.band_hz[0] + s0.band_hz[1])
        why = why_not or (
            f"H1 lines {df:.3g} Hz apart (>= 2 x {n_in} + 2 averages) do not resolve "
            f"a {100 * H1_ZETA:g} %-damped mode at the band's centre {fc:.3g} Hz "
            f"(half-power width {2 * H1_ZETA * fc:.3g} Hz)"
            if df > 2 * H1_ZETA * fc else "")
        if why:
            notes.append(f"PolyMAX output-only: {n_in} driven inputs, {why}; name them "
                         f"with --inputs to use them")
            return method, coh, False, fb >= FEEDBACK, why_not
    if method is None and n_in:
        method = "ssi-cov" if why_not else "n4sid"
        notes.append(f"method {method}: {n_in} driven inputs, "
                     + (f"{why_not}; output-only" if why_not else
                        f"mean coherence {coh:.2f} with the outputs in the band (debiased) "
                        f"(>= {COHERENT:g}: the inputs explain the response)"
                        + ("" if math.isnan(fb) else
                           f" and not fed back by them (the outputs' past explains "
                           f"{100 * fb:.0f} % of their prediction error, < "
                           f"{100 * FEEDBACK:g} %)")
                        + "; input-output"))
    elif method is None:
        method = "ssi-cov"
        notes.append("method ssi-cov: no driven input, output-only")
    return method, coh, method not in OUTPUT_ONLY, fb >= FEEDBACK, why_not


def _n4sid_form(method: str, coh: float, weak: str, notes: list[str], warn: list[str]
                ) -> bool:
    """Whether N4SID runs covariance-driven (said), and a warning for failing inputs.

    Covariance-driven where the inputs explain less than :data:`COHERENT` of the response;
    with that much unmeasured excitation (Hayward's ground channels: 0.64-0.65) PO-MOESP's
    whitening of the instruments biases the poles and loses columns; the covariance-driven
    form (:func:`~modal_twin.identification.n4sid.n4sid`, ``weighting="covariance"``;
    Reynders & De Roeck 2008, pyOMA2's IOcov) does not weight them. Coherent inputs, fed
    back or not, keep PO-MOESP: on the frame on a soil spring of
    ``test/identification/test_feedback.py`` it gives the fixed-base frame, where the
    covariance form found only its top mode (11.18 Hz; session 13). The warning goes
    wherever the inputs fail the test (incoherent or fed back).
    """
    cov_io = method == "n4sid" and coh < COHERENT
    if cov_io:
        notes.append(f"n4sid covariance-driven (past outputs as references, Reynders & De "
                     f"Roeck 2008, as pyOMA2's IOcov): {weak}")
    if method == "n4sid" and weak:
        warn.append("n4sid with inputs that fail the input-output test: its modes are those "
                    "of the system from the measured inputs to the outputs (a structure on "
                    "soil: fixed at the measured points), which may differ from the "
                    "response's modes (the default: output-only ssi-cov); a peak the inputs "
                    "carry themselves (site or soil-structure) is not its pole")
    return cov_io


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
    if not outs and opts.directions is not None and _pick(chans, "output", opts.outputs, None):
        along = sorted({c.direction or "none" for c in _pick(chans, "output", opts.outputs,
                                                              None)})
        msg = (f"{block.source or 'record'}: directions {list(opts.directions)}: no output "
               f"channel along them (the outputs' directions: {along})")
        raise OptionError(msg)
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
    y = block.select(tuple(c.name for c in outs)).data
    u = block.select(tuple(c.name for c in ins)).data if ins else np.zeros((0, y.shape[1]))
    corners = _corners(outs + ins)
    method, coh, io, fed_back, weak = _choose_method(u, y, block.fs_hz, opts, corners, notes)
    if not io:
        ins, u = [], np.zeros((0, y.shape[1]))
    if not ins and method == "n4sid":
        msg = (f"{block.source or 'record'}: method {method} needs input channels (role "
               f"'input'), the record has none driven; use ssi-cov or polymax (output-only) "
               f"or name the inputs")
        raise OptionError(msg)
    s = _settings(y, block.fs_hz, len(ins), opts, corners)
    warn: list[str] = []
    if not ins and (r := rms_spread(y)) > NONSTATIONARY:
        name = "SSI" if method == "ssi-cov" else "PolyMAX"
        hint = ("use n4sid with the measured inputs if there are any" if math.isnan(coh)
                else "the measured inputs are fed back by the structure (--method n4sid "
                     "would give the fixed-base system)" if fed_back
                else f"the measured inputs explain {100 * coh:.0f} % of the response "
                     f"(--method n4sid uses them)")
        warn.append(f"output-only {name} on a non-stationary record: window RMS varies by "
                    f"x{r:.1f} (> x{NONSTATIONARY:g}); its modes assume stationary "
                    f"excitation -- {hint}")
    if s.factor > 1:
        yq = decimate(y, block.fs_hz, s.factor).x
        uq = decimate(u, block.fs_hz, s.factor).x if ins else u[:, :: s.factor]
    else:
        yq, uq = y, u
    spectra: list[_Spectra] = []
    cov_io = _n4sid_form(method, coh, weak, notes, warn)
    sweep = _sweep(method, uq, yq, s, opts.n_blocks_std, notes, spectra,
                   [c.quantity for c in outs], cov_io)
    diag, mm, relaxed, drop = _select(
        sweep, opts, s.band_hz, notes,
        harmonic=lambda f: is_harmonic(yq, s.fs_hz, f),  # a column damped at about zero
        io=bool(ins) and not cov_io,  # output-only and OMAX n4sid: a mode peaks
        spectrum=spectral_peak(yq, s.fs_hz))
    if spectra and spectra[0][2] > 0:  # output-only PolyMAX: modes on peaks of the data
        mm, gone, note = half_spectra_support(mm, spectra[0][1], spectra[0][0],
                                              spectra[0][2], yq.shape[1], s.fs_hz, sweep)
        drop = sorted(drop + gone, key=lambda d: d.f_hz)
        notes.append(note)
    if spectra:
        mm = _lsfd_shapes(mm, spectra[0], s.band_hz)
    return RecordModes(method, tuple(ins), tuple(outs), s, sweep, diag, mm, relaxed,
                       tuple(notes), tuple(warn), tuple(drop), cmif(yq, s.fs_hz))
