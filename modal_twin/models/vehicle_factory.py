"""Plants of a vehicle file: the trailer car with parameter values and elastic mounts.

The vehicle counterpart of :class:`~modal_twin.models.building_factory.BuildingFactory`,
with the protocol :class:`~modal_twin.models.loading.ModelFactory` that the diagnosis and
updating use (``plant``, ``with_theta``, ``parameters``, ``attachments``, ``sites``). The
vehicle's device sites are its secondary suspensions, elastic equipment hangers and primary
suspensions (a device law of the registry can replace one; the diagnosis screens a site
where the record has its stroke and force); its candidate effects are also
parameter changes (``EI_carbody``, ``m_<equipment>``, the suspensions' ``k_`` / ``c_``, the
modal damping ratio ``zeta_cb_<k>`` of the k-th flexible carbody mode) and elastic mounts
of the rigidly bolted equipment (``elastic_mount``, Fig. 3b of [002]).
"""

from __future__ import annotations

import copy
from collections.abc import Iterable, Mapping
from dataclasses import replace
from pathlib import Path

import numpy as np

from modal_twin.errors import OptionError
from modal_twin.models.effects import MOUNT_LAW, EffectSpec, effect_device
from modal_twin.models.loading import merge_effects, split_sensor_effects
from modal_twin.models.parameter_info import Kind, ParameterInfo
from modal_twin.models.plant import Plant, with_sensor_effects
from modal_twin.models.structure_yaml import DeviceSpec
from modal_twin.models.vehicle import PRIMARY_SITES, SUSPENSION_SITES, build_vehicle
from modal_twin.models.vehicle_spec import (
    CARBODY_MODE_PREFIX,
    VehicleSpec,
    apply_theta,
    equipment_mounted,
    load_vehicle,
    parameter_value,
    theta_names,
)

__all__ = ["VehicleFactory"]

_PREFIX_INFO: dict[str, tuple[Kind, str, float, float]] = {
    "m_": ("mass", "kg", 0.5, 2.0), "EI_": ("stiffness", "N m^2", 0.3, 3.0),
    "k_": ("stiffness", "N/m", 0.3, 3.0), "c_": ("damping", "N s/m", 0.01, 5.0),
    "zeta_": ("damping", "1", 0.1, 5.0)}
"""Kind, unit and relative bounds of a vehicle parameter, by name prefix."""


