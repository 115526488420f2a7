"""Sensitivity screening before updating.

- Latin hypercube sampling of the parameters within their bounds and the Spearman rank
  correlation of each natural frequency with each parameter (Eq. (10) of [002]):
  ``rho = 1 - 6 sum d_i^2 / (n (n^2 - 1))`` on ranks -- which parameters the measured
  modes can tell apart at all.
- Relative sensitivities ``S_ij = (d f_i / f_i) / (d theta_j / theta_j)`` at the nominal
  point; parameters whose column has a 2-norm below 0.4 % are dropped and the rest are
  clustered by cosine distance < 0.05 (average linkage), as Case III of Sec. 4 of [004].
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.cluster.hierarchy import fcluster, linkage
from scipy.spatial.distance import pdist
from scipy.stats import qmc, spearmanr

from modal_twin._types import FloatArray, IntArray
from modal_twin.errors import OptionError

__all__ = ["ClusterResult", "ScreeningResult", "cluster_parameters", "lhs_spearman"]

FrequencyFn = Callable[[FloatArray], FloatArray]


@dataclass(frozen=True, slots=True)
class ScreeningResult:
    """Spearman rank correlation of frequencies with parameters over an LHS design."""

    names: tuple[str, ...]
    samples: FloatArray  # (n_samples, n_theta)
    f_hz: FloatArray  # (n_samples, n_modes)
    rho: FloatArray  # (n_modes, n_theta), Eq. (10) of [002]

    def influential(self, threshold: float = 0.3) -> tuple[str, ...]:
        """Parameters with |rho| >= threshold for at least one mode."""
        keep = np.nanmax(np.abs(self.rho), axis=0) >= threshold
        return tuple(n for n, k in zip(self.names, keep, strict=True) if k)


@dataclass(frozen=True, slots=True)
class ClusterResult:
    """Parameter groups of Case III of [004]."""

    names: tuple[str, ...]
    S: FloatArray  # (n_modes, n_theta) relative sensitivities
    dropped: tuple[str, ...]  # column 2-norm below the threshold
    labels: IntArray  # cluster label per kept parameter (0 for dropped)

    def groups(self) -> list[tuple[str, ...]]:
        """Kept parameters grouped by cluster."""
        out: dict[int, list[str]] = {}
        for n, lab in zip(self.names, self.labels, strict=True):
            if lab > 0:
                out.setdefault(int(lab), []).append(n)
        return [tuple(v) for _, v in sorted(out.items())]


def _check_bounds(lower: FloatArray, upper: FloatArray, n: int) -> None:
    if lower.shape != (n,) or upper.shape != (n,):
        msg = f"lower, upper: expected ({n},) each, got {lower.shape} and {upper.shape}"
        raise OptionError(msg)
    if not np.all(np.isfinite(lower) & np.isfinite(upper) & (upper > lower)):
        msg = "bounds: expected finite lower < upper for every parameter"
        raise OptionError(msg)


def lhs_spearman(
    frequencies: FrequencyFn,
    names: Sequence[str],
    lower: FloatArray,
    upper: FloatArray,
    *,
    n_samples: int = 60,
    seed: int = 0,
    executor_map: Callable[..., object] = map,
) -> ScreeningResult:
    """Spearman rank correlation (Eq. (10) of [002]) over a Latin hypercube design.

    Parameters
    ----------
    frequencies : callable theta -> (n_modes,) Hz
    executor_map : a ``map``-like callable (``Executor.map`` for a process pool or Dask)
    """
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    _check_bounds(lower, upper, len(names))
    if n_samples < 4:
        msg = f"n_samples: expected >= 4, got {n_samples}"
        raise OptionError(msg)
    X = qmc.scale(qmc.LatinHypercube(d=len(names), seed=seed).random(n_samples), lower, upper)
    F = np.array(list(executor_map(frequencies, X)))  # type: ignore[call-overload]
    rho = np.empty((F.shape[1], len(names)))
    for i in range(F.shape[1]):
        for j in range(len(names)):
            rho[i, j] = spearmanr(X[:, j], F[:, i]).statistic  # Eq. (10) of [002]
    return ScreeningResult(tuple(names), X, F, rho)


def cluster_parameters(
    frequencies: FrequencyFn,
    names: Sequence[str],
    theta0: FloatArray,
    *,
    rel_step: float = 1e-3,
    min_norm: float = 0.004,
    max_cosine: float = 0.05,
) -> ClusterResult:
    """Return the relative sensitivity matrix and the Case III grouping of [004].

    Central differences; drop columns with 2-norm < ``min_norm``, cluster the rest (average
    linkage) at cosine distance ``max_cosine``.
    """
    theta0 = np.asarray(theta0, float)
    f0 = np.asarray(frequencies(theta0))
    S = np.empty((f0.size, theta0.size))
    for j in range(theta0.size):
        h = rel_step * (abs(theta0[j]) or 1.0)
        tp, tm = theta0.copy(), theta0.copy()
        tp[j] += h
        tm[j] -= h
        df = (np.asarray(frequencies(tp)) - np.asarray(frequencies(tm))) / (2 * h)
        S[:, j] = df / f0 * (abs(theta0[j]) or 1.0)
    norm = np.linalg.norm(S, axis=0)
    kept = np.flatnonzero(norm >= min_norm)
    labels = np.zeros(theta0.size, dtype=np.int64)
    if kept.size == 1:
        labels[kept] = 1
    elif kept.size > 1:
        Z = linkage(pdist(S[:, kept].T, metric="cosine"), method="average")
        labels[kept] = fcluster(Z, t=max_cosine, criterion="distance")
    dropped = tuple(n for n, v in zip(names, norm, strict=True) if v < min_norm)
    return ClusterResult(tuple(names), S, dropped, labels)
