"""Result records of the updating stage (frozen, slotted dataclasses)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modal_twin._types import FloatArray
from modal_twin.updating.matching import ModePairing
from modal_twin.updating.uncertainty import ParameterUncertainty

__all__ = ["UpdateResult"]


@dataclass(frozen=True, slots=True)
class UpdateResult:
    """Outcome of one updating run (global search and / or gradient refinement).

    Attributes
    ----------
    names : tuple of str
        Updated parameters.
    theta_start, theta : (p,) float arrays
        Values before and after, parameter units.
    lower, upper : (p,) float arrays
        Bounds used.
    f_id : (m,) float array
        Identified frequencies, Hz.
    pairing_before, pairing_after : ModePairing
        Mode pairs at the start and at the estimate (``df_rel``, ``mac`` per mode).
    cost_before, cost_after : float
        Eq. (3) of [004] (penalised, :meth:`UpdatingProblem.cost`).
    n_eigen_solves : int
        Eigen-solutions computed (global search and refinement).
    n_global_evals : int
        Cost evaluations of the global search (0 when skipped).
    seconds : float
        Wall time.
    converged : bool
        The refinement reported convergence (or the global search did, if alone).
    message : str
    at_bounds : tuple of str
        Parameters within 0.1 % of the bound range of a bound.
    uncertainty : ParameterUncertainty or None
        Covariance from the Jacobian and the identification (None: no standard deviations).
    """

    names: tuple[str, ...]
    theta_start: FloatArray
    theta: FloatArray
    lower: FloatArray
    upper: FloatArray
    f_id: FloatArray
    pairing_before: ModePairing
    pairing_after: ModePairing
    cost_before: float
    cost_after: float
    n_eigen_solves: int
    n_global_evals: int
    seconds: float
    converged: bool
    message: str
    at_bounds: tuple[str, ...]
    uncertainty: ParameterUncertainty | None

    @property
    def max_abs_df_pct(self) -> float:
        """Largest ``|f_fem / f_id - 1|`` after updating, percent (NaN-safe)."""
        return float(100.0 * np.nanmax(np.abs(self.pairing_after.df_rel)))

    @property
    def min_mac(self) -> float:
        """Smallest MAC of the matched pairs after updating."""
        return float(np.nanmin(self.pairing_after.mac))

    def as_dict(self) -> dict[str, object]:
        """Plain-Python summary (for a report or JSON)."""
        return {
            "names": list(self.names),
            "theta_start": self.theta_start.tolist(),
            "theta": self.theta.tolist(),
            "f_id_hz": self.f_id.tolist(),
            "fem_index_after": self.pairing_after.fem_index.tolist(),
            "df_pct_before": (100 * self.pairing_before.df_rel).tolist(),
            "df_pct_after": (100 * self.pairing_after.df_rel).tolist(),
            "mac_before": self.pairing_before.mac.tolist(),
            "mac_after": self.pairing_after.mac.tolist(),
            "cost_before": self.cost_before, "cost_after": self.cost_after,
            "n_eigen_solves": self.n_eigen_solves, "seconds": self.seconds,
            "converged": self.converged, "at_bounds": list(self.at_bounds),
            "std": None if self.uncertainty is None else self.uncertainty.std.tolist(),
            "determined": None if self.uncertainty is None
            else self.uncertainty.determined.tolist(),
        }
