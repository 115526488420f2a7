"""The one reader of matrix files, and a data set's rules given beside it (not built in)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from modal_twin.errors import ConfigError, ShapeError
from modal_twin.io.matfiles import BRIDGE_DIR, BRIDGE_RULES, load_bridge
from modal_twin.models.matrix_model import load_matrix_model, read_matrix_rules

ROOT = Path(__file__).resolve().parents[2]


def chain(tmp_path: Path) -> Path:
    """Three springs in a chain: K_s1, K_s2, K_s3 (unit stiffness), unit masses."""
    k = []
    for j in range(3):
        K = np.zeros((3, 3))
        if j == 0:
            K[0, 0] = 1.0
        else:
            K[np.ix_([j - 1, j], [j - 1, j])] = [[1.0, -1.0], [-1.0, 1.0]]
        k.append(K)
    p = tmp_path / "chain.npz"
    np.savez(p, M=np.eye(3), K_s3=k[2], K_s1=k[0], K_s2=k[1])
    return p


def test_rules_give_order_and_bounds_the_file_lacks(tmp_path: Path) -> None:
    src = chain(tmp_path)
    plain = load_matrix_model(src)
    assert plain.names == ("s1", "s2", "s3") and plain.lower is None
    rules = tmp_path / "rules.yaml"
    rules.write_text("parameters: [s3, s1, s2]\nlower: [-0.5, -0.1, -0.2]\n"
                     "upper: [1.0, 0.1, 0.2]\n", encoding="utf-8")
    mm = load_matrix_model(src, rules=rules)
    assert mm.names == ("s3", "s1", "s2")
    np.testing.assert_array_equal(mm.lower, [-0.5, -0.1, -0.2])
    np.testing.assert_array_equal(mm.K_j[0].toarray(), plain.K_j[2].toarray())
    # written and read again: the order and the bounds stay paired
    out = tmp_path / "again.npz"
    from modal_twin.models.matrix_model import sparse_members

    np.savez(out, **sparse_members(mm.to_arrays()))
    back = load_matrix_model(out)
    assert back.names == ("s3", "s1", "s2")
    np.testing.assert_array_equal(back.upper, [1.0, 0.1, 0.2])


def test_bad_rules_name_what_is_wrong(tmp_path: Path) -> None:
    src = chain(tmp_path)
    bad = tmp_path / "bad.yaml"
    bad.write_text("parameters: [s1, s2, s4]\n", encoding="utf-8")
    with pytest.raises(ShapeError, match=r"expected the parameters \['s1', 's2', 's4'\]"):
        load_matrix_model(src, rules=bad)
    bad.write_text("parameters: [s1, s2, s3]\nlower: [0, 0, 0]\nupper: [1, 1]\n",
                   encoding="utf-8")
    with pytest.raises(ConfigError, match="upper: expected 3 finite numbers, got 2"):
        read_matrix_rules(bad)
    bad.write_text("parameters: [s1, s2, s3]\nlower: [0, 0, 0]\nupper: [1, 0, 1]\n",
                   encoding="utf-8")
    with pytest.raises(ConfigError, match="lower < upper"):
        read_matrix_rules(bad)
    bad.write_text("parameters: [s1]\nbounds: [0, 1]\n", encoding="utf-8")
    with pytest.raises(ConfigError, match=r"unknown keys \['bounds'\]"):
        read_matrix_rules(bad)


def test_the_bridge_rules_file_holds_the_projects_order_and_bounds() -> None:
    r = read_matrix_rules(ROOT / "config" / "matrix_models" / "pedestrian_bridge.yaml")
    assert r.parameters == ("Frame", "Truss", *(f"Conc{j}" for j in range(1, 12)),
                            "y1", "z1", "y2", "z2")
    assert r.lower is not None and r.upper is not None
    np.testing.assert_array_equal(r.lower, [-0.1, -0.1] + [-0.2] * 11 + [-1.0] * 4)
    np.testing.assert_array_equal(r.upper, [0.1, 0.1] + [0.4] * 11 + [10.0] * 4)
    assert BRIDGE_RULES == ROOT / "config" / "matrix_models" / "pedestrian_bridge.yaml"


@pytest.mark.skipif(not BRIDGE_DIR.is_dir(), reason="../shared/realdata/model_updating absent")
def test_one_reader_reads_the_bridge_as_its_loader_does() -> None:
    b = load_bridge()
    mat = next(BRIDGE_DIR.glob("*SteelPedestrianBridgeExp.mat"))
    mm = load_matrix_model(mat, rules=BRIDGE_RULES)
    assert mm.names == b.names and mm.n_dof == 946
    np.testing.assert_array_equal(mm.lower, b.lower)
    assert (mm.K0 != b.K0).nnz == 0
    np.testing.assert_array_equal(mm.measured_dofs, b.measured_dofs)
