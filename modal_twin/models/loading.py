"""One way to load a model: a file in, a :class:`ModelFactory` out.

A model file is a building structure file (``config/structures/*.yaml``), a vehicle file
(``config/vehicles/*.yaml``), a matrix model of the user's FE tool (``.mat`` / ``.npz``:
:mod:`modal_twin.models.matrix_factory`) or a frame file read as one
(:mod:`modal_twin.models.frame_file`) or a model version file
(:mod:`modal_twin.models.versions`: a structure with parameter values and the effects
added so far). Every kind gives a factory with one protocol, so the twin, updating and
the diagnosis never ask which kind they hold::

    factory = load_model("config/structures/building.yaml")
    plant = factory.plant()                                  # nominal
    plant = factory.plant([EffectSpec("ESB1", "stick_slip", {"Fs": 1e5, "Fk": 7e4})])

A version's effects stay in every plant its factory builds; an effect given to
:meth:`ModelFactory.plant` at a component that already carries one replaces it (so a
joint refit passes all effects again).
"""

from __future__ import annotations

import copy
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

from modal_twin.models.effects import MOUNT_LAW, SENSOR_LAWS, EffectSpec
from modal_twin.models.parameter_info import ParameterInfo
from modal_twin.models.plant import Plant

__all__ = ["ModelFactory", "load_model", "merge_effects", "split_sensor_effects", "with_effects"]


@runtime_checkable
class ModelFactory(Protocol):
    """What every model kind offers: plants with effects, parameters, candidate sites."""

    structure_file: Path
    theta: dict[str, float]
    base_effects: tuple[EffectSpec, ...]
    label: str

    @property
    def sites(self) -> Mapping[str, Any]:
        """Candidate device sites by name (read-only here, so each kind keeps its own type)."""
        ...

    @property
    def parameter_prefixes(self) -> tuple[str, ...]:
        """Prefixes of the parameter names this kind understands."""
        ...

    def with_theta(self, changes: Mapping[str, float]) -> ModelFactory:
        """Return the same model with some parameter values changed."""
        ...

    def parameters(self) -> dict[str, float]:
        """Return the current value of every parameter."""
        ...

    def parameter_info(self, name: str) -> ParameterInfo:
        """Kind, place, nominal value and bounds of a parameter (OptionError: unknown)."""
        ...

    def attachments(self) -> tuple[str, ...]:
        """Rigidly attached masses that could hang on elastic mounts."""
        ...

    def weight(self, component: str) -> float:
        """Weight carried by a component, N."""
        ...

    def site_inputs(self, component: str) -> tuple[dict[str, float], dict[str, float]]:
        """Return the input's share of a site's drift and of its rate (input -> coefficient).

        Empty where the drift is the structure's own (all but a primary suspension's stroke).
        """
        ...

    def plant(self, effects: Iterable[EffectSpec] = ()) -> Plant:
        """Return the plant with the base effects and ``effects`` in place."""
        ...


def merge_effects(base: Iterable[EffectSpec], new: Iterable[EffectSpec]) -> tuple[EffectSpec, ...]:
    """Return ``base`` with every effect of ``new`` added.

    A new effect at a component that already carries a device law replaces it (parameter
    and mount effects stay side by side).
    """
    new = tuple(new)
    taken = {(e.component, _slot(e.law)) for e in new}
    return (*(e for e in base if (e.component, _slot(e.law)) not in taken), *new)


def _slot(law: str) -> str:
    # one device law per component; mounts and sensor laws are slots of their own
    return law if law == MOUNT_LAW or law in SENSOR_LAWS else "device"


def split_sensor_effects(effects: Iterable[EffectSpec]
                         ) -> tuple[tuple[EffectSpec, ...], tuple[EffectSpec, ...]]:
    """(structural effects, sensor effects) of a list of effects."""
    effects = tuple(effects)
    return (tuple(e for e in effects if e.law not in SENSOR_LAWS),
            tuple(e for e in effects if e.law in SENSOR_LAWS))


def with_effects(factory: ModelFactory, effects: Iterable[EffectSpec]) -> ModelFactory:
    """Return a factory whose plants carry ``effects`` beside its own base effects."""
    new = copy.copy(factory)
    new.base_effects = merge_effects(factory.base_effects, effects)
    return new


def _factory_of(structure: str | Path, theta: Mapping[str, float] | None,
                n_modes: int | None) -> ModelFactory:
    from modal_twin.models.frame_file import is_frame_file
    from modal_twin.models.matrix_model import MATRIX_SUFFIXES
    from modal_twin.models.vehicle_spec import is_vehicle_file

    if Path(structure).suffix.lower() in MATRIX_SUFFIXES or is_frame_file(structure):
        from modal_twin.models.matrix_factory import MatrixFactory

        return MatrixFactory(structure, theta=theta, n_modes=n_modes)
    from modal_twin.models.vehicle3d_spec import is_vehicle3d_file

    if is_vehicle3d_file(structure):
        from modal_twin.models.vehicle3d_factory import Vehicle3DFactory

        return Vehicle3DFactory(structure, theta=theta)
    if is_vehicle_file(structure):
        from modal_twin.models.vehicle_factory import VehicleFactory

        return VehicleFactory(structure, theta=theta)
    from modal_twin.models.building_factory import BuildingFactory

    return BuildingFactory(structure, theta=theta, n_modes=n_modes)


def load_model(model_file: str | Path, *, theta: Mapping[str, float] | None = None,
               n_modes: int | None = None) -> ModelFactory:
    """Return the factory of a structure, vehicle or version file.

    Parameters
    ----------
    model_file : path
    theta : mapping, optional
        Parameter values overriding the file's.
    n_modes : int, optional
        Modes kept by a building's reduction (the file's ``n_modes`` by default).

    Raises
    ------
    ConfigError, ModelError, OptionError
        The file is not a model of a known kind, or its content is invalid.
    """
    from modal_twin.models.versions import read_version

    mv = read_version(model_file)
    th = {**mv.theta, **(theta or {})}
    factory = _factory_of(mv.structure, th or None, n_modes)
    if mv.effects:
        factory = copy.copy(factory)
        factory.base_effects = tuple(mv.effects)
    if mv.path is not None:
        factory.label = mv.label
    return factory
