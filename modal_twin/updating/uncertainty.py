"""Parameter covariance from the residual Jacobian and the identification uncertainty.

With residuals ``r(theta)`` whose entries have standard deviations ``sigma`` (from the
identification: frequency and shape standard deviations), the linearised estimate has::

    Cov(theta) = (J' W J)^-1,   W = diag(1 / sigma^2)

(the Gauss-Newton covariance, as in Eqs. (13)-(17) of [003] for its least squares).
Entries with unknown ``sigma`` (``inf``) carry no information. The bounds enter as a weak
prior (a uniform distribution over ``[lower, upper]``, variance ``range^2 / 12``), so
``Cov = (J' W J + P^-1)^-1``: a direction the data do not inform keeps the prior spread
instead of being silently dropped by a pseudo-inverse -- the honest answer to "which
parameters can the data fix". A parameter is *determined* when its standard deviation is
below ``fraction`` of its bound range (the prior alone gives 0.29).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from modal_twin._types import BoolArray, FloatArray
from modal_twin.errors import ShapeError

__all__ = ["ParameterUncertainty", "parameter_covariance"]


@dataclass(frozen=True, slots=True)
class ParameterUncertainty:
    """Linearised parameter uncertainty.

    Attributes
    ----------
    names : tuple of str
    cov : (p, p) float array
        Covariance (parameter units squared); ``inf`` on undetermined directions.
    std : (p,) float array
        Standard deviations.
    corr : (p, p) float array
        Correlation matrix (NaN where a std is infinite).
    fisher_eigenvalues : (p,) float array
        Eigenvalues of ``J' W J`` (descending): the information along each direction.
    determined : (p,) bool array
        ``std < fraction * (upper - lower)``.
    fraction : float
    """

    names: tuple[str, ...]
    cov: FloatArray
    std: FloatArray
    corr: FloatArray
    fisher_eigenvalues: FloatArray
    determined: BoolArray
    fraction: float

    def summary(self) -> dict[str, dict[str, float | bool]]:
        """Return ``{name: {"std": ..., "determined": ...}}``."""
        return {n: {"std": float(s), "determined": bool(d)}
                for n, s, d in zip(self.names, self.std, self.determined, strict=True)}


def parameter_covariance(
    J: FloatArray, sigma: FloatArray, *, names: Sequence[str], lower: FloatArray,
    upper: FloatArray, fraction: float = 0.1,
) -> ParameterUncertainty:
    """Return the covariance of the parameters (module docstring).

    Parameters
    ----------
    J : (n_res, p) float array
        ``d r / d theta`` at the estimate.
    sigma : (n_res,) float array
        Standard deviation of each residual (``inf``: unknown, no information).
    names : sequence of str
    lower, upper : (p,) float arrays
        Bounds, for the "determined" test.
    fraction : float
        A parameter is determined when ``std < fraction * (upper - lower)``.

    Raises
    ------
    ShapeError
        Inconsistent sizes.

    Examples
    --------
    >>> u = parameter_covariance(np.array([[2.0, 0.0]]), np.array([0.1]), names=["a", "b"],
    ...                          lower=np.zeros(2), upper=np.ones(2))
    >>> round(float(u.std[0]), 3), bool(u.determined[1])
    (0.049, False)
    """
    J = np.asarray(J, dtype=float)
    s = np.asarray(sigma, dtype=float).ravel()
    if J.ndim != 2 or J.shape[0] != s.size or len(names) != J.shape[1]:
        msg = (f"J, sigma, names: expected (n_res, p), (n_res,), p names; got {J.shape}, "
               f"{s.shape}, {len(names)}")
        raise ShapeError(msg)
    w = np.where(np.isfinite(s) & (s > 0), 1.0 / np.where(s > 0, s, 1.0), 0.0)
    Jw = J * w[:, None]
    F = Jw.T @ Jw
    rng = np.asarray(upper, dtype=float) - np.asarray(lower, dtype=float)
    prior = rng / np.sqrt(12.0)  # uniform prior over the bounds: the "no information" level
    ev = np.sort(np.linalg.eigvalsh(F))[::-1]
    Fs = prior[:, None] * F * prior[None, :]  # information scaled by the prior
    # (J' W J + P^-1)^-1 through the eigenvectors of the symmetric Fs (eigenvalues of
    # Fs + I are >= 1: no loss of precision when the data are far more informative than
    # the bounds along some directions, where a plain inverse can return negative variances)
    ev_s, V = np.linalg.eigh(0.5 * (Fs + Fs.T))
    inv = (V / (1.0 + np.maximum(ev_s, 0.0))) @ V.T
    cov = prior[:, None] * inv * prior[None, :]
    std = np.sqrt(np.diag(cov))
    corr = cov / np.outer(std, std)
    return ParameterUncertainty(
        names=tuple(names), cov=cov, std=std, corr=corr, fisher_eigenvalues=ev,
        determined=std < fraction * rng, fraction=float(fraction))
