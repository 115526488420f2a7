r"""Several setups, one set of shapes: roving sensors merged through reference channels.

A structure with more measurement points than sensors is tested in setups: some sensors
stay put (the **references**), the others rove. Each setup is identified on its own, so
each gives its modes with shapes of an arbitrary complex scale. PoSER (post separate
estimation re-scaling) joins them: the modes of all the setups are grouped by frequency and
by the MAC of their reference parts (a mode first seen in a later setup, one the first
setup's identification missed, starts its own group and is kept), every member's shape is
scaled so that its reference part matches the group's first member's in least squares,

.. math:: \alpha_s = \frac{\phi_{R,s}^H \phi_{R,a}}{\phi_{R,s}^H \phi_{R,s}},
          \qquad \phi_s \leftarrow \alpha_s \phi_s ,

(:math:`a` the setup that saw the mode first: the first setup for every mode it holds) and
the scaled roving parts are put side by side (a channel measured in several setups keeps
the mean of its scaled values). A channel that no setup seeing the mode measured stays
NaN: unmeasured, not zero. Frequencies and damping ratios are the means over the setups
that saw the mode; their spread is returned with them, and which setups those were.
:func:`cross_mac` gives the MAC between the modes of two setups on their common channels,
the check that the pairing is sound.
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
        Means over the setups that saw the mode; ``f_spread_hz`` / ``zeta_spread`` their
        ranges.
    shapes : (n_channels, n_modes) complex array
        NaN at the channels no setup that saw the mode measured.
    ref_mac : (n_modes, n_setups) array
        MAC of each setup's reference part with that of the setup that saw the mode first
        (NaN: the setup did not see it).
    seen_in : tuple of tuple of int
        Per mode, the setups (0-based) that saw it.
    """

    channels: tuple[str, ...]
    f_hz: FloatArray
    zeta: FloatArray
    shapes: ComplexArray
    f_spread_hz: FloatArray
    zeta_spread: FloatArray
    ref_mac: FloatArray
    seen_in: tuple[tuple[int, ...], ...] = ()

    def complete(self) -> np.ndarray:
        """Return whether each mode was seen in every setup (boolean, per mode)."""
        return np.all(np.isfinite(self.ref_mac), axis=1)


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


def _groups(setups: Sequence[SetupModes], refs: list[str], df_rel: float, min_mac: float
            ) -> list[dict[int, tuple[int, float]]]:
    """Each mode as ``{setup: (mode index, reference MAC with its first member)}``.

    Setup by setup, its modes join the groups so far one to one, best reference MAC first
    (within ``df_rel`` of the group's first frequency and a MAC of at least ``min_mac``);
    a mode that joins none starts a group.
    """
    groups: list[dict[int, tuple[int, float]]] = []
    anchors: list[tuple[float, ComplexArray]] = []
    for k, s in enumerate(setups):
        phi_r = np.asarray(s.shapes)[_rows(s, refs)]
        cand = []
        for g, (f0, r0) in enumerate(anchors):
            near = np.flatnonzero(np.abs(s.f_hz - f0) <= df_rel * f0)
            if near.size:
                scores = mac(r0[:, None], phi_r[:, near])[0]
                cand += [(float(sc), g, int(j)) for sc, j in zip(scores, near, strict=True)
                         if sc >= min_mac]
        used: set[int] = set()
        for sc, g, j in sorted(cand, reverse=True):
            if k not in groups[g] and j not in used:
                groups[g][k] = (j, sc)
                used.add(j)
        for j in range(len(s.f_hz)):
            if j not in used:
                groups.append({k: (j, 1.0)})
                anchors.append((float(s.f_hz[j]), phi_r[:, j]))
    return groups


def merge_setups(setups: Sequence[SetupModes], references: Sequence[str], *,
                 df_rel: float = 0.05, min_mac: float = 0.8) -> MergedModes:
    """Join the setups' modes into shapes over every channel (PoSER, module docstring).

    Modes of different setups are one mode when their frequencies are within ``df_rel``
    and their reference parts have a MAC of at least ``min_mac``; every mode of every
    setup is kept, with the setups that saw it (``seen_in``), in ascending frequency.

    Raises
    ------
    SignalError
        No setup, or a reference channel missing from a setup.
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
    channels = list(dict.fromkeys(c for s in setups for c in s.channels))
    groups = _groups(setups, refs, df_rel, min_mac)
    f_out, z_out, fs_out, zs_out, shapes, macs = [], [], [], [], [], []
    for g in groups:
        a = min(g)
        ref0 = np.asarray(setups[a].shapes)[_rows(setups[a], refs), g[a][0]]
        total = np.zeros(len(channels), complex)
        count = np.zeros(len(channels))
        for k, (j, _) in g.items():
            s = setups[k]
            phi = np.asarray(s.shapes)[:, j]
            pr = phi[_rows(s, refs)]
            alpha = np.vdot(pr, ref0) / np.vdot(pr, pr)  # least squares: alpha pr ~ ref0
            for i, c in enumerate(s.channels):
                total[channels.index(c)] += alpha * phi[i]
                count[channels.index(c)] += 1
        with np.errstate(invalid="ignore", divide="ignore"):
            shapes.append(np.where(count > 0, total / np.maximum(count, 1), np.nan + 0j))
        fk = np.array([setups[k].f_hz[j] for k, (j, _) in g.items()])
        zk = np.array([setups[k].zeta[j] for k, (j, _) in g.items()])
        f_out.append(fk.mean())
        z_out.append(zk.mean())
        fs_out.append(np.ptp(fk))
        zs_out.append(np.ptp(zk))
        macs.append([g[k][1] if k in g else np.nan for k in range(len(setups))])
    order = np.argsort(f_out, kind="stable")
    return MergedModes(tuple(channels), np.array(f_out)[order], np.array(z_out)[order],
                       np.asarray(shapes, dtype=np.complex128).T[:, order],
                       np.array(fs_out)[order], np.array(zs_out)[order],
                       np.array(macs, dtype=float)[order],
                       tuple(tuple(sorted(groups[i])) for i in order))
