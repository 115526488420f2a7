"""Readers of MATLAB ``.mat`` files: the pedestrian-bridge updating data set.

The public Structural-Model-Updating project (GPL-3.0) publishes a 946-DOF FE model of a
steel-frame, concrete-deck pedestrian bridge with 17 stiffness substructures
``K(alpha) = K0 + sum_j alpha_j K_j`` (``K_Frame``, ``K_Truss``, ``K_Conc1..11`` and the
support springs ``K_y1, K_z1, K_y2, K_z2``), a singular mass ``M0`` (massless DOFs), the
58 measured DOFs and five modes identified from ambient tests (eigenvalues
``(2 pi f)^2`` with standard deviations, shapes with standard deviations), plus the
project's own results (100 multi-start ``fmincon`` runs). The files are read from
``/work/shared/realdata/model_updating`` (or a folder given); they are never copied. The
data set's parameter order and bounds are not in this reader: they are the rules file
``config/matrix_models/pedestrian_bridge.yaml`` (:data:`BRIDGE_RULES`,
:func:`modal_twin.models.matrix_model.read_matrix_rules`). Any other matrix file is read by
:func:`modal_twin.models.matrix_model.load_matrix_model`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from modal_twin._types import FloatArray, IntArray
from modal_twin.errors import ConfigError
from modal_twin.models.array_files import mat_arrays
from modal_twin.models.matrix_model import read_matrix_rules

__all__ = [
    "BRIDGE_DIR",
    "BRIDGE_RULES",
    "BridgeData",
    "BridgePublished",
    "load_bridge",
    "load_bridge_published",
]

BRIDGE_DIR = Path("/work/shared/realdata/model_updating")
_PREFIX = "SteelPedestrianBridge__"
_MODEL = _PREFIX + "Experiment__Experiment_Model_Updating__SteelPedestrianBridgeExp.mat"
_MODES = _PREFIX + "Experiment__Experiment_Model_Updating__ExpModeInfo_FEM.mat"
BRIDGE_RULES = (Path(__file__).resolve().parents[2] / "config" / "matrix_models"
                / "pedestrian_bridge.yaml")
"""Order of the 17 parameters alpha_j (the project's ``structModel.K_j``) and its bounds."""


@dataclass(frozen=True, slots=True)
class BridgeData:
    """The pedestrian bridge model and its identified modes.

    Attributes
    ----------
    M : (946, 946) scipy.sparse.csr_array
        Mass (kg units of the source; singular).
    K0 : (946, 946) scipy.sparse.csr_array
        Nominal stiffness (``alpha = 0``).
    K_j : tuple of 17 (946, 946) scipy.sparse.csr_array
        ``dK / d alpha_j``.
    names : tuple of str
        Substructure names, in the order of :data:`BRIDGE_RULES`.
    lower, upper : (17,) float arrays
        The project's bounds on ``alpha`` (-0.1..0.1 frame / truss, -0.2..0.4 concrete,
        -1..10 support springs).
    measured_dofs : (58,) int array
        0-based DOF indices of the sensors.
    lambda_exp, std_lambda : (5,) float arrays
        Identified eigenvalues ``(2 pi f)^2`` and their standard deviations, rad^2/s^2.
    psi, std_psi : (58, 5) float arrays
        Identified shapes (largest entry near 1) and their standard deviations.
    """

    M: sp.csr_array
    K0: sp.csr_array
    K_j: tuple[sp.csr_array, ...]
    names: tuple[str, ...]
    lower: FloatArray
    upper: FloatArray
    measured_dofs: IntArray
    lambda_exp: FloatArray
    std_lambda: FloatArray
    psi: FloatArray
    std_psi: FloatArray

    @property
    def f_hz(self) -> FloatArray:
        """Identified frequencies, Hz."""
        return np.sqrt(self.lambda_exp) / (2.0 * np.pi)

    @property
    def std_f_hz(self) -> FloatArray:
        """Their standard deviations, Hz (first order: ``std_lambda / (8 pi^2 f)``)."""
        return self.std_lambda / (8.0 * np.pi**2 * self.f_hz)


@dataclass(frozen=True, slots=True)
class BridgePublished:
    """The project's best published result (lowest objective of 100 fmincon runs).

    Attributes
    ----------
    alpha : (17,) float array
    fval : float
    seconds_per_run : float
        Median wall time of one run, s.
    formulation : int
        1 (MAC-value) or 2 (eigenvector difference).
    """

    alpha: FloatArray
    fval: float
    seconds_per_run: float
    formulation: int


def _file(folder: Path, name: str) -> Path:
    p = folder / name
    if not p.is_file():
        msg = f"{name}: expected in {folder}, not found"
        raise ConfigError(msg)
    return p


def load_bridge(folder: str | Path | None = None, *, rules: str | Path = BRIDGE_RULES
                ) -> BridgeData:
    """Read the bridge model and modes (module docstring), parameters as ``rules`` say.

    Raises
    ------
    ConfigError
        A file is missing or lacks a variable; a rules file without bounds.
    """
    d = Path(folder) if folder is not None else BRIDGE_DIR
    r = read_matrix_rules(rules)
    if r.lower is None or r.upper is None:
        msg = f"{rules}: expected the bridge's bounds (lower, upper)"
        raise ConfigError(msg)
    mod = mat_arrays(_file(d, _MODEL))
    exp = mat_arrays(_file(d, _MODES))
    try:
        K_j = tuple(sp.csr_array(np.asarray(mod[f"K_{k}"], dtype=float)) for k in r.parameters)
        M = sp.csr_array(np.asarray(mod["M0"], dtype=float))
        dofs = np.asarray(mod["measDOFs"], dtype=np.int64).ravel() - 1  # MATLAB 1-based
        lam = np.asarray(exp["lambdaExp"], dtype=float).ravel()
        slam = np.asarray(exp["std_lambdaExp"], dtype=float).ravel()
        psi = np.asarray(exp["psiExp_m"], dtype=float)
        spsi = np.asarray(exp["std_psiExp"], dtype=float)
    except KeyError as err:
        msg = f"{_MODEL} / {_MODES}: missing variable {err}"
        raise ConfigError(msg) from err
    K0 = sp.csr_array(sum(K_j[1:], K_j[0]))  # K(alpha) = sum_j (1 + alpha_j) K_j
    return BridgeData(M=M, K0=K0, K_j=K_j, names=r.parameters,
                      lower=r.lower, upper=r.upper, measured_dofs=dofs, lambda_exp=lam,
                      std_lambda=slam, psi=psi, std_psi=spsi)


def load_bridge_published(folder: str | Path | None = None, formulation: int = 1
                          ) -> BridgePublished:
    """Read the project's best run of formulation 1 or 2 (module docstring).

    Raises
    ------
    ConfigError
        A missing file or a formulation other than 1 or 2.
    """
    if formulation not in (1, 2):
        msg = f"formulation: expected 1 or 2, got {formulation!r}"
        raise ConfigError(msg)
    d = Path(folder) if folder is not None else BRIDGE_DIR
    r = mat_arrays(_file(d, f"{_PREFIX}Results__form{formulation}_interior-point_100runs.mat"))
    fval = np.asarray(r["fval"], dtype=float).ravel()
    k = int(np.argmin(fval))
    return BridgePublished(alpha=np.asarray(r["x"], dtype=float)[:, k]
                           if "x" in r else np.asarray(r["alpha"], dtype=float)[:, k],
                           fval=float(fval[k]),
                           seconds_per_run=float(np.median(np.asarray(r["t"], dtype=float))),
                           formulation=formulation)
