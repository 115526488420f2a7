"""Where the model fails: error by channel, place, direction, quantity, band and level.

Given measured and predicted records of the same channels, the residual
``e = predicted - measured`` is broken down (each channel normalised by its measured
variance so that accelerations, drifts and forces compare):

- per channel: relative error in RMS (Eq. (8) of [004]) and normalised MSE,
  ``NMSE = var(e) / var(y)``;
- per place (``ChannelSpec.location``), direction and quantity: mean NMSE of its channels;
- per frequency band: the share of the normalised residual energy in the band (Welch);
- coherence of the residual with the inputs: a residual the inputs explain linearly
  (coherence near 1) points at a linear model error, one they do not at a nonlinearity
  or noise;
- amplitude dependence: over windows, the slope ``b`` of log RMS(e) against log RMS(y);
  ``b`` near 1 is an error proportional to the response (linear), ``b`` well above 1 an
  error that grows faster than the response (a nonlinearity that engages with level).
"""

from __future__ import annotations

import itertools
from collections import defaultdict
from dataclasses import dataclass

import numpy as np
from scipy import signal

from modal_twin._types import FloatArray
from modal_twin.channels import ChannelSpec
from modal_twin.errors import ShapeError, SignalError
from modal_twin.twin.metrics import channel_metrics

__all__ = ["GroupError", "WhereReport", "where_it_fails"]


@dataclass(frozen=True, slots=True)
class GroupError:
    """Error of a group of channels (a place, a direction, a band ...)."""

    kind: str
    key: str
    nmse_pct: float
    n_channels: int


@dataclass(frozen=True, slots=True)
class WhereReport:
    """Breakdown of the residual. Arrays are per channel, in ``channels`` order."""

    channels: tuple[ChannelSpec, ...]
    rms_error_pct: FloatArray  # Eq. (8) of [004]
    nmse_pct: FloatArray
    coherence_with_inputs: FloatArray
    level_slope: FloatArray
    groups: tuple[GroupError, ...]
    bands_hz: tuple[tuple[float, float], ...]
    band_share: FloatArray  # share of the normalised residual energy per band

    def worst(self, kind: str, n: int = 5) -> list[GroupError]:
        """Return the ``n`` groups of a kind with the largest NMSE."""
        return sorted((g for g in self.groups if g.kind == kind), key=lambda g: -g.nmse_pct)[:n]

    def format(self, top: int = 10) -> str:
        """Human-readable tables."""
        order = np.argsort(-self.nmse_pct)[:top]
        w = max([12, *(len(self.channels[i].name) + 1 for i in order)])
        out = [f"{'channel':<{w}}{'Eq.8 %':>9}{'NMSE %':>9}{'coh(in)':>9}{'level b':>9}"]
        for i in order:
            out.append(f"{self.channels[i].name:<{w}}{self.rms_error_pct[i]:9.2f}"
                       f"{self.nmse_pct[i]:9.2f}{self.coherence_with_inputs[i]:9.2f}"
                       f"{self.level_slope[i]:9.2f}")
        for kind in ("location", "direction", "quantity"):
            worst = self.worst(kind, 6)
            out.append(f"by {kind}: " + ", ".join(f"{g.key} {g.nmse_pct:.1f} %" for g in worst))
        bands = ", ".join(f"{lo:.2g}-{hi:.2g} Hz {100 * s:.0f} %"
                          for (lo, hi), s in zip(self.bands_hz, self.band_share, strict=True)
                          if s >= 0.02)
        out.append(f"residual energy by band: {bands}")
        return "\n".join(out)


def _bands(fs_hz: float, n: int, n_bands: int) -> tuple[tuple[float, float], ...]:
    f_lo = max(4.0 * fs_hz / n, 1e-3)
    edges = np.geomspace(f_lo, fs_hz / 2, n_bands + 1)
    edges[0] = 0.0
    return tuple((float(a), float(b)) for a, b in itertools.pairwise(edges))


