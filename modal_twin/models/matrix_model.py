"""A model given as matrices by the user's own FE tool: M, K, substructures K_j, C, DOF map.

Conventions of the arrays (a ``.mat`` or ``.npz`` file read by :func:`load_matrix_model`,
the one reader of matrix files, or any mapping of names to arrays):

- mass ``M`` (or ``M0``); stiffness ``K`` (or ``K0``); damping ``C`` (optional);
- substructure stiffnesses ``K_<name>`` (any number; ``K_whole`` is a copy of the total,
  ignored). With substructures the stiffness is parametrised as
  ``K(theta) = K0 + sum_j theta_j K_j`` (``theta = 0`` nominal); when no ``K`` is given,
  ``K0 = sum_j K_j``, i.e. ``K(alpha) = sum_j (1 + alpha_j) K_j`` as in the
  Structural-Model-Updating project;
- ``dofs``: DOF labels (strings such as ``"12:z"``), or ``dof_nodes`` and ``dof_dirs``;
  default ``"0".."n-1"``;
- ``measDOFs`` / ``measured_dofs``: the DOFs of the sensors (``measDOFs`` is MATLAB's
  1-based; ``measured_dofs`` is 0-based);
- ``force_dofs``: 0-based DOFs where a measured point force (a hammer, a shaker) drives
  the structure (optional; a model with force DOFs is driven by those forces, one without
  by uniform base motion: :class:`~modal_twin.models.matrix_factory.MatrixFactory`);
- ``lower`` / ``upper``: bounds of ``theta`` (optional); ``parameter_names``: the order of
  the ``theta_j`` (optional; what :meth:`MatrixModel.to_arrays` writes);
- ``node_xyz``: ``(n_nodes, 4)`` rows of node number, x, y, z in metres (optional: where
  the DOF labels' nodes are, so a test on the model has a geometry); ``trace_nodes``: node
  numbers to join by lines (optional; 0 lifts the pen, as UFF 82).

Any matrix may be stored dense or sparse. Sparse in an NPZ (what ``export model`` and
``update`` write, :func:`sparse_members`): the marker ``sparse_format = "csr"`` and, for a
matrix ``X``, the members ``X__data``, ``X__indices``, ``X__indptr`` and ``X__shape`` of its
CSR form (:class:`scipy.sparse.csr_array`); :func:`read_matrix_arrays` rebuilds them, after
checking that they are one consistent CSR matrix. In a ``.mat``: MATLAB's own sparse class.

Rules of a data set that its file does not hold -- the order of its parameters, their
bounds -- live in a small YAML file beside the user's command (``--rules``;
``config/matrix_models/pedestrian_bridge.yaml`` is the public pedestrian bridge's), never in
the reader: :func:`read_matrix_rules`.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp

from modal_twin._types import FloatArray, IntArray
from modal_twin.errors import ConfigError, ModelError, ShapeError
from modal_twin.validation import LIMITS

__all__ = [
    "MATRIX_SUFFIXES",
    "SPARSE_FORMAT",
    "MatrixModel",
    "MatrixRules",
    "load_matrix_model",
    "matrix_model_from_arrays",
    "read_matrix_arrays",
    "read_matrix_rules",
    "sparse_members",
]

MATRIX_SUFFIXES = (".mat", ".npz")
"""File kinds a matrix model is read from."""
SPARSE_FORMAT = "csr"
"""Value of the NPZ marker ``sparse_format`` (module docstring)."""
_PARTS = ("data", "indices", "indptr", "shape")


@dataclass(frozen=True, slots=True)
class MatrixModel:
    """Matrices of a linear structure and their parametrisation (module docstring).

    Attributes
    ----------
    M, K0 : (n, n) scipy.sparse.csr_array
        Mass and nominal stiffness (``theta = 0``), SI units of the source.
    C : (n, n) csr_array or None
        Damping.
    K_j : tuple of (n, n) csr_array
        ``dK / dtheta_j``.
    names : tuple of str
        Parameter names (the ``<name>`` of ``K_<name>``).
    dofs : tuple of str
        DOF labels, length n.
    measured_dofs : (n_s,) int array
        0-based DOFs of the sensors (empty when the file does not say).
    lower, upper : (p,) float arrays or None
        Bounds of theta when the file gives them.
    source : str
    force_dofs : tuple of int
        0-based DOFs driven by measured point forces (empty: base motion drives it).
    node_xyz : (n_nodes, 4) float array or None
        Node number, x, y, z (m) of the nodes the DOF labels name, when the file gives them.
    trace_nodes : (k,) int array or None
        Node numbers joined by lines to draw the structure (0: a break).
    """

    M: sp.csr_array
    K0: sp.csr_array
    C: sp.csr_array | None
    K_j: tuple[sp.csr_array, ...]
    names: tuple[str, ...]
    dofs: tuple[str, ...]
    measured_dofs: IntArray
    lower: FloatArray | None
    upper: FloatArray | None
    source: str = ""
    force_dofs: tuple[int, ...] = ()
    node_xyz: FloatArray | None = None
    trace_nodes: IntArray | None = None

    @property
    def n_dof(self) -> int:
        """Number of DOFs."""
        return int(self.M.shape[0])

    def K(self, theta: FloatArray) -> sp.csr_array:  # noqa: N802 (matrix symbol)
        """Stiffness at ``theta``: ``K0 + sum_j theta_j K_j``."""
        out = self.K0.copy()
        for t, Kj in zip(np.asarray(theta, dtype=float), self.K_j, strict=True):
            if t:
                out = out + t * Kj
        return sp.csr_array(out)

    def to_arrays(self, theta: FloatArray | None = None) -> dict[str, Any]:
        """Return the named arrays of the model at ``theta``.

        The matrices stay sparse; :func:`sparse_members` makes them NPZ members.
        """
        th = np.zeros(len(self.names)) if theta is None else np.asarray(theta, dtype=float)
        out: dict[str, Any] = {"M": self.M, "K": self.K(th),
                               "dofs": np.array(self.dofs), "theta": th,
                               "parameter_names": np.array(self.names),
                               "measured_dofs": self.measured_dofs}
        if self.C is not None:
            out["C"] = self.C
        if self.force_dofs:
            out["force_dofs"] = np.array(self.force_dofs, dtype=np.int64)
        for n, Kj in zip(self.names, self.K_j, strict=True):
            out[f"K_{n}"] = Kj
        if self.lower is not None and self.upper is not None:
            out["lower"], out["upper"] = self.lower, self.upper
        if self.node_xyz is not None:
            out["node_xyz"] = self.node_xyz
        if self.trace_nodes is not None:
            out["trace_nodes"] = self.trace_nodes
        return out


def _natural(s: str) -> list[Any]:
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", s)]


def _check_dofs(shape: tuple[int, ...], name: str, source: str) -> None:
    """Refuse a matrix declaring more rows or columns than ``LIMITS["n_dof"]`` DOFs.

    A sparse matrix may declare any shape in a few bytes; the modes of its DOFs would
    allocate in proportion (:data:`~modal_twin.validation.LIMITS`).
    """
    hi = int(LIMITS["n_dof"].hi)
    if max(shape, default=0) > hi:
        msg = (f"{source}: {name} declares shape {shape}; expected at most {hi} rows and "
               "columns (LIMITS['n_dof'])")
        raise ConfigError(msg)


def _square(a: Any, name: str, n: int | None, source: str) -> sp.csr_array:
    A = sp.csr_array(a.astype(float)) if sp.issparse(a) else sp.csr_array(
        np.asarray(a, dtype=float))
    if A.ndim != 2 or A.shape[0] != A.shape[1] or (n is not None and A.shape[0] != n):
        want = f"({n}, {n})" if n is not None else "square"
        msg = f"{source}: {name} expected {want}, got {A.shape}"
        raise ShapeError(msg)
    return A


def _dofs(a: Mapping[str, Any], n: int, source: str) -> tuple[str, ...]:
    if "dofs" in a:
        d = tuple(str(v).strip() for v in np.asarray(a["dofs"]).ravel())
    elif "dof_nodes" in a and "dof_dirs" in a:
        d = tuple(f"{int(nn)}:{str(dd).strip()}" for nn, dd in zip(
            np.asarray(a["dof_nodes"]).ravel(), np.asarray(a["dof_dirs"]).ravel(), strict=True))
    else:
        return tuple(str(k) for k in range(n))
    if len(d) != n:
        msg = f"{source}: dofs expected {n} labels, got {len(d)}"
        raise ShapeError(msg)
    return d


def _geometry(a: Mapping[str, Any], source: str) -> tuple[FloatArray | None, IntArray | None]:
    """``node_xyz`` and ``trace_nodes`` of the arrays, checked (module docstring)."""
    xyz = trace = None
    if "node_xyz" in a:
        xyz = np.asarray(a["node_xyz"], dtype=float)
        if (xyz.ndim != 2 or xyz.shape[1] != 4 or not np.all(np.isfinite(xyz))
                or not np.all(xyz[:, 0] == np.round(xyz[:, 0])) or np.any(xyz[:, 0] <= 0)
                or np.unique(xyz[:, 0]).size != xyz.shape[0]):
            msg = (f"{source}: node_xyz expected rows of (node number > 0, x, y, z), finite, "
                   f"distinct nodes; got shape {xyz.shape}")
            raise ShapeError(msg)
    if "trace_nodes" in a:
        trace = np.asarray(a["trace_nodes"]).ravel()
        if trace.dtype.kind not in "iu" or np.any(trace < 0):
            msg = f"{source}: trace_nodes expected node numbers (0: a break), got {trace[:5]}"
            raise ShapeError(msg)
        trace = trace.astype(np.int64)
    return xyz, trace


def matrix_model_from_arrays(a: Mapping[str, Any], source: str = "matrices",
                             order: tuple[str, ...] | None = None) -> MatrixModel:
    """Build a :class:`MatrixModel` from named arrays (module docstring).

    Parameters
    ----------
    order : tuple of str, optional
        Order of the substructure names (default: ``parameter_names`` when the arrays
        name every ``K_`` matrix, else natural sort of the ``K_`` names).

    Raises
    ------
    ModelError
        No mass matrix, or neither a stiffness nor substructures.
    ShapeError
        Matrices of different sizes, bad DOF labels or measured DOFs out of range.
    """
    mkey = next((k for k in ("M", "M0") if k in a), None)
    if mkey is None:
        msg = f"{source}: expected a mass matrix 'M' or 'M0', found {sorted(a)}"
        raise ModelError(msg)
    _check_dofs(tuple(np.shape(a[mkey])), mkey, source)  # .npz members checked on reading
    M = _square(a[mkey], mkey, None, source)
    n = M.shape[0]
    subs = [k[2:] for k in a if k.startswith("K_") and k not in ("K_whole", "K_j")]
    written = ([str(v).strip() for v in np.asarray(a["parameter_names"]).ravel()]
               if "parameter_names" in a else [])
    if order is None and written and sorted(written) == sorted(subs):
        order = tuple(written)  # the order the file was written in (to_arrays)
    if order is not None and sorted(order) != sorted(subs):
        msg = (f"{source}: expected the parameters {list(order)} as substructures K_<name>, "
               f"got {sorted(subs, key=_natural)}")
        raise ShapeError(msg)
    names = tuple(order) if order is not None else tuple(sorted(subs, key=_natural))
    K_j = tuple(_square(a[f"K_{s}"], f"K_{s}", n, source) for s in names)
    kkey = next((k for k in ("K", "K0") if k in a), None)
    if kkey is None and not K_j:
        msg = f"{source}: expected a stiffness 'K' / 'K0' or substructures 'K_<name>'"
        raise ModelError(msg)
    K0 = (_square(a[kkey], kkey, n, source) if kkey is not None
          else sp.csr_array(sum(K_j[1:], K_j[0])))
    C = _square(a["C"], "C", n, source) if "C" in a else None
    if "measured_dofs" in a:
        meas = np.asarray(a["measured_dofs"], dtype=np.int64).ravel()
    elif "measDOFs" in a:
        meas = np.asarray(a["measDOFs"], dtype=np.int64).ravel() - 1  # MATLAB 1-based
    else:
        meas = np.zeros(0, np.int64)
    if meas.size and (meas.min() < 0 or meas.max() >= n):
        msg = f"{source}: measured DOFs expected in [0, {n}), got [{meas.min()}, {meas.max()}]"
        raise ShapeError(msg)
    force = np.asarray(a.get("force_dofs", np.zeros(0)), dtype=np.int64).ravel()
    if force.size and (force.min() < 0 or force.max() >= n or np.unique(force).size
                       != force.size):
        msg = f"{source}: force_dofs expected distinct DOFs in [0, {n}), got {force.tolist()}"
        raise ShapeError(msg)
    lo = np.asarray(a["lower"], dtype=float).ravel() if "lower" in a else None
    hi = np.asarray(a["upper"], dtype=float).ravel() if "upper" in a else None
    xyz, trace = _geometry(a, source)
    return MatrixModel(M, K0, C, K_j, names, _dofs(a, n, source), meas, lo, hi, source,
                       tuple(int(i) for i in force), xyz, trace)


def sparse_members(arrays: Mapping[str, Any]) -> dict[str, Any]:
    """Return ``arrays`` as NPZ members: each scipy.sparse matrix as its CSR parts.

    (``X__data``, ``X__indices``, ``X__indptr``, ``X__shape`` and the marker
    ``sparse_format``; module docstring.) Other arrays are kept as they are.
    """
    out: dict[str, Any] = {}
    for k, v in arrays.items():
        if sp.issparse(v):
            A = sp.csr_array(v)
            A.sum_duplicates()
            out.update({f"{k}__data": A.data, f"{k}__indices": A.indices,
                        f"{k}__indptr": A.indptr, f"{k}__shape": np.array(A.shape, np.int64)})
            out["sparse_format"] = np.array(SPARSE_FORMAT)
        else:
            out[k] = v
    return out


def _from_members(a: dict[str, Any], source: str) -> dict[str, Any]:
    """Rebuild the sparse matrices of NPZ members (:func:`sparse_members`), checked."""
    names = sorted({k.rsplit("__", 1)[0] for k in a if k.rsplit("__", 1)[-1] in _PARTS
                    and "__" in k})
    if not names:
        return a
    marker = str(np.asarray(a.get("sparse_format", "")))
    if marker != SPARSE_FORMAT:
        msg = (f"{source}: sparse members {names[:4]} without the marker sparse_format = "
               f"{SPARSE_FORMAT!r} (got {marker!r})")
        raise ConfigError(msg)
    out = {k: v for k, v in a.items() if k != "sparse_format" and not (
        "__" in k and k.rsplit("__", 1)[-1] in _PARTS)}
    for n in names:
        missing = [q for q in _PARTS if f"{n}__{q}" not in a]
        if missing:
            msg = f"{source}: sparse matrix {n!r} lacks its member(s) {missing}"
            raise ConfigError(msg)
        data, ind, ptr, shape = (np.asarray(a[f"{n}__{q}"]) for q in _PARTS)
        ok = (shape.shape == (2,) and shape.dtype.kind in "iu" and int(shape.min()) >= 0
              and data.ndim == ind.ndim == ptr.ndim == 1 and data.size == ind.size
              and ptr.size == int(shape[0]) + 1 and ind.dtype.kind in "iu"
              and ptr.dtype.kind in "iu" and data.dtype.kind in "fiu")
        if not ok:
            msg = (f"{source}: sparse matrix {n!r}: members of inconsistent sizes (data "
                   f"{data.shape}, indices {ind.shape}, indptr {ptr.shape}, shape "
                   f"{shape.tolist()}); expected a CSR matrix")
            raise ConfigError(msg)
        _check_dofs(tuple(int(s) for s in shape), f"sparse matrix {n!r}", source)
        try:
            A = sp.csr_array((data.astype(float), ind, ptr), shape=(int(shape[0]),
                                                                    int(shape[1])))
            A.check_format(full_check=True)
        except ValueError as err:
            msg = f"{source}: sparse matrix {n!r} is not a valid CSR matrix ({err})"
            raise ConfigError(msg) from err
        out[n] = A
    return out


def read_matrix_arrays(path: str | Path) -> dict[str, Any]:
    """Return the named arrays of a ``.mat`` (MATLAB 4 to 7.3) or ``.npz`` file.

    Refused before loading when they would unpack to more than
    :data:`~modal_twin.validation.FILE_UNPACKED_MAX_BYTES` (:mod:`modal_twin.models.array_files`;
    a sparse matrix counts by its members). Sparse NPZ members come back as
    :class:`scipy.sparse.csr_array` (module docstring).

    Raises
    ------
    ConfigError
        Another kind of file, one that does not read, one too large unpacked, or sparse
        members that are not one consistent CSR matrix.
    """
    from modal_twin.models.array_files import mat_arrays, npz_arrays

    p = Path(path)
    if p.suffix.lower() == ".npz":
        return _from_members(npz_arrays(p), str(p))
    if p.suffix.lower() == ".mat":
        return mat_arrays(p)
    msg = f"{p}: expected a .mat or .npz matrix file, got {p.suffix!r}"
    raise ConfigError(msg)


@dataclass(frozen=True, slots=True)
class MatrixRules:
    """Rules of a matrix data set its file does not hold (module docstring).

    Attributes
    ----------
    parameters : tuple of str
        Order of the substructure factors ``theta_j`` (the ``<name>`` of ``K_<name>``).
    lower, upper : (p,) float arrays or None
        Their bounds.
    source : str
    """

    parameters: tuple[str, ...]
    lower: FloatArray | None
    upper: FloatArray | None
    source: str = ""


def read_matrix_rules(path: str | Path) -> MatrixRules:
    """Read a rules file: ``parameters`` (names, in order), ``lower`` and ``upper`` (optional).

    Raises
    ------
    ConfigError
        Unreadable YAML, unknown keys, no parameter names, bounds of another length or with
        ``lower >= upper``.
    """
    from modal_twin.yaml_files import read_yaml

    doc = read_yaml(path, "matrix rules file")
    src = str(path)
    bad = sorted(set(doc) - {"parameters", "lower", "upper"})
    if bad:
        msg = f"{src}: unknown keys {bad}; valid: ['parameters', 'lower', 'upper']"
        raise ConfigError(msg)
    names = doc.get("parameters")
    if not isinstance(names, list) or not names or len(set(map(str, names))) != len(names):
        msg = f"{src}: parameters: expected a list of distinct names, got {names!r}"
        raise ConfigError(msg)
    if ("lower" in doc) != ("upper" in doc):
        msg = f"{src}: expected both lower and upper, or neither"
        raise ConfigError(msg)
    bounds = []
    for key in ("lower", "upper"):
        if key not in doc:
            continue
        try:
            v = np.asarray(doc[key], dtype=float).ravel()
        except (TypeError, ValueError) as err:
            msg = f"{src}: {key}: expected {len(names)} numbers, got {doc[key]!r}"
            raise ConfigError(msg) from err
        if v.size != len(names) or not np.all(np.isfinite(v)):
            msg = f"{src}: {key}: expected {len(names)} finite numbers, got {v.size}"
            raise ConfigError(msg)
        bounds.append(v)
    lo, hi = (bounds[0], bounds[1]) if bounds else (None, None)
    if lo is not None and hi is not None and not np.all(lo < hi):
        msg = f"{src}: expected lower < upper for every parameter"
        raise ConfigError(msg)
    return MatrixRules(tuple(str(n) for n in names), lo, hi, src)


def load_matrix_model(path: str | Path, *, rules: str | Path | MatrixRules | None = None
                      ) -> MatrixModel:
    """Read a ``.mat`` / ``.npz`` matrix model or a frame file: the one reader of matrix files.

    A frame file (``kind: frame``, :mod:`modal_twin.models.frame_file`) gives the arrays of
    its nominal frame.

    ``rules`` (a file, :func:`read_matrix_rules`) give the parameters' order and bounds a
    data set's file does not hold; its bounds replace any the file has.

    Raises
    ------
    ConfigError
        Not a readable ``.mat`` / ``.npz`` file; a bad rules file.
    ModelError, ShapeError
        See :func:`matrix_model_from_arrays`; rules naming other parameters than the file's.
    """
    from dataclasses import replace

    from modal_twin.models.frame_file import frame_arrays, is_frame_file

    arrays = frame_arrays(path) if is_frame_file(path) else read_matrix_arrays(path)
    r = rules if isinstance(rules, MatrixRules) or rules is None else read_matrix_rules(rules)
    mm = matrix_model_from_arrays(arrays, str(path), r.parameters if r is not None else None)
    if r is not None and r.lower is not None and r.upper is not None:
        mm = replace(mm, lower=r.lower.copy(), upper=r.upper.copy())
    return mm
