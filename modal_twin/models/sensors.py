"""The channel map of a rig file, and how measured channels meet a model (by their roles).

Measured table inputs, then the structure's sensors, each with the rig's sensitivity for its
quantity (what the acquisition calibrates with). For a user's own record,
:func:`model_input_of` says which model input an ``input`` channel drives and
:func:`match_outputs` which model channel a measured response is.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

from modal_twin.channels import ChannelSpec
from modal_twin.errors import ConfigError
from modal_twin.models.plant import Plant
from modal_twin.models.rig_file import RigFile

__all__ = ["ChannelRoute", "match_outputs", "measured_channels", "model_input_of",
           "rig_channels", "route_channels", "table_channels", "with_sensitivity"]

INPUT_PREFIX = "table_"
"""Name prefix of the measured inputs of the shipped scenarios (``table_ax`` drives ``ax``)."""


def rig_channels(rig: RigFile) -> tuple[ChannelSpec, ...]:
    """Channels of a rig (table inputs, then the structure's).

    With the rig's sensitivities per quantity: the channel map the acquisition applies.
    """
    from modal_twin.models.loading import load_model

    plant = load_model(rig.structure).plant()
    return with_sensitivity(table_channels(plant) + measured_channels(plant, rig.channels),
                            rig.sensitivity)


def measured_channels(plant: Plant, patterns: Sequence[str]) -> tuple[ChannelSpec, ...]:
    """Return the plant's channels a rig measures: those matching ``patterns`` (fnmatch).

    No patterns: every channel, in the plant's order.

    Raises
    ------
    ConfigError
        If a pattern matches none of the plant's channels (it names the first few).
    """
    from fnmatch import fnmatchcase

    if not patterns:
        return plant.channels
    for pat in patterns:
        if not any(fnmatchcase(c.name, pat) for c in plant.channels):
            msg = (f"rig channels: {pat!r} matches none of {plant.name}'s channels "
                   f"(they start {list(plant.channel_names[:4])})")
            raise ConfigError(msg)
    return tuple(c for c in plant.channels if any(fnmatchcase(c.name, p) for p in patterns))


def table_channels(plant: Plant) -> tuple[ChannelSpec, ...]:
    """Measured input channels ``table_<input>`` of a plant.

    (table motion, track irregularity, a hammer's force), each with the plant's quantity
    for it; an input acting at a node (``plant.input_places``) has its node and direction
    (and the node's position where the plant knows it, ``plant.input_positions_m``).
    """
    if plant.input_places:
        pos = plant.input_positions_m or ((0.0, 0.0, 0.0),) * len(plant.input_places)
        return tuple(ChannelSpec(f"table_{n}", q, "", d, position_m=xyz, node=node)
                     for n, q, (node, d), xyz in zip(plant.input_names, plant.input_quantities,
                                                     plant.input_places, pos, strict=True))
    return tuple(ChannelSpec(f"table_{n}", q, "table", n.removeprefix("a"))
                 for n, q in zip(plant.input_names, plant.input_quantities, strict=True))


def with_sensitivity(channels: tuple[ChannelSpec, ...],
                     sensitivity: dict[str, float]) -> tuple[ChannelSpec, ...]:
    """Channels with the sensitivity of their quantity (1.0 where none is given)."""
    return tuple(replace(c, sensitivity=sensitivity.get(c.quantity, 1.0)) for c in channels)


_ANGULAR = ("angular_acceleration",)


def model_input_of(ch: ChannelSpec, model_inputs: Sequence[str]) -> str | None:
    """Return the model input an input-role channel drives, or None.

    Its own name, its name without ``table_``, or from its quantity and direction: an
    acceleration along x drives ``ax``, an angular acceleration about x ``arx`` (the
    building's table inputs); any other model names its inputs and the channel must too.
    """
    for name in (ch.name, ch.name.removeprefix("table_")):
        if name in model_inputs:
            return name
    d = ch.direction.lower().removeprefix("r")
    if d in ("x", "y", "z"):
        guess = ("ar" if ch.quantity in _ANGULAR or ch.direction.startswith("r") else "a") + d
        if guess in model_inputs and ch.quantity in ("acceleration", *_ANGULAR):
            return guess
    return None


def match_outputs(channels: Sequence[ChannelSpec], model: Sequence[ChannelSpec]
                  ) -> dict[str, str]:
    """Model channel name of each measured channel that has one.

    By name, else by the same place (``location``, or the ``node`` when a channel names no
    location), direction and quantity: an imported ``roof_x`` at location ``R_P1`` along x
    is the model's ``R_P1_x``; a channel at node ``12`` along z a matrix model's ``12_z``.
    """
    by_name = {c.name for c in model}
    by_place = {(c.location or c.node, c.direction, c.quantity): c.name for c in model
                if c.location or c.node}
    out: dict[str, str] = {}
    for c in channels:
        if c.name in by_name:
            out[c.name] = c.name
        elif (key := (c.location or c.node, c.direction, c.quantity)) in by_place:
            out[c.name] = by_place[key]
    return out


@dataclass(frozen=True, slots=True)
class ChannelRoute:
    """What each measured channel is to a model.

    Attributes
    ----------
    inputs : tuple of (channel, model input)
        Measured channels that drive a model input (any subset of the model's inputs).
    outputs : tuple of (channel, name)
        Measured responses, named as the model's channel at the same place, direction and
        quantity when it has one (else under their own name).
    """

    inputs: tuple[tuple[str, str], ...]
    outputs: tuple[tuple[str, str], ...]


def route_channels(names: Sequence[str], channels: Sequence[ChannelSpec] | None = None,
                   model_inputs: Sequence[str] | None = None,
                   model_channels: Sequence[ChannelSpec] = (), *,
                   source: str = "") -> ChannelRoute:
    """Say which of the channels ``names`` drive the model and which it is compared with.

    With a channel map (``channels``) the roles decide (a channel the map does not list
    gets the role its name implies): ``input`` channels drive the model input
    :func:`model_input_of` names; ``output`` / ``device_*`` channels are responses, renamed
    by :func:`match_outputs`; ``reference`` channels are left out. Without a map,
    ``table_<x>`` drives input ``<x>`` and every other channel is a response. Without
    ``model_inputs`` an input channel drives the input its name says.

    Raises
    ------
    ConfigError
        An input channel that drives none of ``model_inputs``, or two that drive one.
    """
    specs = {c.name: c for c in channels or ()}
    rename = match_outputs([specs.get(n) or ChannelSpec(n, "") for n in names],
                           model_channels) if model_channels else {}
    driven: dict[str, str] = {}  # model input -> the channel driving it
    outs: list[tuple[str, str]] = []
    for name in names:
        spec = specs.get(name) or ChannelSpec(name, "")
        role = spec.effective_role if channels is not None else (
            "input" if name.startswith(INPUT_PREFIX) else "output")
        if role == "reference":
            continue
        if role != "input":
            outs.append((name, rename.get(name, name)))
            continue
        target = (name.removeprefix(INPUT_PREFIX) if model_inputs is None
                  else model_input_of(spec, model_inputs))
        if target is None:
            msg = (f"{source or 'record'}: channel {name!r} (role input, {spec.quantity or '?'} "
                   f"{spec.direction or '?'}) drives none of the model's inputs "
                   f"{list(model_inputs or ())}")
            raise ConfigError(msg)
        if target in driven:
            msg = (f"{source or 'record'}: channels {driven[target]!r} and {name!r} both drive "
                   f"the model input {target!r}")
            raise ConfigError(msg)
        driven[target] = name
    return ChannelRoute(tuple((n, t) for t, n in driven.items()), tuple(outs))
