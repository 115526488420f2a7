"""Checks of trial stiffness / mass matrices: known answers and no native crash."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

from modal_twin.errors import ModelError
from modal_twin.models.fe import solve_modes
from modal_twin.models.fe.definite import check_entries, positive_definite

ROOT = Path(__file__).resolve().parents[2]


def _chain(n: int, k: float = 1.0) -> sp.csc_matrix:
    """Fixed-free spring chain: positive definite, tridiagonal."""
    main = np.full(n, 2.0 * k)
    main[-1] = k
    return sp.diags([-k * np.ones(n - 1), main, -k * np.ones(n - 1)], [-1, 0, 1]).tocsc()


def test_positive_definite_known_answers() -> None:
    assert positive_definite(_chain(50)) == (True, -1)
    free = _chain(50).tolil()
    free[0, 0] = 1.0  # free-free chain: one rigid-body mode, singular
    ok, j = positive_definite(free.tocsc())
    assert not ok and 0 <= j < 50
    indef = sp.csc_matrix(np.array([[1.0, 2.0], [2.0, 1.0]]))  # eigenvalues 3, -1
    assert positive_definite(indef)[0] is False


@pytest.mark.parametrize(("value", "dof", "match"), [
    (np.nan, 3, "finite entries, got nan at DOF"),
    (np.inf, 4, "finite entries, got inf"),
    (0.0, 5, r"diagonal entry > 0\), got 0 at DOF 5"),
    (-2.0, 6, r"got -2 at DOF 6"),
])
def test_check_entries_names_dof(value: float, dof: int, match: str) -> None:
    K = _chain(10).tolil()
    K[dof, dof] = value
    with pytest.raises(ModelError, match=match):
        check_entries("K", K.tocsc(), positive_diagonal=True)
    assert positive_definite(K.tocsc()) == (False, dof)


def test_empty_column_refused_with_dof() -> None:
    K = _chain(10).tolil()
    K[:, 7] = 0.0
    K[7, :] = 0.0
    with pytest.raises(ModelError, match="DOF 7"):
        check_entries("K", K.tocsc(), positive_diagonal=True)


def test_solve_modes_refuses_indefinite_sparse() -> None:
    n = 600  # above the dense fallback: the sparse shift-invert path
    K = _chain(n).tolil()
    K[n // 2, n // 2] = -5.0
    with pytest.raises(ModelError, match=r"diagonal entry > 0\), got -5 at DOF 300"):
        solve_modes(K.tocsc(), sp.eye(n, format="csc"), 3, method="sparse")
    K = _chain(n).tolil()
    K[n // 2, n // 2 + 1] = K[n // 2 + 1, n // 2] = -10.0  # indefinite with a positive diagonal
    with pytest.raises(ModelError, match="positive definite"):
        solve_modes(K.tocsc(), sp.eye(n, format="csc"), 3, method="sparse")


def test_solve_modes_sparse_known_answer() -> None:
    n = 600  # fixed-free chain: omega_j = 2 sin((2j - 1) pi / (2 (2n + 1)))
    sol = solve_modes(_chain(n), sp.eye(n, format="csc"), 3, method="sparse")
    j = np.arange(1, 4)
    expected = 2.0 * np.sin((2 * j - 1) * np.pi / (2 * (2 * n + 1)))
    np.testing.assert_allclose(sol.omega, expected, rtol=1e-8)


_TRIALS = """
import numpy as np
from modal_twin.errors import ModelError
from modal_twin.models.building import build_building, modal_reduction
from modal_twin.models.fe.definite import positive_definite
b = build_building()
par = b.assembly.parametric
th0 = par.theta_vector(None)
rng = np.random.default_rng(12)
bad = [0.0, -1.0, 1e-300, 1e300, np.inf, -np.inf, np.nan, -1e10]
refused = 0
for t in range(1000):
    x = th0.copy()
    if t % 2:
        x[: 3] = 0.0  # all moduli 0: empty rows and columns in K (the reported crash)
    mask = rng.random(x.size) < 0.5
    x[mask] = rng.choice(bad, size=int(mask.sum()))
    K = par.K(x)
    positive_definite(K)
    try:
        modal_reduction(b, theta=dict(zip(par.names, x.tolist())))
    except ModelError:
        refused += 1
print("refused", refused)
"""


def test_thousand_singular_and_indefinite_trials_do_not_crash() -> None:
    env = {"PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1", "PATH": "/usr/bin:/bin"}
    proc = subprocess.run([sys.executable, "-c", textwrap.dedent(_TRIALS)], env=env,
                          capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip() == "refused 1000"
