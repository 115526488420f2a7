"""Channel-map files (JSON or YAML) and their application to imported channels.

A map file holds ``{"channels": [{"name": ..., "role": ..., "quantity": ..., ...}]}``
(:func:`modal_twin.channels.channel_map_to_dict`). A user map given to ``modal-twin
import --map`` overrides, per channel name, the fields it states; a name the data does
not have is an error (the map does not fit the data).
"""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

from modal_twin.channels import ChannelSpec, channel_map_from_dict, channel_map_to_dict
from modal_twin.errors import ConfigError
from modal_twin.yaml_files import read_yaml

__all__ = ["MAP_FILE", "apply_map", "read_channel_map", "write_channel_map"]

MAP_FILE = "channel_map.json"
"""Name of the channel map written inside an imported bag folder."""


def read_channel_map(path: str | Path) -> list[ChannelSpec]:
    """Channels of a map file (``.json``, ``.yaml`` / ``.yml``), or of a bag's map.

    Raises
    ------
    ConfigError
        Missing or malformed file.
    """
    p = Path(path)
    if p.is_dir():
        p = p / MAP_FILE
    if not p.is_file():
        msg = f"{p}: channel map not found"
        raise ConfigError(msg)
    if p.suffix.lower() == ".json":
        try:
            d: Any = json.loads(p.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError) as err:
            msg = f"{p}: expected a JSON channel map, got unreadable text ({err})"
            raise ConfigError(msg) from err
    else:
        d = read_yaml(p, "channel map")
    return channel_map_from_dict(d, str(p))


def apply_map(channels: list[ChannelSpec], user: list[ChannelSpec], given: list[set[str]],
              source: str) -> list[ChannelSpec]:
    """Channels with the fields a user map states replaced.

    Parameters
    ----------
    channels : list of ChannelSpec
        As read from the data files.
    user : list of ChannelSpec
        The map's channels.
    given : list of set of str
        For each map channel, the keys the map file states (the others keep the data's).
    source : str
        Map file name for messages.

    Raises
    ------
    ConfigError
        A map channel the data do not have.
    """
    index = {c.name: k for k, c in enumerate(channels)}
    missing = [u.name for u in user if u.name not in index]
    if missing:
        msg = (f"{source}: channel map does not fit the data: channels {missing} are not in "
               f"the record (it has {sorted(index)})")
        raise ConfigError(msg)
    out = list(channels)
    fields = {"role": "role", "quantity": "quantity", "location": "location", "node": "node",
              "direction": "direction", "sensitivity": "sensitivity", "position_m": "position_m"}
    for u, keys in zip(user, given, strict=True):
        k = index[u.name]
        changes = {f: getattr(u, f) for key, f in fields.items() if key in keys}
        out[k] = replace(out[k], **changes)
    return out


def map_keys(path: str | Path) -> list[set[str]]:
    """Return the keys each channel of a map file states (for :func:`apply_map`)."""
    p = Path(path)
    d = json.loads(p.read_text()) if p.suffix.lower() == ".json" else read_yaml(p, "map")
    return [set(r) for r in d.get("channels", [])]


def write_channel_map(path: str | Path, channels: list[ChannelSpec], **extra: Any) -> Path:
    """Write a channel map as JSON (``extra``: record-level metadata)."""
    p = Path(path)
    p.write_text(json.dumps(_finite(channel_map_to_dict(channels, **extra)), indent=1,
                            default=str, allow_nan=False))
    return p


def _finite(obj: Any) -> Any:
    """NaN / Inf -> None, recursively (strict JSON has no NaN)."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    return obj
