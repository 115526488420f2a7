r"""Exact static condensation of the massless DOFs of a parametric model.

A DOF without mass and damping carries no inertia: in ``K phi = omega^2 M phi`` its rows
read ``K_IB phi_B + K_II phi_I = 0``, so ``phi_I = -K_II^-1 K_IB phi_B`` and the
eigenproblem of the remaining ("master") DOFs,

.. math:: (K_{BB} - K_{BI} K_{II}^{-1} K_{IB})\\, \\phi_B = \\omega^2 M_{BB}\\, \\phi_B,

has exactly the same eigenvalues (Guyan reduction is exact when the condensed DOFs are
massless). A finely meshed frame whose members carry no distributed mass (masses lumped at
the joints, as the building of [004]) is mostly such DOFs: its 100,000 DOFs condense to
the few hundred of the joints.

The parametric form ``K(theta) = K0 + sum_i K_i (theta_i - theta_i0)`` (Sec. 4 of [004]) is
kept exactly: the condensed DOFs split into connected groups (the interior nodes of one
member); a group whose stiffness is ``theta_p / theta_p0`` times its nominal value (it
touches only elements of parameter ``p``, or no parameter at all) contributes a Schur
complement that scales the same way, so the condensed matrices stay affine in theta. Any
other group is kept among the masters.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.sparse.csgraph import connected_components

from modal_twin._types import BoolArray, FloatArray, IntArray
from modal_twin.errors import ShapeError
from modal_twin.models.fe.parametric import ParametricMatrices

__all__ = ["Condensation", "condense_massless", "expand_shapes"]


@dataclass(frozen=True, slots=True)
class Condensation:
    """A parametric model condensed to its master DOFs.

    Attributes
    ----------
    par : ParametricMatrices
        Condensed matrices (masters only), affine in theta as the original.
    masters : (n_m,) int array
        Indices of the kept DOFs in the original DOF order.
    n_dof : int
        DOFs of the original model.
    n_groups : int
        Groups of massless DOFs condensed.
    n_kept_mixed : int
        Massless DOFs kept as masters because their group mixes parameters.
    """

    par: ParametricMatrices
    masters: IntArray
    n_dof: int
    n_groups: int
    n_kept_mixed: int


def _massless(par: ParametricMatrices) -> BoolArray:
    """DOFs with no entry in M0, C0 or any mass / damping derivative."""
    mats = [par.M0, par.C0] + [d for d, k in zip(par.derivatives, par.kinds, strict=True)
                               if k != "K"]
    load = np.zeros(par.K0.shape[0])
    for A in mats:
        load += np.asarray(abs(sp.csr_array(A)).sum(axis=1)).ravel()
    return load == 0.0


def _row_param(par: ParametricMatrices, K0: sp.csr_array, dK: list[sp.csr_array | None]
               ) -> IntArray:
    """Per DOF.

    The one parameter whose elements make its whole row of K (``-1``: no parameter), or ``-2``
    where the row mixes parameters or fixed and scaled stiffness.

    Two coupled rows labelled ``p`` and ``q >= -1`` must share the label (K is symmetric),
    so a connected group of labelled rows scales with one parameter.

    """
    n = K0.shape[0]
    touch = np.zeros(n, dtype=np.int64)
    which = np.full(n, -1, dtype=np.int64)
    R = K0.copy()
    for i, d in enumerate(dK):
        if d is None:
            continue
        hit = np.diff(d.indptr) > 0
        touch += hit
        which[hit] = i
        R = R - par.theta0[i] * d
    row_norm = np.sqrt(np.asarray(abs(K0).power(2).sum(axis=1)).ravel())
    rest = np.sqrt(np.asarray(abs(sp.csr_array(R)).power(2).sum(axis=1)).ravel())
    scaled_only = rest <= 1e-9 * np.maximum(row_norm, np.finfo(float).tiny)
    label = np.where(touch == 0, -1, np.where((touch == 1) & scaled_only, which, -2))
    return label


def _schur(K0: sp.csr_array, rows: IntArray, masters: IntArray) -> sp.csr_array:
    """``K_BI K_II^-1 K_IB`` of one set of condensed rows, on the master DOFs."""
    K_IB = K0[rows][:, masters].tocsc()
    cols = np.flatnonzero(np.diff(K_IB.indptr))  # masters coupled to these rows
    lu = spla.splu(sp.csc_matrix(K0[rows][:, rows]))
    X = lu.solve(K_IB[:, cols].toarray())
    S = K_IB[:, cols].T @ X  # K_BI = K_IB' (K symmetric)
    S = 0.5 * (S + S.T)
    n = masters.size
    r, c = np.meshgrid(cols, cols, indexing="ij")
    return sp.csr_array((S.ravel(), (r.ravel(), c.ravel())), shape=(n, n))


def condense_massless(par: ParametricMatrices, keep: IntArray | BoolArray | None = None
                      ) -> Condensation:
    """Condense the massless DOFs of ``par`` exactly (module docstring).

    Parameters
    ----------
    par : ParametricMatrices
    keep : int indices or (n,) bool mask, optional
        DOFs that stay masters whatever their mass (sensors, device ends).

    Returns
    -------
    Condensation

    Raises
    ------
    ShapeError
        ``keep`` of the wrong length or out of range.
    """
    n = par.K0.shape[0]
    keep_mask = np.zeros(n, dtype=bool)
    if keep is not None:
        k = np.asarray(keep)
        if k.dtype == bool:
            if k.shape != (n,):
                msg = f"keep: expected a mask of shape ({n},), got {k.shape}"
                raise ShapeError(msg)
            keep_mask = k.copy()
        else:
            if k.size and (k.min() < 0 or k.max() >= n):
                msg = f"keep: expected DOF indices in [0, {n}), got {k.min()}..{k.max()}"
                raise ShapeError(msg)
            keep_mask[k.astype(np.int64)] = True
    K0 = sp.csr_array(par.K0)
    dK = [sp.csr_array(d) if kind == "K" else None
          for d, kind in zip(par.derivatives, par.kinds, strict=True)]
    label = _row_param(par, K0, dK)
    cand = np.flatnonzero(_massless(par) & ~keep_mask & (label >= -1))
    n_mixed = int(np.count_nonzero(_massless(par) & ~keep_mask & (label == -2)))
    _, comp = connected_components(K0[cand][:, cand] != 0, directed=False)
    groups: dict[int, list[IntArray]] = {}
    for c in np.unique(comp):
        rows = cand[comp == c]
        groups.setdefault(int(label[rows[0]]), []).append(rows)
    cond = np.zeros(n, dtype=bool)
    for rs in groups.values():
        for r in rs:
            cond[r] = True
    masters = np.flatnonzero(~cond)
    Kc = K0[masters][:, masters]
    derivs = [sp.csr_array(d)[masters][:, masters] for d in par.derivatives]
    for p, rs in groups.items():
        S = _schur(K0, np.concatenate(rs), masters)
        Kc = Kc - S
        if p >= 0:
            derivs[p] = derivs[p] - S / par.theta0[p]
    cpar = ParametricMatrices(
        names=par.names, kinds=par.kinds, theta0=par.theta0.copy(), K0=sp.csr_array(Kc),
        M0=sp.csr_array(par.M0)[masters][:, masters],
        C0=sp.csr_array(par.C0)[masters][:, masters],
        derivatives=tuple(sp.csr_array(d) for d in derivs))
    return Condensation(cpar, masters, n, sum(len(r) for r in groups.values()), n_mixed)


def expand_shapes(cond: Condensation, par: ParametricMatrices, Phi_m: FloatArray,
                  theta: FloatArray | None = None) -> FloatArray:
    """Full-model shapes ``phi_I = -K_II^-1 K_IB phi_B`` from the masters' ``Phi_m``."""
    K = par.K(theta)
    n = cond.n_dof
    inner = np.setdiff1d(np.arange(n), cond.masters)
    out = np.zeros((n, Phi_m.shape[1]))
    out[cond.masters] = Phi_m
    if inner.size:
        lu = spla.splu(sp.csc_matrix(K[inner][:, inner]))
        out[inner] = -lu.solve(np.asarray(K[inner][:, cond.masters] @ Phi_m))
    return out
