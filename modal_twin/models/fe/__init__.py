"""Sparse 3D finite elements: frames, springs, masses, rigid links, parametric matrices, modes."""

from __future__ import annotations

from modal_twin.models.fe.assembly import FEAssembly, assemble_model
from modal_twin.models.fe.eigen import (
    ModalSolution,
    count_eigenvalues_below,
    default_shift,
    lowest_eigenpairs,
    solve_modes,
)
from modal_twin.models.fe.elements import (
    DOF_NAMES,
    frame_local_matrices,
    frame_rotation,
    frame_shear_factors,
    two_node_matrix,
)
from modal_twin.models.fe.model import (
    Contribution,
    FEModel,
    NodeId,
    rigid_body_mass_block,
    skew,
)
from modal_twin.models.fe.parametric import ParametricMatrices

__all__ = [
    "DOF_NAMES",
    "Contribution",
    "FEAssembly",
    "FEModel",
    "ModalSolution",
    "NodeId",
    "ParametricMatrices",
    "assemble_model",
    "count_eigenvalues_below",
    "default_shift",
    "frame_local_matrices",
    "frame_rotation",
    "frame_shear_factors",
    "lowest_eigenpairs",
    "rigid_body_mass_block",
    "skew",
    "solve_modes",
    "two_node_matrix",
]