class VehicleFactory:
    """Build plants of one vehicle file with different parameter values and mounts.

    Parameters
    ----------
    vehicle_file : path
        A vehicle file (``config/vehicles/*.yaml``).
    theta : mapping, optional
        Parameter values (:func:`~modal_twin.models.vehicle_spec.theta_names`).
    """

    # parameters the diagnosis screens as candidates: equipment masses, carbody bending
    # stiffness, primary and secondary suspension stiffness and damping, the damping ratio
    # of each of the first flexible carbody modes (zeta_cb_1 = first bending)
    base_effects: tuple[EffectSpec, ...] = ()  # a version's effects, kept in every plant
    label: str = ""  # the version's label, part of every plant's name
    parameter_prefixes = ("m_", "EI_", "k_", "c_", CARBODY_MODE_PREFIX)

    def __init__(self, vehicle_file: str | Path, *,
                 theta: Mapping[str, float] | None = None) -> None:
        self.structure_file = Path(vehicle_file)
        self.theta = dict(theta or {})
        self.spec: VehicleSpec = load_vehicle(vehicle_file)
        apply_theta(self.spec, self.theta)  # refuses unknown names and bad values now

    @property
    def sites(self) -> dict[str, DeviceSpec]:
        """Device sites: secondary suspensions, elastic hangers, primary suspensions.

        The secondary suspension of each bogie, each elastic hanger, the primary suspension
        of each wheelset, with their k and c now. A device law of the registry placed there
        replaces the element's spring and dashpot; a 2-direction law's second direction
        takes no stroke
        (the ``k`` and ``c`` of both directions are the element's). An item the file
        bolts rigidly is a candidate for an ``elastic_mount`` instead.
        """
        spec = apply_theta(self.spec, self.theta)
        kc = {site: (spec.suspension("k_secondary", b), spec.suspension("c_secondary", b))
              for b, site in enumerate(SUSPENSION_SITES)}
        kc.update({e.name: (e.k_mount, e.c_mount) for e in spec.equipment
                   if e.mount == "elastic"})
        kc.update({site: (spec.suspension("k_primary", i // 2),
                          spec.suspension("c_primary", i // 2))
                   for i, site in enumerate(PRIMARY_SITES)})
        return {site: DeviceSpec(site, j, np.array([k, k]), np.array([c, c]), 0.0, "linear")
                for j, (site, (k, c)) in enumerate(kc.items())}

    def site_inputs(self, component: str) -> tuple[dict[str, float], dict[str, float]]:
        """Return the input's share of a site's stroke and of its rate (input -> coefficient).

        A primary suspension's stroke is its bogie's point less the track under its
        wheelset (``-zt<i>``, rate ``-vt<i>``); the other sites' strokes hold no input.
        """
        if component not in PRIMARY_SITES:
            return {}, {}
        i = PRIMARY_SITES.index(component) + 1
        return {f"zt{i}": -1.0}, {f"vt{i}": -1.0}

    def with_theta(self, changes: Mapping[str, float]) -> VehicleFactory:
        """Return a factory of the same vehicle with some parameter values changed.

        The file is not read again.
        """
        new = copy.copy(self)
        new.theta = {**self.theta, **changes}
        apply_theta(new.spec, new.theta)  # refuses unknown names and bad values now
        return new

    def parameters(self) -> dict[str, float]:
        """Return the current value of every parameter."""
        spec = apply_theta(self.spec, self.theta)
        return {n: parameter_value(spec, n) for n in theta_names(spec)}

    def parameter_info(self, name: str) -> ParameterInfo:
        """Kind (stiffness / mass / damping), place, nominal value.

        (the file's) and plausible bounds of a parameter, from its prefix
        (:data:`_PREFIX_INFO`).

        Raises
        ------
        OptionError
            Unknown name.

        """
        if name not in theta_names(self.spec):
            msg = f"parameter: expected one of {list(theta_names(self.spec))}, got {name!r}"
            raise OptionError(msg)
        v = float(parameter_value(self.spec, name))
        if name.startswith(CARBODY_MODE_PREFIX):  # as the building's modal damping
            return ParameterInfo(name, "damping", "carbody", v, 0.1 * v, 5.0 * v, "1",
                                 "modal_damping")
        for prefix, (kind, unit, lo, hi) in _PREFIX_INFO.items():
            if name.startswith(prefix):
                return ParameterInfo(name, kind, name[len(prefix):].replace("_", " "), v,
                                     lo * v, hi * v, unit, prefix.rstrip("_"))
        return ParameterInfo(name, "stiffness", name, v, 0.3 * v, 3.0 * v, "", "other")

    def attachments(self) -> tuple[str, ...]:
        """Return the rigidly mounted equipment an ``elastic_mount`` effect can hang."""
        return tuple(e.name for e in self.spec.equipment if e.mount == "rigid")

    def weight(self, component: str) -> float:
        """Weight of an equipment item or on a suspension, N.

        On a secondary suspension half the carbody's, on a primary one a quarter of the
        carbody's and half its bogie's.
        """
        spec = apply_theta(self.spec, self.theta)
        if component in SUSPENSION_SITES:
            return 0.5 * 9.81 * spec.carbody_mass
        if component in PRIMARY_SITES:
            return 9.81 * (0.25 * spec.carbody_mass + 0.5 * spec.bogie_mass)
        return 9.81 * spec.equipment_named(component).mass

    def plant(self, effects: Iterable[EffectSpec] = ()) -> Plant:
        """Return the plant with ``effects`` (elastic mounts, device laws at sites) applied.

        Raises
        ------
        OptionError
            An effect other than ``elastic_mount`` or a device law at a site, or a mount at
            an unknown / already elastic item.
        """
        spec = self.spec
        effects, sensors = split_sensor_effects(merge_effects(self.base_effects, effects))
        devices = {}
        sites = self.sites
        for e in effects:
            if e.component in sites and e.law != MOUNT_LAW:
                devices[e.component] = effect_device(sites[e.component], e.law, e.params,
                                                     weight=self.weight(e.component))
                continue
            if e.law != MOUNT_LAW:
                msg = (f"effect {e.law!r} at {e.component!r}: a vehicle takes "
                       f"{MOUNT_LAW!r} effects at {list(self.attachments())}, device laws "
                       f"at {list(sites)} and parameter changes")
                raise OptionError(msg)
            if e.component not in self.attachments():
                msg = (f"{MOUNT_LAW}: unknown or already elastic item {e.component!r}; "
                       f"rigid items: {list(self.attachments())}")
                raise OptionError(msg)
            spec = equipment_mounted(spec, e.component, float(e.params["f_hz"]),
                                     float(e.params.get("zeta", 0.05)),
                                     u_h=float(e.params.get("u_h", 0.0)),
                                     m=float(e.params.get("m", 3.0)),
                                     u_s=float(e.params.get("u_s", 0.0)),
                                     r=float(e.params.get("r", 1.0)),
                                     n=float(e.params.get("n", 0.0)))
        plant = build_vehicle(spec, theta=self.theta or None, site_devices=devices,
                              device_channels=tuple(sites))
        plant = replace(plant, name=f"{plant.name}#{self.label}") if self.label else plant
        return with_sensor_effects(plant, sensors)
