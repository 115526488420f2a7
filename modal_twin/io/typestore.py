"""rosbags typestore with modal_twin_msgs registered from the same .msg files rosidl builds.

One source of truth: the ``.msg`` files of ``msg_defs/`` (installed by rosidl under
``<prefix>/share/modal_twin_msgs/msg``) are parsed here with rosbags, so a bag writes the
same definitions (and type hashes) that the live topics use.
"""

from __future__ import annotations

import functools
import os
import sys
from pathlib import Path
from typing import Any

from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from modal_twin.errors import ConfigError

__all__ = ["known_types", "msg_dirs", "typestore"]

PKG = "modal_twin_msgs"


def msg_dirs() -> Path:
    """Folder holding ``msg/`` and ``srv/`` of modal_twin_msgs (source tree first)."""
    candidates = [Path(__file__).resolve().parents[2] / "msg_defs"]
    prefixes = [p for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    prefixes.append(sys.prefix)
    candidates += [Path(p) / "share" / PKG for p in prefixes]
    for c in candidates:
        if (c / "msg" / "SignalBlock.msg").is_file():
            return c
    msg = f"cannot find the {PKG} .msg files; looked in {[str(c) for c in candidates]}"
    raise ConfigError(msg)


@functools.cache
def typestore() -> Any:
    """Jazzy typestore with every modal_twin_msgs message registered."""
    store = get_typestore(Stores.ROS2_JAZZY)
    types: dict[str, Any] = {}
    for f in sorted((msg_dirs() / "msg").glob("*.msg")):
        types.update(get_types_from_msg(f.read_text(), f"{PKG}/msg/{f.stem}"))
    store.register(types)
    return store


def known_types() -> list[str]:
    """All message types a bag can hold (modal_twin_msgs and the Jazzy standard set)."""
    return sorted(typestore().fielddefs)
