from __future__ import annotations

import numpy as np
import pytest

from modal_twin.errors import OptionError
from modal_twin.identification.modal_model import ModalModel, PoleSet, PoleSweep
from modal_twin.identification.stabilization import select_modes, stabilization_diagram

SHAPES = np.eye(4, dtype=complex)  # four orthogonal shapes


def _sweep(rows: list[list[tuple[float, float, int]]]) -> PoleSweep:
    """rows[k] = poles of order k as (f_hz, zeta, shape index)."""
    sets = []
    for k, row in enumerate(rows):
        f = np.array([r[0] for r in row])
        z = np.array([r[1] for r in row])
        s = SHAPES[:, [r[2] for r in row]] if row else np.zeros((4, 0), complex)
        nan = np.full(f.shape, np.nan)
        sets.append(PoleSet(2 * (k + 1), f, z, s, nan, nan))
    return PoleSweep("test", np.arange(2, 2 * len(rows) + 1, 2), tuple(sets), np.zeros(0), 0)


def test_004_rule_flags() -> None:
    sw = _sweep(
        [
            [(1.000, 0.050, 0), (2.0, 0.02, 1)],  # mode 2: next order 2.5 % away
            [(1.005, 0.051, 0), (2.05, 0.02, 1)],  # back 2.4 % and damping +50 %
            [(1.008, 0.052, 0), (2.0, 0.03, 1)],
            [(1.009, 0.052, 2), (2.0, 0.03, 1)],  # shape changes: MAC = 0
        ]
    )
    d = stabilization_diagram(sw)
    assert d.stable[0].tolist() == [True, False]
    assert d.stable_f[1].tolist() == [True, False]  # 2.05 -> 2.0 Hz is 2.4 %
    assert d.stable_f[2].tolist() == [True, True]
    assert d.stable_zeta[2].tolist() == [True, True]
    assert d.stable_zeta[1].tolist() == [True, False]
    assert d.stable_mac[2].tolist() == [False, True]
    assert d.stable[3].tolist() == [False, True]  # last order compared with the one below
    assert (d.rel_tol_f, d.rel_tol_zeta, d.mac_min) == (0.01, 0.05, 0.95)
    loose = stabilization_diagram(sw, rel_tol_f=0.03, rel_tol_zeta=0.6, mac_min=0.0)
    assert loose.stable[1].all()


def test_selection_keeps_close_modes_with_distinct_shapes() -> None:
    rows = []
    for k in range(10):
        e = 1e-4 * k
        rows.append(
            [
                (0.685 + e, 0.076, 0),
                (0.698 + e, 0.086, 1),  # 1.9 % apart but orthogonal shapes
                (0.710 + e, 0.079, 2),
                (3.0, -0.01, 3),  # negative damping, stable: rejected
                (5.0, 0.5, 3),  # over-damped (50 %), stable: rejected
            ]
        )
    rows[4].append((7.0, 0.02, 3))  # isolated pole: rejected
    mm = select_modes(stabilization_diagram(_sweep(rows)))
    assert isinstance(mm, ModalModel)
    np.testing.assert_allclose(mm.f_hz, [0.6855, 0.6985, 0.7105], atol=6e-4)
    np.testing.assert_allclose(mm.zeta, [0.076, 0.086, 0.079])
    assert mm.shapes.shape == (4, 3)
    assert mm.method == "test"
    assert mm.order == int(mm.mode_orders.max())
    assert mm.n_support.tolist() == [10, 10, 10]
    only = select_modes(stabilization_diagram(_sweep(rows)), f_range_hz=(0.69, 0.70))
    assert only.f_hz.size == 1


def test_nothing_stable_gives_empty_model() -> None:
    rows = [[(1.0 + 0.1 * k, 0.02, 0)] for k in range(5)]
    mm = select_modes(stabilization_diagram(_sweep(rows)))
    assert mm.f_hz.size == 0
    assert mm.shapes.shape == (4, 0)
    assert mm.order == 0


def test_errors() -> None:
    sw = _sweep([[(1.0, 0.02, 0)], [(1.0, 0.02, 0)]])
    with pytest.raises(OptionError, match="rel_tol_f, rel_tol_zeta, mac_min"):
        stabilization_diagram(sw, mac_min=1.5)
    with pytest.raises(OptionError, match="at least 2 model orders"):
        stabilization_diagram(_sweep([[(1.0, 0.02, 0)]]))
    d = stabilization_diagram(sw)
    with pytest.raises(OptionError, match="zeta_max: expected a value in"):
        select_modes(d, zeta_max=0.0)
    with pytest.raises(OptionError, match="min_support: expected an integer >= 1"):
        select_modes(d, min_support=0)
