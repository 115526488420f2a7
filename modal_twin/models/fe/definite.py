"""Checks of stiffness and mass matrices built from trial parameters, before any factorisation.

A parameter trial (an updating step, a ``/model/parameters`` message, a diagnosis fit) can
give a stiffness with zero, negative, infinite or NaN entries. SuperLU with diagonal
pivoting (``diag_pivot_thresh = 0``) has crashed the process on such matrices (empty
columns), so nothing here calls it: the entries are checked first (finite, no DOF without
stiffness or mass), then ``K`` is factorised as ``P K P' = (I + L) D (I + L)'`` by QDLDL
(the LDL' of OSQP: a fixed elimination tree, no pivoting that depends on the values, a
zero pivot reported as an error), and Sylvester's criterion is read off ``D``.
"""

from __future__ import annotations

from typing import TypeAlias

import numpy as np
import qdldl
import scipy.sparse as sp

from modal_twin._types import FloatArray, IntArray
from modal_twin.errors import ModelError

__all__ = ["check_entries", "ldl_factor", "positive_definite", "require_positive_definite"]

Matrix: TypeAlias = sp.sparray | sp.spmatrix | FloatArray


def _csc(A: Matrix) -> sp.csc_matrix:
    return sp.csc_matrix(A, dtype=float)


def _bad_entry(name: str, Ac: sp.csc_matrix, positive_diagonal: bool) -> tuple[int, str] | None:
    """Return (DOF, message) of the first non-finite entry or bad diagonal entry, or None."""
    bad = ~np.isfinite(Ac.data)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        col = int(np.searchsorted(Ac.indptr, k, side="right") - 1)
        return col, (f"{name}: expected finite entries, got {float(Ac.data[k])!r} at "
                     f"DOF ({int(Ac.indices[k])}, {col})")
    d = Ac.diagonal()
    wrong = ~(d > 0.0) if positive_diagonal else d < 0.0
    if wrong.any():
        j = int(np.flatnonzero(wrong)[0])
        if positive_diagonal:
            return j, (f"{name}: expected positive definite (every diagonal entry > 0), got "
                       f"{d[j]:.6g} at DOF {j} (no stiffness there, or negative)")
        return j, f"{name}: expected a diagonal >= 0, got {d[j]:.6g} at DOF {j}"
    return None


def check_entries(name: str, A: Matrix, *, positive_diagonal: bool) -> None:
    """Refuse a square matrix with non-finite entries or a bad diagonal, naming the DOF.

    Parameters
    ----------
    name : str
        Matrix name for the message (``"K"``, ``"M"``, ``"K - sigma M"``).
    A : (n, n) sparse or dense array
    positive_diagonal : bool
        True: every diagonal entry must be > 0 (no DOF left without stiffness, hence no
        empty row or column); False: >= 0 (a mass that may be semi-definite).

    Raises
    ------
    ModelError
        With the first offending DOF index and its value.
    """
    Ac = _csc(A)
    if Ac.shape[0] != Ac.shape[1]:
        msg = f"{name}: expected a square matrix, got shape {Ac.shape}"
        raise ModelError(msg)
    found = _bad_entry(name, Ac, positive_diagonal)
    if found is not None:
        raise ModelError(found[1])


def ldl_factor(A: Matrix) -> tuple[qdldl.Solver, FloatArray, IntArray] | None:
    """Factorise a symmetric ``A`` as ``P A P' = (I + L) D (I + L)'``: (solver, D, DOF of each).

    ``A`` must have passed :func:`check_entries` (finite, nonzero diagonal). None when
    QDLDL meets an exactly zero pivot (``A`` singular or indefinite). ``solver.solve(b)``
    solves ``A x = b``.
    """
    try:
        solver = qdldl.Solver(_csc(A))
        _, d, perm = solver.factors()
    except (RuntimeError, ValueError):  # zero pivot: not quasi-definite
        return None
    return solver, np.asarray(d, dtype=float), np.asarray(perm, dtype=np.int64)


def positive_definite(K: Matrix, rtol: float = 1e-13) -> tuple[bool, int]:
    """Positive-definiteness test of a symmetric K: (ok, index of a bad DOF, -1 if ok).

    Checks the entries first (:func:`check_entries`: a non-finite entry or a diagonal
    entry <= 0 is the bad DOF), then factorises ``P K P' = (I + L) D (I + L)'`` (QDLDL,
    AMD ordering) and applies Sylvester's criterion: ``K`` is positive definite iff every
    ``D_jj > 0``. Pivots below ``rtol`` times the largest diagonal entry count as zero (a
    mechanism). Never crashes the process on singular, indefinite or non-finite input.
    """
    Kc = _csc(K)
    n = Kc.shape[0]
    if n == 0:
        return True, -1
    found = _bad_entry("K", Kc, positive_diagonal=True)
    if found is not None:
        return False, found[0]
    scale = float(Kc.diagonal().max())
    ldl = ldl_factor(Kc)
    if ldl is None:
        return False, int(np.argmin(Kc.diagonal()))
    _, d, perm = ldl
    bad = np.flatnonzero(~(d > rtol * scale))
    if bad.size == 0:
        return True, -1
    return False, int(perm[bad[0]])


def require_positive_definite(name: str, K: Matrix, rtol: float = 1e-13) -> None:
    """Raise :class:`ModelError` naming the DOF where ``K`` fails :func:`positive_definite`."""
    check_entries(name, K, positive_diagonal=True)
    ok, j = positive_definite(K, rtol)
    if not ok:
        msg = (f"{name}: expected positive definite, got a non-positive LDL' pivot at DOF {j} "
               "(a modulus or stiffness <= 0, or a mechanism)")
        raise ModelError(msg)
