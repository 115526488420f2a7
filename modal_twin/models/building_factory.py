"""Plants of a building structure file: the reduced system, its inputs and measured channels."""

from __future__ import annotations

import copy
from collections.abc import Iterable, Mapping
from pathlib import Path

from modal_twin.channels import ChannelSpec
from modal_twin.errors import OptionError
from modal_twin.models.building import build_building, modal_reduction
from modal_twin.models.building_parameters import modal_parameters, parameter_info
from modal_twin.models.devices import Device
from modal_twin.models.effects import EffectSpec, effect_device
from modal_twin.models.loading import merge_effects, split_sensor_effects
from modal_twin.models.parameter_info import ParameterInfo
from modal_twin.models.plant import Plant, Source, with_sensor_effects

__all__ = ["INPUTS_6DOF", "BuildingFactory"]

INPUTS_6DOF = ("ax", "ay", "az", "arx", "ary", "arz")
_QUANTITIES_6DOF = ("acceleration",) * 3 + ("angular_acceleration",) * 3


class BuildingFactory:
    """Build plants of one structure with different effects, reusing its modal reduction.

    Every device is its nominal linear spring-dashpot (Table 6 of [004]) unless an effect
    replaces it (:func:`~modal_twin.models.effects.effect_device`). Channels: the sensors'
    absolute accelerations, each device's drift (``<dev>_dx``, ``_dy``) and force
    (``<dev>_fx``, ``_fy``), in that order, whatever the device laws.

    Parameters
    ----------
    structure_file : path
    theta : mapping, optional
        Parameter values (e.g. ``E_Fc27``, ``k_RB2_x``) replacing the nominal ones.
    n_modes : int, optional
        Modes kept (the file's ``n_modes`` by default).
    """

    # parameters the diagnosis screens as candidates: floor masses, moduli, element-group
    # stiffness (column lines kcol_, storeys kst_), damping factors (zeta_, rayleigh_) and the
    # added mass of each floor with its position (madd_<floor>, _x, _y); the isolators'
    # linear k and c (k_, c_); nonlinear laws at the isolators are screened on their
    # force-state data. parameter_info(name) tells kind and
    # place of each.
    base_effects: tuple[EffectSpec, ...] = ()  # a version's effects, kept in every plant
    label: str = ""  # the version's label, part of every plant's name
    parameter_prefixes = ("m_", "E_", "k_", "c_", "kcol_", "kst_", "zeta_", "rayleigh_",
                          "madd_")

    def __init__(self, structure_file: str | Path, *, theta: Mapping[str, float] | None = None,
                 n_modes: int | None = None) -> None:
        self.structure_file = Path(structure_file)
        self.theta = dict(theta or {})
        self.n_modes = n_modes
        self.bld = build_building(structure_file)
        self.mb = modal_reduction(self.bld, n_modes, theta=dict(theta) if theta else None)
        self.weights = self.bld.gravity_loads()
        self.sites = {d.name: d for d in self.bld.spec.devices}

    def with_theta(self, changes: Mapping[str, float]) -> BuildingFactory:
        """Return a factory of the same structure with some parameter values changed.

        The assembly is shared (K(theta) is parametric), only the modal reduction is
        redone.

        """
        new = copy.copy(self)
        new.theta = {**self.theta, **changes}
        new.mb = modal_reduction(self.bld, self.n_modes, theta=new.theta or None)
        return new

    def parameters(self) -> dict[str, float]:
        """Return current value of every model parameter.

        The assembly's ``theta`` (moduli, device rates, floor masses, group and link
        factors), then the damping and added-mass parameters
        (:mod:`~modal_twin.models.building_parameters`).

        """
        par = self.bld.assembly.parametric
        out = {n: float(v) for n, v in zip(par.names, par.theta_vector(
            {k: v for k, v in self.theta.items() if k in par.names} or None), strict=True)}
        modal = modal_parameters(self.bld)
        out.update({k: float(self.theta.get(k, v)) for k, v in modal.items()})
        return out

    def parameter_info(self, name: str) -> ParameterInfo:
        """Kind (stiffness / mass / damping), place.

        Nominal value and plausible bounds of a parameter, e.g. ``kcol_1A`` -> stiffness at
        "column line 1A".

        Raises
        ------
        OptionError
            Unknown name.

        """
        return parameter_info(self.bld, name, omega=self.mb.omega)

    def attachments(self) -> tuple[str, ...]:
        """Rigidly attached masses that an ``elastic_mount`` effect could hang on springs.

        (none in a building structure file).
        """
        return ()

    def site_inputs(self, component: str) -> tuple[dict[str, float], dict[str, float]]:
        """Return no input share: every site's drift here is the structure's own."""
        return {}, {}

    def weight(self, component: str) -> float:
        """Weight carried by a component, N."""
        return float(max(self.weights[self.bld.device_names.index(component)], 0.0))

    def plant(self, effects: Iterable[EffectSpec] = ()) -> Plant:
        """Return the plant with ``effects`` placed at their components."""
        bld = self.bld
        effects, sensors = split_sensor_effects(merge_effects(self.base_effects, effects))
        devices: dict[str, Device] = {}
        for e in effects:
            if e.component not in bld.device_names:
                msg = (f"effect {e.law!r}: unknown component {e.component!r}; components: "
                       f"{list(bld.device_names)}")
                raise OptionError(msg)
            devices[e.component] = effect_device(self.sites[e.component], e.law, e.params,
                                                 weight=self.weight(e.component))
        system = self.mb.to_reduced_system(devices or None, outputs=("acc", "drift", "force"))
        y_index = {n: i for i, n in enumerate(system.output_names)}
        f_rows = [f"{att.device.name}_f{a}" for att in system.devices
                  for a in "xy"[: att.device.n_dir]]
        channels: list[ChannelSpec] = []
        sources: list[Source] = []
        for name, xyz in zip(bld.channel_names, bld.channel_xyz, strict=True):
            loc, _, direction = name.rpartition("_")
            channels.append(ChannelSpec(name, "acceleration", loc, direction, position_m=(
                float(xyz[0]), float(xyz[1]), float(xyz[2]))))
            sources.append(("y", y_index[name]))
        for qty, key in (("displacement", "d"), ("force", "f")):
            for dev in bld.device_names:
                for a in "xy":
                    name = f"{dev}_{key}{a}"
                    channels.append(ChannelSpec(name, qty, dev, a))
                    sources.append(("y", y_index[name]) if name in y_index
                                   else ("force", f_rows.index(name)))
        label = ",".join(f"{e.component}:{e.law}" for e in effects) or "nominal"
        version = f"#{self.label}" if self.label else ""
        plant = Plant(system, INPUTS_6DOF, _QUANTITIES_6DOF, tuple(channels), tuple(sources),
                      name=f"{bld.spec.name}@{label}{version}")
        return with_sensor_effects(plant, sensors)
