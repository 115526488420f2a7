r"""A model given as matrices by the user's FE tool, as a factory of plants for the twin.

M, K, substructures K_j, C and a DOF map (:mod:`modal_twin.models.matrix_model`) become a
:class:`~modal_twin.models.loading.ModelFactory`: the twin and the diagnosis then treat
the file like a structure file.

The plant is the modal reduction of ``M q'' + C q' + K(theta) q = -M P a_g``: the lowest
``n_modes`` mass-normalised modes (shift-invert Lanczos, massless DOFs allowed), damping
``Phi' C Phi`` when the file gives ``C`` and modal damping ``zeta`` otherwise, and the base
acceleration ``a_g`` along x, y, z entering through the influence matrix ``P`` (1 where a
DOF is a translation along that direction: uniform support motion of a structure held by
its supports or ground springs). Its channels are the absolute accelerations
``Phi_s q'' + P_s a_g`` of the measured DOFs (all translational DOFs when the file names
none), each with its node and direction, so a measured channel at the same node and
direction meets it (:func:`~modal_twin.models.sensors.match_outputs`). The DOF labels
``"<node>:<direction>"`` give node and direction (:mod:`modal_twin.models.matrix_model`).
A matrix model has no devices: effects that need one are refused by name.

A model whose file names ``force_dofs`` (the points a hammer or a shaker hits; a frame file's
``forces``) is driven by measured point forces there instead,

.. math::
   \ddot q + C \dot q + \Omega^2 q = \Phi_f^T f(t), \qquad \ddot x_s = \Phi_s \ddot q,

its inputs named ``force_<node>_<direction>`` (quantity ``force``, each with its node and
direction) and its channels the accelerations of the measured DOFs. Where the file gives
its nodes' coordinates (``node_xyz``) every channel and input carries its node's position.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from functools import cached_property
from pathlib import Path

import numpy as np

from modal_twin.channels import ChannelSpec
from modal_twin.errors import ModelError, OptionError
from modal_twin.models.effects import SENSOR_LAWS, EffectSpec
from modal_twin.models.matrix_model import MatrixModel, load_matrix_model
from modal_twin.models.parameter_info import ParameterInfo
from modal_twin.models.plant import Plant, with_sensor_effects
from modal_twin.models.reduced import ReducedSystem
from modal_twin.validation import LIMITS

__all__ = ["MatrixFactory", "dof_place"]

_AXES = ("x", "y", "z")


def dof_place(label: str) -> tuple[str, str]:
    """(node, direction) of a DOF label ``"<node>:<direction>"`` (direction '' otherwise)."""
    node, sep, d = label.partition(":")
    return (node.strip(), d.strip().lower()) if sep else (label.strip(), "")


class MatrixFactory:
    """Plants of a matrix model (module docstring).

    Parameters
    ----------
    path : path
        The ``.mat`` / ``.npz`` file.
    theta : mapping, optional
        Substructure factors (``K = K0 + sum theta_j K_j``), by name; 0 when not given.
    n_modes : int, optional
        Modes kept (default: every mode up to 30).
    zeta : float
        Modal damping ratio when the file has no ``C``.
    """

    sites: Mapping[str, object] = {}

    def __init__(self, path: str | Path, *, theta: Mapping[str, float] | None = None,
                 n_modes: int | None = None, zeta: float = 0.02,
                 model: MatrixModel | None = None) -> None:
        self.structure_file = Path(path)
        self.mm = model or load_matrix_model(path)
        unknown = sorted(set(theta or {}) - set(self.mm.names))
        if unknown:
            msg = (f"{path}: unknown parameters {unknown}; the file's substructures are "
                   f"{list(self.mm.names)}")
            raise OptionError(msg)
        self.theta = {str(k): float(v) for k, v in (theta or {}).items()}
        self.n_modes = n_modes
        self.zeta = zeta
        self.base_effects: tuple[EffectSpec, ...] = ()
        self.label = f"{self.structure_file.stem}@matrices"

    @property
    def parameter_prefixes(self) -> tuple[str, ...]:
        """The substructure names: every one may be screened."""
        return tuple(self.mm.names)

    def with_theta(self, changes: Mapping[str, float]) -> MatrixFactory:
        """Return the same model with some substructure factors changed."""
        return MatrixFactory(self.structure_file, theta={**self.theta, **changes},
                             n_modes=self.n_modes, zeta=self.zeta, model=self.mm)

    def parameters(self) -> dict[str, float]:
        """Return every substructure factor (0: nominal)."""
        return {n: self.theta.get(n, 0.0) for n in self.mm.names}

    def attachments(self) -> tuple[str, ...]:
        """Return no attachments: a matrix model has no rigid masses to mount elastically."""
        return ()

    def site_inputs(self, component: str) -> tuple[dict[str, float], dict[str, float]]:
        """Return no input share: every site's drift here is the structure's own."""
        return {}, {}

    def weight(self, component: str) -> float:
        """Refuse: a matrix model has no devices that carry weight."""
        msg = f"{self.structure_file}: a matrix model has no device {component!r}"
        raise OptionError(msg)

    @cached_property
    def _plant(self) -> Plant:
        mm = self.mm
        th = np.array([self.parameters()[n] for n in mm.names])
        K, M = mm.K(th), mm.M
        places = [dof_place(d) for d in mm.dofs]
        P = np.array([[1.0 if d == a else 0.0 for a in _AXES] for _, d in places])
        keep = np.flatnonzero(P.any(axis=0))
        if mm.force_dofs:
            return self._force_plant(K, M, places)
        if keep.size == 0:
            msg = (f"{self.structure_file}: no DOF label names a direction x / y / z "
                   "('<node>:<direction>'), so no base input can drive the model")
            raise ModelError(msg)
        P = P[:, keep]
        Phi, omega, C = self._modes(K, M)
        r = omega.size
        rows = (mm.measured_dofs if mm.measured_dofs.size
                else np.flatnonzero(P.any(axis=1)))[:int(LIMITS["n_channels"].hi)]
        n_out = rows.size
        C_out = np.zeros((n_out, 3 * r))
        C_out[:, 2 * r:] = Phi[rows]  # absolute acceleration: Phi_s q'' + P_s a_g
        system = ReducedSystem(M=np.eye(r), C=C, K=np.diag(omega ** 2),
                               Gamma=Phi.T @ (M @ P), devices=(), C_out=C_out, D_out=P[rows])
        chans = []
        xyz = self._positions()
        for i in rows:
            node, d = places[i]
            name = f"{node}_{d}" if d else f"dof{i}"
            chans.append(ChannelSpec(name, "acceleration", node, d,
                                     position_m=xyz.get(node, (0.0, 0.0, 0.0)), node=node))
        return Plant(system, tuple(f"a{_AXES[k]}" for k in keep),
                     ("acceleration",) * keep.size, tuple(chans),
                     tuple(("y", k) for k in range(n_out)), self.label)

    def _modes(self, K: object, M: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Mass-normalised modes, natural frequencies (rad/s) and modal damping matrix."""
        from modal_twin.models.fe.eigen import solve_modes

        mm = self.mm
        sol = solve_modes(K, M, self.n_modes or min(mm.n_dof, 30))
        C = (sol.Phi.T @ (mm.C @ sol.Phi) if mm.C is not None
             else np.diag(2.0 * self.zeta * sol.omega))
        return sol.Phi, sol.omega, C

    def _force_plant(self, K: object, M: object, places: list[tuple[str, str]]) -> Plant:
        """Return the plant driven by point forces at ``force_dofs`` (module docstring)."""
        mm = self.mm
        Phi, omega, C = self._modes(K, M)
        r = omega.size
        rows = (mm.measured_dofs if mm.measured_dofs.size
                else np.arange(mm.n_dof))[:int(LIMITS["n_channels"].hi)]
        C_out = np.zeros((rows.size, 3 * r))
        C_out[:, 2 * r:] = Phi[rows]
        f = list(mm.force_dofs)
        # the simulator's M q'' + C q' + K q = -Gamma u: a force enters as +Phi_f^T f
        system = ReducedSystem(M=np.eye(r), C=C, K=np.diag(omega ** 2), Gamma=-Phi[f].T,
                               devices=(), C_out=C_out, D_out=np.zeros((rows.size, len(f))))
        xyz = self._positions()
        chans = tuple(ChannelSpec(f"{places[i][0]}_{places[i][1]}" if places[i][1]
                                  else f"dof{i}", "acceleration", places[i][0],
                                  places[i][1],
                                  position_m=xyz.get(places[i][0], (0.0, 0.0, 0.0)),
                                  node=places[i][0]) for i in rows)
        names = tuple(f"force_{places[i][0]}_{places[i][1]}" if places[i][1] else f"force_{i}"
                      for i in f)
        return Plant(system, names, ("force",) * len(f), chans,
                     tuple(("y", k) for k in range(rows.size)), self.label,
                     input_places=tuple(places[i] for i in f),
                     input_positions_m=tuple(xyz.get(places[i][0], (0.0, 0.0, 0.0))
                                             for i in f) if xyz else ())

    def _positions(self) -> dict[str, tuple[float, float, float]]:
        """Node (as the DOF labels name it) -> (x, y, z) m, from the file's ``node_xyz``."""
        xyz = self.mm.node_xyz
        if xyz is None:
            return {}
        return {str(int(r[0])): (float(r[1]), float(r[2]), float(r[3])) for r in xyz}

    def parameter_info(self, name: str) -> ParameterInfo:
        """Return what a substructure factor is: a stiffness of that substructure.

        Bounds from the file (``lower`` / ``upper``), else -0.9 (the substructure nearly
        gone) to +2 (three times as stiff).

        Raises
        ------
        OptionError
            Not a substructure of the file.
        """
        mm = self.mm
        if name not in mm.names:
            msg = f"{self.structure_file}: unknown parameter {name!r}; it has {list(mm.names)}"
            raise OptionError(msg)
        j = mm.names.index(name)
        lo = float(mm.lower[j]) if mm.lower is not None else -0.9
        hi = float(mm.upper[j]) if mm.upper is not None else 2.0
        return ParameterInfo(name, "stiffness", f"substructure {name}", 0.0, lo, hi, "1",
                             "group")

    def plant(self, effects: Iterable[EffectSpec] = ()) -> Plant:
        """Return the reduced plant, seen through any sensor effects.

        Raises
        ------
        OptionError
            A device effect: a matrix model has no devices.
        """
        every = (*self.base_effects, *effects)
        devices = [e for e in every if e.law not in SENSOR_LAWS]
        sensors = [e for e in every if e.law in SENSOR_LAWS]
        if devices:
            msg = (f"{self.structure_file}: a matrix model has no devices, so "
                   f"{[f'{e.law} at {e.component}' for e in devices]} cannot be added; give "
                   "a structure file for device effects")
            raise OptionError(msg)
        return with_sensor_effects(self._plant, sensors) if sensors else self._plant
