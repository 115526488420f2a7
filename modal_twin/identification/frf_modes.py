"""Modes of a measured FRF matrix (a hammer test's): PolyMAX poles, LSFD shapes.

PolyMAX (pLSCF, Eqs. (1)-(4) of [002]) over the orders ``2..order_max`` with numerator
shapes for the stabilization diagram, the stable columns selected
(:func:`~modal_twin.identification.stabilization.select_modes`), then LSFD shapes
(Eq. (5) of [002]) for the selected poles only
(:func:`~modal_twin.identification.lsfd.lsfd_modes`). The shapes are over the FRFs'
outputs (the responses).
"""

from __future__ import annotations

import numpy as np

from modal_twin._types import ComplexArray, FloatArray
from modal_twin.errors import OptionError
from modal_twin.identification.lsfd import lsfd_modes
from modal_twin.identification.modal_model import ModalModel
from modal_twin.identification.polymax import polymax
from modal_twin.identification.stabilization import select_modes, stabilization_diagram

__all__ = ["modes_from_frf"]


def modes_from_frf(H: ComplexArray, f_hz: FloatArray, *, band_hz: tuple[float, float],
                   order_max: int = 30, zeta_max: float = 0.1) -> ModalModel:
    """PolyMAX + LSFD modes of ``H (n_out, n_in, n_f)`` in ``band_hz`` (module docstring).

    Raises
    ------
    OptionError
        A band without lines or an order below 2.
    """
    f = np.asarray(f_hz, dtype=float)
    sel = (f >= band_hz[0]) & (f <= band_hz[1])
    if not (band_hz[0] < band_hz[1]) or np.count_nonzero(sel) < 8 or order_max < 2:
        msg = (f"band_hz {band_hz} and order_max {order_max}: expected a band holding "
               f"lines of the FRFs ({f.min():.4g}-{f.max():.4g} Hz) and an order >= 2")
        raise OptionError(msg)
    Hb, fb = np.asarray(H)[..., sel], f[sel]
    sweep = polymax(Hb, fb, orders=range(2, order_max + 1), band_hz=band_hz,
                    shapes="numerator")
    mm = select_modes(stabilization_diagram(sweep), zeta_max=zeta_max, f_range_hz=band_hz)
    return lsfd_modes(mm, Hb, fb)
