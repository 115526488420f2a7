"""Node parameters declared from a config dataclass and frozen back into it."""

from __future__ import annotations

import dataclasses
from typing import Any, TypeVar

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node

from modal_twin.errors import ConfigError

__all__ = ["declare_config"]

T = TypeVar("T")


def declare_config(node: Node, cls: type[T]) -> T:
    """Declare a parameter per field of dataclass ``cls``; return the instance the node was given.

    Default = field default, description = ``field.metadata['doc']``.

    The parameters are read-only once declared: the node reads them at start, so a change
    at run time is refused (``set_parameters`` answers ``successful=False``) instead of
    being accepted and silently ignored.

    Raises
    ------
    ConfigError
        If a value has the wrong type or the dataclass's ``__post_init__`` refuses it; the
        message names the node and the parameter.
    """
    values: dict[str, Any] = {}
    for f in dataclasses.fields(cls):  # type: ignore[arg-type]
        if f.default is not dataclasses.MISSING:
            default = f.default
        elif f.default_factory is not dataclasses.MISSING:
            default = f.default_factory()
        else:
            msg = f"{cls.__name__}.{f.name} needs a default to be a ROS parameter"
            raise ConfigError(msg)
        if isinstance(default, tuple):
            default = list(default)
        desc = ParameterDescriptor(description=str(f.metadata.get("doc", "")), read_only=True)
        try:
            value = node.declare_parameter(f.name, default, desc).value
        except Exception as err:
            msg = f"node {node.get_name()!r}, parameter {f.name!r}: {err}"
            raise ConfigError(msg) from err
        if isinstance(default, list) and value is not None:
            value = list(value)
        values[f.name] = tuple(value) if isinstance(f.default, tuple) else value
    try:
        return cls(**values)
    except (TypeError, ValueError) as err:
        msg = f"node {node.get_name()!r}: {err}"
        raise ConfigError(msg) from err
