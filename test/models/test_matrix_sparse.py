"""Matrix models stored sparse: CSR members in an NPZ, read back equal; dense still read;
malformed or oversized sparse members refused with one line; the pedestrian bridge's .mat
exported to a file of the .mat's size with the same eigenfrequencies."""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp

from modal_twin.cli import main
from modal_twin.errors import ConfigError
from modal_twin.models.matrix_model import load_matrix_model, read_matrix_arrays, sparse_members

BRIDGE = "realdata/model_updating/SteelPedestrianBridge__Experiment__Experiment_Model_Updating__" \
         "SteelPedestrianBridgeExp.mat"


def _chain(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A spring-mass chain: M, and the stiffness split into the odd and even springs."""
    k_odd, k_even = np.zeros((n, n)), np.zeros((n, n))
    for i in range(n):  # spring i joins DOF i-1 (or the ground) and DOF i
        k = k_odd if i % 2 else k_even
        k[i, i] += 1000.0 * (i + 1)
        if i:
            k[i - 1, i - 1] += 1000.0 * (i + 1)
            k[i - 1, i] -= 1000.0 * (i + 1)
            k[i, i - 1] -= 1000.0 * (i + 1)
    return np.diag(np.linspace(1.0, 2.0, n)), k_odd, k_even


def _f_hz(M: np.ndarray, K: np.ndarray, n: int | None = None) -> np.ndarray:
    """The ``n`` lowest natural frequencies, from M phi = mu K phi (mu = 1 / omega^2: a
    massless DOF gives mu = 0, no infinite eigenvalue)."""
    mu = sla.eigh(M, K, eigvals_only=True)[::-1][:n]
    return 1.0 / np.sqrt(mu) / (2 * np.pi)


def test_sparse_npz_round_trip_and_dense_still_read(tmp_path: Path) -> None:
    M, ko, ke = _chain(30)
    dense = tmp_path / "dense.npz"
    np.savez(dense, M=M, K_odd=ko, K_even=ke)
    mm = load_matrix_model(dense)
    members = sparse_members(mm.to_arrays(np.array([0.1, -0.2])))
    assert str(members["sparse_format"]) == "csr"
    assert "K" not in members and members["K__indptr"].size == 31
    sparse = tmp_path / "sparse.npz"
    np.savez(sparse, **members)
    back = load_matrix_model(sparse)
    assert back.names == ("even", "odd")
    np.testing.assert_array_equal(back.M.toarray(), M)
    np.testing.assert_allclose(back.K_j[0].toarray(), ke)
    # the stored K is K(theta) of the source: its frequencies are those of the closed sum
    k_theta = (1 - 0.2) * ko + (1 + 0.1) * ke
    np.testing.assert_allclose(_f_hz(back.M.toarray(), back.K0.toarray()), _f_hz(M, k_theta),
                               rtol=1e-12)


def _bad(tmp_path: Path, **members: np.ndarray) -> Path:
    p = tmp_path / "bad.npz"
    np.savez(p, M=np.eye(3), **members)
    return p


@pytest.mark.parametrize(("change", "words"), [
    ({"sparse_format": np.array("coo")}, "without the marker"),
    ({"K__indptr": np.array([0, 1, 2])}, "inconsistent sizes"),
    ({"K__indices": np.array([0, 1, 7])}, "not a valid CSR"),
    ({"K__shape": np.array([3.0, 3.0])}, "inconsistent sizes"),
])
def test_malformed_sparse_members_refused(tmp_path: Path, change: dict[str, np.ndarray],
                                          words: str) -> None:
    good = sparse_members({"K": sp.csr_array(np.eye(3))})
    p = _bad(tmp_path, **{**good, **change})
    with pytest.raises(ConfigError, match=words):
        read_matrix_arrays(p)
    parts = dict(good)
    del parts["K__indptr"]
    with pytest.raises(ConfigError, match="lacks its member"):
        read_matrix_arrays(_bad(tmp_path, **parts))


def test_sparse_member_declaring_too_much_refused_unread(tmp_path: Path) -> None:
    p = tmp_path / "bomb.npz"
    good = sparse_members({"M": sp.csr_array(np.eye(3))})
    with zipfile.ZipFile(p, "w", zipfile.ZIP_DEFLATED) as z:
        for k, v in good.items():
            if k != "M__data":
                with z.open(f"{k}.npy", "w") as fh:
                    np.lib.format.write_array(fh, np.asarray(v))
        with z.open("M__data.npy", "w") as fh:  # declares 2**40 values, holds none
            np.lib.format.write_array_header_1_0(
                fh, {"descr": "<f8", "fortran_order": False, "shape": (1 << 40,)})
    with pytest.raises(ConfigError, match="FILE_UNPACKED_MAX_BYTES"):
        read_matrix_arrays(p)


def test_bridge_exports_sparse_small_with_the_same_modes(shared_dir: Path, tmp_path: Path
                                                         ) -> None:
    src = shared_dir / BRIDGE
    out = tmp_path / "bridge.npz"
    assert main(["export", "model", str(src), "--out", str(out)]) == 0
    size, mat = out.stat().st_size, src.stat().st_size
    assert size < 2 * mat  # dense it was 136 MB from the 1 MB .mat
    a, b = load_matrix_model(src), load_matrix_model(out)
    assert b.names == a.names and b.dofs == a.dofs
    np.testing.assert_array_equal(b.measured_dofs, a.measured_dofs)
    fa = _f_hz(a.M.toarray(), a.K0.toarray(), 20)
    fb = _f_hz(b.M.toarray(), b.K0.toarray(), 20)
    assert 0.5 < fa[0] < 50.0  # a footbridge's first modes
    np.testing.assert_allclose(fb, fa, rtol=1e-12)
    for ka, kb in zip(a.K_j, b.K_j, strict=True):
        assert abs(ka - kb).max() == 0.0


def _declaring(path: Path, n: int, *, cols: int | None = None) -> Path:
    """A sparse M and K of ``n`` x ``cols`` (default ``n``) declared, one entry each (CSR)."""
    nnz_rows = np.zeros(n + 1, np.int32)
    nnz_rows[1:] = 1  # the one entry in row 0
    members = {}
    for k in ("M", "K"):
        members.update({f"{k}__data": np.array([1.0]), f"{k}__indices": np.array([0], np.int32),
                        f"{k}__indptr": nnz_rows,
                        f"{k}__shape": np.array([n, cols or n], np.int64)})
    np.savez_compressed(path, sparse_format=np.array("csr"), **members)
    return path


def test_a_sparse_matrix_declaring_too_many_dofs_is_refused(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """2 M DOFs in 18 kB (the modes would take 2e6 x 61 floats): one line, exit 2."""
    from modal_twin.validation import LIMITS

    hi = int(LIMITS["n_dof"].hi)
    assert hi == 1 << 20
    bomb = _declaring(tmp_path / "bomb.npz", 2 * hi)
    assert bomb.stat().st_size < 100_000
    with pytest.raises(ConfigError, match=rf"sparse matrix 'K' declares shape \({2 * hi}, "
                                          rf"{2 * hi}\); expected at most {hi} rows"):
        read_matrix_arrays(bomb)
    wide = _declaring(tmp_path / "wide.npz", 3, cols=1 << 40)  # few rows, 2^40 columns
    with pytest.raises(ConfigError, match=r"declares shape \(3, 1099511627776\)"):
        read_matrix_arrays(wide)
    out = tmp_path / "o.npz"
    for argv in (["model", "info", str(bomb)], ["export", "model", str(bomb), "--out", str(out)]):
        assert main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert "\n" not in err and err.endswith("(LIMITS['n_dof'])"), err
    assert not out.exists()


def test_the_dof_limit_is_exact(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """At the limit a model reads (its matrices as written), one DOF more is refused; a
    dense or .mat M is held to the same limit."""
    from modal_twin.validation import LIMITS, Limit

    monkeypatch.setitem(LIMITS, "n_dof", Limit(1, 4, integer=True))
    mm = load_matrix_model(_declaring(tmp_path / "four.npz", 4))
    assert mm.n_dof == 4 and mm.M.toarray()[0, 0] == 1.0 and mm.M.nnz == 1
    with pytest.raises(ConfigError, match=r"sparse matrix 'K' declares shape \(5, 5\)"):
        read_matrix_arrays(_declaring(tmp_path / "five.npz", 5))
    np.savez(tmp_path / "dense.npz", M=np.eye(5), K=np.eye(5))
    with pytest.raises(ConfigError, match=r"M declares shape \(5, 5\); expected at most 4"):
        load_matrix_model(tmp_path / "dense.npz")
