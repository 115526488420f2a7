"""FE model updating: mode matching, objectives, sensitivities, optimizers, stages, uncertainty."""

from __future__ import annotations

from modal_twin.updating.device_ls import DeviceKC, device_kc, fit_devices, kc_bounds, kc_nominal
from modal_twin.updating.matching import ModePairing, match_modes, pair_costs
from modal_twin.updating.objectives import (
    close_match,
    frequencies_converged,
    frequency_figure_of_merit,
    frequency_mac_damping_cost,
    relaxed_cost,
    weighted_frequency_mac_cost,
)
from modal_twin.updating.optimize import global_search, multi_start, refine, update
from modal_twin.updating.problem import PENALTY, ModeTargets, UpdatingProblem, real_shapes
from modal_twin.updating.reduced_basis import reduced_problem
from modal_twin.updating.results import UpdateResult
from modal_twin.updating.screening import (
    ClusterResult,
    ScreeningResult,
    cluster_parameters,
    lhs_spearman,
)
from modal_twin.updating.sensitivity import EigenDerivatives, eigen_derivatives
from modal_twin.updating.stages import Stage, StagedResult, building_stages, staged_update
from modal_twin.updating.uncertainty import ParameterUncertainty, parameter_covariance

__all__ = [
    "PENALTY",
    "ClusterResult",
    "DeviceKC",
    "EigenDerivatives",
    "ModePairing",
    "ModeTargets",
    "ParameterUncertainty",
    "ScreeningResult",
    "Stage",
    "StagedResult",
    "UpdateResult",
    "UpdatingProblem",
    "building_stages",
    "close_match",
    "cluster_parameters",
    "device_kc",
    "eigen_derivatives",
    "fit_devices",
    "frequencies_converged",
    "frequency_figure_of_merit",
    "frequency_mac_damping_cost",
    "global_search",
    "kc_bounds",
    "kc_nominal",
    "lhs_spearman",
    "match_modes",
    "multi_start",
    "pair_costs",
    "parameter_covariance",
    "real_shapes",
    "reduced_problem",
    "refine",
    "relaxed_cost",
    "staged_update",
    "update",
    "weighted_frequency_mac_cost",
]