def _level_slope(e: FloatArray, y: FloatArray, n_windows: int) -> FloatArray:
    """Per channel slope of log RMS(e) vs log RMS(y) over windows."""
    nt = y.shape[1] // n_windows * n_windows
    re = np.sqrt(np.mean(e[:, :nt].reshape(len(e), n_windows, -1) ** 2, axis=2))
    ry = np.sqrt(np.mean(y[:, :nt].reshape(len(y), n_windows, -1) ** 2, axis=2))
    out = np.full(len(y), np.nan)
    for c in range(len(y)):
        ok = (re[c] > 0) & (ry[c] > 0)
        ly = np.log(ry[c, ok])
        if ok.sum() >= 3 and np.ptp(ly) > 0.1:
            out[c] = np.polyfit(ly, np.log(re[c, ok]), 1)[0]
    return out


def where_it_fails(
    measured: FloatArray,
    predicted: FloatArray,
    channels: tuple[ChannelSpec, ...],
    fs_hz: float,
    *,
    inputs: FloatArray | None = None,
    n_bands: int = 8,
    n_windows: int = 10,
) -> WhereReport:
    """Break the residual of ``predicted`` against ``measured`` down (module docstring).

    Parameters
    ----------
    measured, predicted : (n_channels, nt) arrays
    channels : ChannelSpec per row
    fs_hz : sample rate
    inputs : (n_in, nt) array, optional
        Measured inputs, for the coherence of the residual with them.

    Raises
    ------
    ShapeError
        Shapes that differ or do not match ``channels``.
    SignalError
        Records too short to analyse (fewer than 64 samples per window).
    """
    if measured.shape != predicted.shape or measured.shape[0] != len(channels):
        msg = (f"measured, predicted: expected two ({len(channels)}, nt) arrays, got "
               f"{measured.shape} and {predicted.shape}")
        raise ShapeError(msg)
    nt = measured.shape[1]
    if nt < 64 * n_windows:
        msg = f"records of {nt} samples are too short: need >= {64 * n_windows}"
        raise SignalError(msg)
    m = channel_metrics(predicted, measured)
    e = predicted - measured
    var_y = np.var(measured, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        nmse = np.where(var_y > 0, 100.0 * np.var(e, axis=1) / var_y, np.nan)
    groups: list[GroupError] = []
    for kind in ("location", "direction", "quantity"):
        by: dict[str, list[float]] = defaultdict(list)
        for c, v in zip(channels, nmse, strict=True):
            if np.isfinite(v):
                by[getattr(c, kind) or "?"].append(float(v))
        groups += [GroupError(kind, k, float(np.mean(v)), len(v)) for k, v in by.items()]
    nper = min(nt, max(256, int(2 ** np.floor(np.log2(nt / 8)))))
    f, pe = signal.welch(e, fs=fs_hz, nperseg=nper, axis=-1)
    bands = _bands(fs_hz, nper, n_bands)
    with np.errstate(divide="ignore", invalid="ignore"):
        pe_n = np.where(var_y[:, None] > 0, pe / var_y[:, None], 0.0)
    energy = np.array([pe_n[:, (f >= lo) & (f < hi)].sum() for lo, hi in bands])
    share = energy / energy.sum() if energy.sum() > 0 else np.zeros(len(bands))
    coh = np.zeros(len(channels))
    if inputs is not None:
        if inputs.shape[1] != nt:
            msg = f"inputs: expected (n_in, {nt}), got {inputs.shape}"
            raise ShapeError(msg)
        active = [u for u in inputs if np.std(u) > 0]
        for u in active:
            _, cxy = signal.coherence(u[None, :], e, fs=fs_hz, nperseg=nper, axis=-1)
            _, pu = signal.welch(u, fs=fs_hz, nperseg=nper)
            band = pu > 1e-3 * pu.max()  # where the input has energy
            coh = np.maximum(coh, np.mean(cxy[:, band], axis=1))
    return WhereReport(
        channels=tuple(channels),
        rms_error_pct=m.rms_error_pct,
        nmse_pct=nmse,
        coherence_with_inputs=coh,
        level_slope=_level_slope(e, measured, n_windows),
        groups=tuple(groups),
        bands_hz=bands,
        band_share=share,
    )
