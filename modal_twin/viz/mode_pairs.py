"""Identified modes on the structure: sampled model shapes, MAC pairs, SEREP expansion.

An identified shape is known at the measured channels only. To draw it on the whole
structure it is expanded with the model's modes (SEREP: the least-squares combination of
the model shapes sampled at the channels that reproduces it), and each identified mode is
paired with the model mode of highest MAC at the channels (Eq. (6) of [002]).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from modal_twin._types import ComplexArray, FloatArray
from modal_twin.errors import ShapeError
from modal_twin.identification.metrics import mac_measured

__all__ = ["channel_nodes", "expand_shapes", "pair_by_mac", "real_shapes", "sampled_shapes"]

_AXIS = {"x": 0, "y": 1, "z": 2}


def channel_nodes(channels: Sequence[str], node_xyz: FloatArray,
                  sensors: Mapping[str, FloatArray],
                  dofs: Sequence[Mapping[str, object]] = ()) -> list[tuple[int, int]]:
    """(node index, axis) of each channel ``<sensor>_<x|y|z>`` (or its file entry).

    Raises
    ------
    ShapeError
        A channel that names no sensor of the structure or no axis.
    """
    out = []
    for k, ch in enumerate(channels):
        entry = dofs[k] if k < len(dofs) else {}
        sensor, _, axis = ch.rpartition("_")
        axis = str(entry.get("direction") or axis).lower()
        if sensor not in sensors or axis not in _AXIS:
            msg = (f"channel {ch!r}: expected <sensor>_<x|y|z> with a sensor of the "
                   f"structure ({sorted(sensors)[:6]} ...)")
            raise ShapeError(msg)
        node = int(np.argmin(np.linalg.norm(node_xyz - sensors[sensor], axis=1)))
        out.append((node, _AXIS[axis]))
    return out


def sampled_shapes(shapes: FloatArray, where: Sequence[tuple[int, int]]) -> FloatArray:
    """Model shapes (n_modes, n_nodes, 3) at the channels: (n_ch, n_modes)."""
    return np.stack([shapes[:, n, a] for n, a in where])


def real_shapes(shapes: ComplexArray) -> FloatArray:
    """Each complex shape (column) turned so that its largest entry is real, real part.

    An entry not measured (NaN: a mode some roving setups lacked) stays NaN and is never
    the largest.
    """
    s = np.asarray(shapes, complex)
    mag = np.abs(s)
    k = np.argmax(np.where(np.isfinite(mag), mag, -1.0), axis=0)
    phase = np.exp(-1j * np.angle(s[k, np.arange(s.shape[1])]))
    return np.real(s * phase)


def pair_by_mac(identified: ComplexArray, model_at_channels: FloatArray
                ) -> list[tuple[int, int, float]]:
    """Return (identified index, model index, MAC): each identified mode with its best."""
    m = mac_measured(identified, model_at_channels)
    m = np.where(np.isfinite(m), m, 0.0)  # a shape with no measured entry pairs with nothing
    return [(i, int(np.argmax(m[i])), float(np.max(m[i]))) for i in range(m.shape[0])]


def expand_shapes(identified: FloatArray, model_at_channels: FloatArray,
                  model_shapes: FloatArray) -> FloatArray:
    """SEREP expansion of real shapes (n_ch, m) onto the nodes: (m, n_nodes, 3).

    ``model_at_channels`` (n_ch, k) are the model's shapes at the channels and
    ``model_shapes`` (k, n_nodes, 3) the same on every node; the coefficients are the
    least-squares solution of ``model_at_channels a = identified``.
    """
    ident = np.asarray(identified, dtype=float)
    ok = np.isfinite(ident)
    if ok.all():
        a, *_ = np.linalg.lstsq(model_at_channels, ident, rcond=None)  # (k, m)
    else:  # an entry not measured (NaN) leaves its row out of that mode's fit
        a = np.column_stack([np.linalg.lstsq(model_at_channels[ok[:, j]], ident[ok[:, j], j],
                                             rcond=None)[0] for j in range(ident.shape[1])])
    return np.einsum("km,knd->mnd", a, model_shapes)
