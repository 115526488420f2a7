"""Parametric system matrices ``K(theta) = K0 + sum_i K_i (theta_i - theta_i0)`` (Sec. 4 of [004]).

Each named parameter ``theta_i`` enters exactly one of the stiffness, mass or damping
matrices, linearly (an elastic modulus, a density, a spring rate, a lumped mass, a dashpot
rate), so ``K_i = dK/dtheta_i`` is exact and constant. The updating stage calls
:meth:`ParametricMatrices.K` and :meth:`ParametricMatrices.dK` (and the ``M`` / ``C`` twins).

References
----------
[004] Base-isolated E-Defense building, Sec. 4: ``K = K0 + sum_i K_i (theta_i - theta_i^nominal)``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.sparse as sp

from modal_twin._types import FloatArray
from modal_twin.errors import OptionError, ShapeError

__all__ = ["ParametricMatrices"]

Kind = Literal["K", "M", "C"]


@dataclass(frozen=True, slots=True)
class ParametricMatrices:
    """Nominal matrices and exact parameter derivatives, in the assembly's reduced DOFs.

    Attributes
    ----------
    names : tuple of str
        Parameter names, in order of first use.
    kinds : tuple of {"K", "M", "C"}
        Which matrix each parameter enters.
    theta0 : (n_theta,) float array
        Nominal values (SI units of the parameter: Pa, kg/m^3, N/m, kg, N s/m).
    K0, M0, C0 : (n, n) scipy.sparse.csr_array
        Nominal stiffness, mass and damping.
    derivatives : tuple of (n, n) scipy.sparse.csr_array
        ``d(matrix of kinds[i]) / d theta_i``.
    """

    names: tuple[str, ...]
    kinds: tuple[Kind, ...]
    theta0: FloatArray
    K0: sp.csr_array
    M0: sp.csr_array
    C0: sp.csr_array
    derivatives: tuple[sp.csr_array, ...]

    @property
    def n_theta(self) -> int:
        """Number of parameters."""
        return len(self.names)

    def index(self, name: str | int) -> int:
        """Return the position of parameter ``name`` (a name or an index)."""
        if isinstance(name, int | np.integer) and not isinstance(name, bool):
            if not 0 <= int(name) < self.n_theta:
                msg = f"parameter index: expected 0 <= i < {self.n_theta}, got {name}"
                raise OptionError(msg)
            return int(name)
        try:
            return self.names.index(name)
        except ValueError:
            msg = f"parameter: expected one of {list(self.names)}, got {name!r}"
            raise OptionError(msg) from None

    def theta_vector(self, theta: Mapping[str, float] | Sequence[float] | FloatArray | None
                     ) -> FloatArray:
        """Return the full parameter vector: an array as is, a mapping over ``theta0``."""
        if theta is None:
            return self.theta0.copy()
        if isinstance(theta, Mapping):
            out = self.theta0.copy()
            for name, val in theta.items():
                out[self.index(name)] = float(val)
            return out
        arr = np.asarray(theta, dtype=float)
        if arr.shape != (self.n_theta,):
            msg = f"theta: expected shape ({self.n_theta},), got {arr.shape}"
            raise ShapeError(msg)
        return arr

    def _matrix(self, kind: Kind, theta: Mapping[str, float] | Sequence[float] | FloatArray
                | None) -> sp.csr_array:
        base = {"K": self.K0, "M": self.M0, "C": self.C0}[kind]
        th = self.theta_vector(theta)
        out = base.copy()
        for i, d in enumerate(th - self.theta0):
            if self.kinds[i] == kind and d != 0.0:
                out = out + d * self.derivatives[i]  # Sec. 4 of [004]
        return sp.csr_array(out)

    def _derivative(self, kind: Kind, i: str | int) -> sp.csr_array:
        j = self.index(i)
        if self.kinds[j] != kind:
            return sp.csr_array(self.K0.shape, dtype=float)
        return self.derivatives[j]

    def K(  # noqa: N802 (matrix symbol)
        self, theta: Mapping[str, float] | Sequence[float] | FloatArray | None = None
    ) -> sp.csr_array:
        """Return ``K(theta) = K0 + sum_i K_i (theta_i - theta_i0)`` (Sec. 4 of [004])."""
        return self._matrix("K", theta)

    def M(  # noqa: N802 (matrix symbol)
        self, theta: Mapping[str, float] | Sequence[float] | FloatArray | None = None
    ) -> sp.csr_array:
        """Return ``M(theta)``, linear in the mass parameters."""
        return self._matrix("M", theta)

    def C(  # noqa: N802 (matrix symbol)
        self, theta: Mapping[str, float] | Sequence[float] | FloatArray | None = None
    ) -> sp.csr_array:
        """Return ``C(theta)``, linear in the damping parameters."""
        return self._matrix("C", theta)

    def dK(self, i: str | int) -> sp.csr_array:  # noqa: N802 (matrix symbol)
        """Return ``dK/dtheta_i`` (zero matrix for a mass or damping parameter)."""
        return self._derivative("K", i)

    def dM(self, i: str | int) -> sp.csr_array:  # noqa: N802 (matrix symbol)
        """Return ``dM/dtheta_i`` (zero matrix for a stiffness or damping parameter)."""
        return self._derivative("M", i)

    def dC(self, i: str | int) -> sp.csr_array:  # noqa: N802 (matrix symbol)
        """Return ``dC/dtheta_i`` (zero matrix for a stiffness or mass parameter)."""
        return self._derivative("C", i)
