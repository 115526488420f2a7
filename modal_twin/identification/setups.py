r"""Several setups, one set of shapes: roving sensors merged through reference channels.

A structure with more measurement points than sensors is tested in setups: some sensors
stay put (the **references**), the others rove. Each setup is identified on its own, so
each gives its modes with shapes of an arbitrary complex scale. PoSER (post separate
estimation re-scaling) joins them: the modes of the setups are paired by frequency and by
the MAC of their reference parts, every setup's shape is scaled so that its reference part
matches the first setup's in least squares,

.. math:: \alpha_s = \frac{\phi_{R,1}^H \phi_{R,s}}{\phi_{R,s}^H \phi_{R,s}}\;\text{(conj.)},
          \qquad \phi_s \leftarrow \alpha_s \phi_s ,

and the scaled roving parts are put side by side (a channel measured in several setups
keeps the mean of its scaled values). Frequencies and damping ratios are the means over
the setups; their spread is returned with them. :func:`cross_mac` gives the MAC between the
modes of two setups on their common channels, the check that the pairing is sound.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from modal_twin._types import ComplexArray, FloatArray
from modal_twin.errors import ShapeError, SignalError
from modal_twin.identification.metrics import mac

__all__ = ["MergedModes", "SetupModes", "cross_mac", "merge_setups"]


@dataclass(frozen=True, slots=True)
class SetupModes:
    """The modes one setup identified: its channels and, per mode, f, zeta and shape."""

    channels: tuple[str, ...]
    f_hz: FloatArray
    zeta: FloatArray
    shapes: ComplexArray  # (n_channels, n_modes)

    def __post_init__(self) -> None:
        n_ch, n_m = np.shape(self.shapes)
        if n_ch != len(self.channels) or n_m != len(self.f_hz) or n_m != len(self.zeta):
            msg = (f"setup: expected shapes ({len(self.channels)}, {len(self.f_hz)}) for its "
                   f"channels and modes, got {np.shape(self.shapes)}")
            raise ShapeError(msg)


@dataclass(frozen=True, slots=True)
class MergedModes:
    """Modes over every channel of every setup.

    Attributes
    ----------
    channels : tuple of str
        Every channel measured in some setup (first appearance order).
    f_hz, zeta : (n_modes,) arrays
        Means over the setups; ``f_spread_hz`` / ``zeta_spread`` their ranges.
    shapes : (n_channels, n_modes) complex array
    ref_mac : (n_modes, n_setups) array
        MAC of each setup's reference part with the first setup's, per mode.
    """

    channels: tuple[str, ...]
    f_hz: FloatArray
    zeta: FloatArray
    shapes: ComplexArray
    f_spread_hz: FloatArray
    zeta_spread: FloatArray
    ref_mac: FloatArray


def _rows(setup: SetupModes, names: Sequence[str]) -> list[int]:
    idx = {c: i for i, c in enumerate(setup.channels)}
    return [idx[c] for c in names]


def cross_mac(a: SetupModes, b: SetupModes) -> FloatArray:
    """MAC (n_modes_a, n_modes_b) of two setups' modes on the channels both measured."""
    common = [c for c in a.channels if c in set(b.channels)]
    if not common:
        msg = "cross_mac: the two setups share no channel"
        raise SignalError(msg)
    return mac(np.asarray(a.shapes)[_rows(a, common)], np.asarray(b.shapes)[_rows(b, common)])


def merge_setups(setups: Sequence[SetupModes], references: Sequence[str], *,
                 df_rel: float = 0.05, min_mac: float = 0.8) -> MergedModes:
    """Join the setups' modes into shapes over every channel (PoSER, module docstring).

    A mode of the first setup is kept when every other setup has a mode within ``df_rel``
    of its frequency whose reference part has a MAC of at least ``min_mac`` with it.

    Raises
    ------
    SignalError
        A reference channel missing from a setup, or no mode found in every setup.
    """
    if not setups:
        msg = "merge_setups: expected at least one setup"
        raise SignalError(msg)
    refs = list(references)
    for k, s in enumerate(setups):
        missing = [r for r in refs if r not in s.channels]
        if missing:
            msg = f"setup {k}: lacks reference channels {missing}"
            raise SignalError(msg)
    first = setups[0]
    channels = list(dict.fromkeys(c for s in setups for c in s.channels))
    f_out, z_out, fs_out, zs_out, shapes, macs = [], [], [], [], [], []
    for m in range(len(first.f_hz)):
        ref0 = np.asarray(first.shapes)[_rows(first, refs), m]
        picks: list[tuple[int, int, float]] = []
        for s in setups:
            phi_r = np.asarray(s.shapes)[_rows(s, refs)]
            near = np.flatnonzero(np.abs(s.f_hz - first.f_hz[m]) <= df_rel * first.f_hz[m])
            if near.size == 0:
                break
            scores = mac(ref0[:, None], phi_r[:, near])[0]
            j = int(near[int(np.argmax(scores))])
            if float(scores.max()) < min_mac:
                break
            picks.append((setups.index(s), j, float(scores.max())))
        if len(picks) != len(setups):
            continue
        total = np.zeros(len(channels), complex)
        count = np.zeros(len(channels))
        for k, j, _ in picks:
            s = setups[k]
            phi = np.asarray(s.shapes)[:, j]
            pr = phi[_rows(s, refs)]
            alpha = np.vdot(pr, ref0) / np.vdot(pr, pr)  # least squares: alpha pr ~ ref0
            for i, c in enumerate(s.channels):
                total[channels.index(c)] += alpha * phi[i]
                count[channels.index(c)] += 1
        shapes.append(total / count)
        fk = np.array([setups[k].f_hz[j] for k, j, _ in picks])
        zk = np.array([setups[k].zeta[j] for k, j, _ in picks])
        f_out.append(fk.mean())
        z_out.append(zk.mean())
        fs_out.append(np.ptp(fk))
        zs_out.append(np.ptp(zk))
        macs.append([sc for _, _, sc in picks])
    if not shapes:
        msg = "merge_setups: no mode of the first setup was found in every setup"
        raise SignalError(msg)
    return MergedModes(tuple(channels), np.array(f_out), np.array(z_out),
                       np.asarray(shapes, dtype=np.complex128).T, np.array(fs_out),
                       np.array(zs_out),
                       np.array(macs))
