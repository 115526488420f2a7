"""Parameters of a building beyond its assembly: damping factors, an added mass per floor.

The assembly's parameters (:class:`~modal_twin.models.fe.ParametricMatrices`: moduli ``E_*``,
device rates ``k_* / c_*``, floor masses ``m_*``, element-group factors ``kcol_*`` /
``kst_*``, link factors) enter ``K``, ``M`` or ``C`` linearly (Sec. 4 of [004]). Two more
families act at the modal reduction (:func:`modal_twin.models.building.modal_reduction`):

* damping (YAML ``damping``): a factor ``param`` (e.g. ``zeta_sup``, nominal 1) on every
  added-damping target, factors on the targets of mode groups, and the Rayleigh
  coefficients ``alpha``, ``beta`` (``C += alpha M + beta K``);
* an added mass per rigid floor, the candidate "a mass the model lacks" with its position:
  ``madd_<floor>`` (kg, nominal 0) at ``(madd_<floor>_x, madd_<floor>_y)`` (m, nominal the
  floor's plan centre) with radius of gyration ``madd_<floor>_r`` (m, nominal 0: a point
  mass) about its own centre. On the floor's master ``(ux, uy, rz)`` it is the in-plane
  part of the rigid-body mass of a body of mass ``m`` and polar inertia ``m rg^2`` at
  offset ``(dx, dy)`` (see :func:`~modal_twin.models.fe.rigid_body_mass_block`)::

      m [[1, 0, -dy], [0, 1, dx], [-dy, dx, dx^2 + dy^2 + rg^2]]

  exact for a rigid diaphragm: translation, eccentricity and rotary inertia (parallel-axis
  theorem) move together as one candidate; a mass spread over the plan (equipment over
  several bays) has ``rg > 0``. Its vertical translation is shared by the floor's nodes
  around its position (:func:`vertical_shares`; the floor is not rigid out of its plane).

:func:`parameter_info` gives every parameter's kind (stiffness / mass / damping), place and
plausible bounds, for screening and for reports ("stiffness at column line 1A").
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
from scipy.optimize import nnls

from modal_twin._types import FloatArray
from modal_twin.errors import OptionError
from modal_twin.models.parameter_info import Kind, ParameterInfo

if TYPE_CHECKING:
    from modal_twin.models.building import BuildingModel
    from modal_twin.models.structure_yaml import DampingSpec

__all__ = ["ADDED_MASS_PREFIX", "ParameterInfo", "added_mass_matrix", "added_mass_parameters",
           "damping_targets", "modal_parameters", "parameter_info", "split_theta"]

ADDED_MASS_PREFIX = "madd_"


def damping_targets(spec: DampingSpec, r: int, theta: Mapping[str, float]) -> FloatArray:
    """Target damping ratio of each of the ``r`` modes (0 for the isolation modes).

    ``spec.superstructure_zeta`` then ``spec.default_zeta`` from mode ``n_isolation_modes``
    on (Sec. 6 of [004]), times the factor ``spec.param`` and the mode-group factors.
    """
    target = np.full(r, spec.default_zeta)
    lo = spec.n_isolation_modes
    target[:lo] = 0.0
    ns = len(spec.superstructure_zeta)
    target[lo: lo + ns] = np.asarray(spec.superstructure_zeta)[: max(0, r - lo)]
    if spec.param:
        target *= theta.get(spec.param, 1.0)
    for name, first, last in spec.mode_groups:
        target[first - 1: last] *= theta.get(name, 1.0)
    return target


def _floor_geometry(building: BuildingModel, floor: str) -> tuple[FloatArray, FloatArray]:
    """(master xyz, plan centre xy) of a floor."""
    fl = next(f for f in building.spec.floors if f.name == floor)
    xyz = np.array([building.spec.model.xyz(n) for n in fl.nodes])
    return building.spec.model.xyz(fl.master), xyz[:, :2].mean(axis=0)


def added_mass_parameters(building: BuildingModel) -> dict[str, float]:
    """``madd_<floor>`` (0 kg), ``_x / _y`` (plan centre, m) and ``_r`` (0 m) of every floor."""
    out: dict[str, float] = {}
    for f in building.spec.floors:
        _, c = _floor_geometry(building, f.name)
        base = f"{ADDED_MASS_PREFIX}{f.name}"
        out.update({base: 0.0, f"{base}_x": float(c[0]), f"{base}_y": float(c[1]),
                    f"{base}_r": 0.0})
    return out


def modal_parameters(building: BuildingModel) -> dict[str, float]:
    """Nominal values of the parameters acting at the modal reduction (module docstring)."""
    return {**building.spec.damping.parameters(), **added_mass_parameters(building)}


def split_theta(building: BuildingModel, theta: Mapping[str, float] | None
                ) -> tuple[dict[str, float] | None, dict[str, float]]:
    """Split a parameter mapping into (assembly part or None, modal part with defaults).

    Raises
    ------
    OptionError
        A name that is neither an assembly nor a modal parameter (lists the valid ones).
    """
    modal = modal_parameters(building)
    if theta is None:
        return None, modal
    names = building.assembly.parametric.names
    asm = {k: float(v) for k, v in theta.items() if k in names}
    bad = [k for k in theta if k not in names and k not in modal]
    if bad:
        msg = f"theta: unknown parameters {bad}; valid: {[*names, *modal]}"
        raise OptionError(msg)
    modal.update({k: float(v) for k, v in theta.items() if k in modal})
    return asm or None, modal


def added_mass_matrix(building: BuildingModel, theta: Mapping[str, float]) -> sp.csr_array | None:
    """Sum of the floors' added-mass blocks on the free DOFs (None when every mass is 0).

    Raises
    ------
    OptionError
        A negative added mass.
    """
    asm = building.assembly
    rows: list[int] = []
    cols: list[int] = []
    vals: list[float] = []
    for f in building.spec.floors:
        base = f"{ADDED_MASS_PREFIX}{f.name}"
        m = float(theta.get(base, 0.0))
        if m == 0.0:
            continue
        if m < 0.0:
            msg = f"{base}: expected an added mass >= 0 kg, got {m!r}"
            raise OptionError(msg)
        master, _ = _floor_geometry(building, f.name)
        dx = float(theta[f"{base}_x"]) - master[0]
        dy = float(theta[f"{base}_y"]) - master[1]
        d = [asm.dof_index(f.master, n) for n in ("ux", "uy", "rz")]
        rg = float(theta.get(f"{base}_r", 0.0))
        if rg < 0.0:
            msg = f"{base}_r: expected a radius of gyration >= 0 m, got {rg!r}"
            raise OptionError(msg)
        block = m * np.array([[1.0, 0.0, -dy], [0.0, 1.0, dx],
                              [-dy, dx, dx * dx + dy * dy + rg * rg]])
        for i in range(3):
            for j in range(3):
                rows.append(d[i])
                cols.append(d[j])
                vals.append(float(block[i, j]))
        # vertical translation shared by the floor's nodes around its plan position
        nodes = list(f.nodes)
        xy = np.array([building.spec.model.xyz(n)[:2] for n in nodes])
        shares = vertical_shares(xy, master[:2] + np.array([dx, dy]))
        for node, w in zip(nodes, shares, strict=True):
            zfull = asm.full_dof_index(node, "uz")
            zdof = int(np.searchsorted(asm.free_dofs, zfull))
            if w > 0.0 and zdof < asm.n_dof and asm.free_dofs[zdof] == zfull:  # not supported
                rows.append(zdof)
                cols.append(zdof)
                vals.append(m * float(w))
    if not vals:
        return None
    n = asm.n_dof
    return sp.csr_array(sp.coo_array((vals, (rows, cols)), shape=(n, n)))


def vertical_shares(xy: FloatArray, at: FloatArray) -> FloatArray:
    """Shares of a mass at plan point ``at`` lumped on nodes ``xy`` (n, 2) for vertical motion.

    Non-negative, summing to 1, with their centroid at ``at`` wherever ``at`` lies in the
    nodes' convex hull (the mass's static vertical load and its first moments about both
    plan axes are kept, so rocking sees it where it is); among such shares those on the
    nearest nodes (least squares with a small penalty growing with each node's distance,
    by NNLS): a mass at a node stays on it. Outside the hull, the centroid is the hull's
    nearest point.
    """
    xy = np.asarray(xy, dtype=float)
    span = float(np.ptp(xy, axis=0).max()) or 1.0
    rows = np.vstack([np.ones(len(xy)), (xy - at).T / span])
    dist = np.linalg.norm(xy - at, axis=1) / span
    a = np.vstack([1e3 * rows, 1e-3 * np.diag(dist + 1e-3)])
    b = np.concatenate([[1e3, 0.0, 0.0], np.zeros(len(xy))])
    w, _ = nnls(a, b)
    total = float(w.sum())
    return w / total if total > 0 else np.full(len(xy), 1.0 / len(xy))


def _floor_mass(building: BuildingModel, floor: str) -> float:
    asm = building.assembly
    fl = next(f for f in building.spec.floors if f.name == floor)
    d = asm.M_full.diagonal()
    return float(sum(d[asm.full_dof_index(n, "ux")] for n in fl.nodes))


def parameter_info(building: BuildingModel, name: str, *, omega: FloatArray | None = None
                   ) -> ParameterInfo:
    """Kind, place, nominal value and plausible bounds of parameter ``name``.

    Parameters
    ----------
    building : BuildingModel
    name : str
        An assembly or a modal parameter.
    omega : (r,) float array, optional
        Natural frequencies (rad/s), for the bounds of the Rayleigh coefficients (10 % at
        the first / first superstructure mode).

    Raises
    ------
    OptionError
        Unknown name (lists the valid ones).
    """
    spec = building.spec
    par = building.assembly.parametric
    modal = modal_parameters(building)
    groups = {g.name: g for g in spec.groups}
    if name in par.names:
        v = float(par.theta0[par.index(name)])
        kinds: dict[str, Kind] = {"K": "stiffness", "M": "mass", "C": "damping"}
        kind = kinds[par.kinds[par.index(name)]]
        return _assembly_info(building, name, kind, v, groups)
    if name not in modal:
        msg = f"parameter: expected one of {[*par.names, *modal]}, got {name!r}"
        raise OptionError(msg)
    v = modal[name]
    d = spec.damping
    for f in spec.floors:
        base = f"{ADDED_MASS_PREFIX}{f.name}"
        if name == base:
            return ParameterInfo(name, "mass", f"floor {f.name}", v, 0.0,
                                 0.5 * _floor_mass(building, f.name), "kg", "added_mass")
        if name in (f"{base}_x", f"{base}_y"):
            ax = 0 if name.endswith("_x") else 1
            xy = np.array([spec.model.xyz(n)[ax] for n in f.nodes])
            a = "xy"[ax]
            return ParameterInfo(name, "mass", f"floor {f.name} ({a} of the added mass)", v,
                                 float(xy.min()), float(xy.max()), "m", f"added_mass_{a}")
        if name == f"{base}_r":
            xy = np.array([spec.model.xyz(n)[:2] for n in f.nodes])
            half_diag = 0.5 * float(np.linalg.norm(xy.max(axis=0) - xy.min(axis=0)))
            return ParameterInfo(name, "mass", f"floor {f.name} (radius of gyration of the "
                                 "added mass)", v, 0.0, half_diag, "m", "added_mass_r")
    w = np.array([2.0 * np.pi]) if omega is None else np.asarray(omega, dtype=float)
    if name == d.alpha_param:
        return ParameterInfo(name, "damping", "Rayleigh mass-proportional damping", v, 0.0,
                             max(0.2 * float(w[0]), 2.0 * v), "1/s", "rayleigh")
    if name == d.beta_param:
        w_sup = float(w[min(d.n_isolation_modes, w.size - 1)])
        return ParameterInfo(name, "damping", "Rayleigh stiffness-proportional damping", v, 0.0,
                             max(0.2 / w_sup, 2.0 * v), "s", "rayleigh")
    place = ("superstructure modes" if name == d.param else
             next(f"modes {a}-{b}" for g, a, b in d.mode_groups if g == name))
    return ParameterInfo(name, "damping", place, v, 0.1 * v, 5.0 * v, "1", "modal_damping")


def _assembly_info(building: BuildingModel, name: str, kind: Kind, v: float,
                   groups: Mapping[str, object]) -> ParameterInfo:
    spec = building.spec
    if name in groups:
        return ParameterInfo(name, kind, str(getattr(groups[name], "place", name)), v,
                             0.3 * v, 3.0 * v, "1", "group")
    for link in spec.links:
        if name in (link.param, link.c_param):
            where = f"link {link.name} ({link.n1}-{link.n2 if link.n2 is not None else 'ground'})"
            return ParameterInfo(name, kind, where, v, 0.3 * v if kind == "stiffness"
                                 else 0.01 * v, 3.0 * v if kind == "stiffness" else 5.0 * v,
                                 "1", "link")
    for dev in spec.devices:
        for ax in "xy":
            if name in (f"k_{dev.name}_{ax}", f"c_{dev.name}_{ax}"):
                lo = 0.3 if kind == "stiffness" else 0.01
                unit = "N/m" if kind == "stiffness" else "N s/m"
                return ParameterInfo(name, kind, f"device {dev.name} {ax}", v, lo * v,
                                     (3.0 if kind == "stiffness" else 5.0) * v, unit, "device")
    if name.startswith("E_"):
        return ParameterInfo(name, kind, f"material {name[2:]} (all its elements)", v,
                             0.3 * v, 3.0 * v, "Pa", "modulus")
    floors = {f.name for f in spec.floors}
    if kind == "mass" and name.startswith("m_") and name[2:] in floors:
        return ParameterInfo(name, kind, f"floor {name[2:]}", v, 0.5 * v, 2.0 * v, "kg", "mass")
    unit = {"stiffness": "N/m", "mass": "kg", "damping": "N s/m"}[kind]
    return ParameterInfo(name, kind, f"parameter {name}", v, 0.3 * v, 3.0 * v, unit, "other")
