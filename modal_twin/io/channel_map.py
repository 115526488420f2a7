"""Channel-map files (JSON or YAML) and their application to imported channels.

A map file holds ``{"channels": [{"name": ..., "role": ..., "quantity": ..., ...}]}``
(:func:`modal_twin.channels.channel_map_to_dict`). A user map given to ``modal-twin
import --map`` overrides, per channel name, the fields it states; a name the data does
not have is an error (the map does not fit the data).

Without a map, :func:`roles_from_locations` gives strong-motion channels their role from
the sensor location their header states (CSMIP ``Location:``, SMC ``<loclbl=>``):

1. **base** words (free field, on ground, ground / grnd level, ground floor, basement,
   footing, foundation, pile cap, column base, an abutment with no structure word) ->
   ``input``: the motion the structure is driven by;
2. **structure** words (deck, roof, top, floor or level with a number, midspan, girder,
   story, penthouse) -> ``output``;
3. one input per support and direction: base sensors of one named support (``Bent 4``,
   ``Abutment 1``, ``Pier 2``, ``East Abutment``) in one direction are one motion; one
   stays ``input``, the others become ``reference``: not the lower end of a member that
   also carries a structure sensor (``North Column, Grnd Level`` under ``North Column,
   Top``: a drift pair), then the largest peak (best signal to noise);
4. a vertical sensor on the deck over a support (a structure word with abutment / bent /
   pier, not midspan) follows the support's vertical motion and carries no vertical
   mode: ``reference``;
5. a vertical base motion measured at one named support only, where base motion is
   measured at several, is a partial input (the other supports drive the deck
   vertically too, unmeasured): ``reference``;
6. a location with neither kind of word, or with both, cannot be told: no role (the import
   then refuses and asks for ``--map``).
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

from modal_twin.channels import ChannelSpec, channel_map_from_dict, channel_map_to_dict
from modal_twin.errors import ConfigError
from modal_twin.yaml_files import read_text, read_yaml

__all__ = ["MAP_FILE", "apply_map", "read_channel_map", "roles_from_locations",
           "write_channel_map"]

MAP_FILE = "channel_map.json"
"""Name of the channel map written inside an imported bag folder."""


def read_channel_map(path: str | Path) -> list[ChannelSpec]:
    """Channels of a map file (``.json``, ``.yaml`` / ``.yml``), or of a bag's map.

    Bounded before parsing (:func:`modal_twin.yaml_files.read_text`,
    :func:`~modal_twin.yaml_files.read_yaml`).

    Raises
    ------
    ConfigError
        Missing, malformed or too large file.
    """
    p = Path(path)
    if p.is_dir():
        p = p / MAP_FILE
    if not p.is_file():
        msg = f"{p}: channel map not found"
        raise ConfigError(msg)
    if p.suffix.lower() == ".json":
        try:
            d: Any = json.loads(read_text(p, "channel map"))
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
    d = (json.loads(read_text(p, "map")) if p.suffix.lower() == ".json"
         else read_yaml(p, "map"))
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


_BASE = re.compile(
    r"free[ -]?field|on ground|\bgr(?:ou)?nd\b\.?(?:\s*(?:level|floor|surface|lvl))?"
    r"|basement|footing|foundation|pile[ -]?cap|column base|base of column|base slab",
    re.IGNORECASE)
"""Location words of a sensor measuring the motion the structure stands on."""
_STRUCTURE = re.compile(
    r"\bdeck\b|\broof\b|\btop\b|\bmid-?span\b|middle of \w+ span|girder|penthouse"
    r"|\b(?:floor|level|lvl|story|storey)\s*\d+|\d+(?:st|nd|rd|th)?\s*(?:floor|level|story|storey)"
    r"|\bmezzanine\b",
    re.IGNORECASE)
"""Location words of a sensor on the structure itself."""
_ABUTMENT = re.compile(r"^\W*abut(?:ment)?\b", re.IGNORECASE)
_SUPPORT = re.compile(r"(?:\b(north|south|east|west|middle|center|centre)\s+)?"
                      r"\b(abut(?:ment)?|bent|pier)s?\b\.?\s*(\d+[a-z]?)?", re.IGNORECASE)
_MIDSPAN = re.compile(r"mid-?span|middle of \w+ span|between", re.IGNORECASE)
_VERTICAL = {"up", "down", "dn", "vert", "vertical", "z"}


def _support(location: str) -> str:
    """Named support of a location (``"bent 4"``, ``"abutment 1"``, ``"east abutment"``)."""
    m = _SUPPORT.search(location)
    if m is None:
        return ""
    kind = "abutment" if m.group(2).lower().startswith("abut") else m.group(2).lower()
    return " ".join(w for w in ((m.group(1) or "").lower(), kind, (m.group(3) or "").lower())
                    if w)


def _member(location: str) -> str:
    """Location without its base / structure words: the member a sensor sits on."""
    rest = _STRUCTURE.sub(" ", _BASE.sub(" ", location.lower()))
    return " ".join(re.findall(r"[a-z0-9]+", rest))


def roles_from_locations(locations: Sequence[str], orientations: Sequence[str],
                         peaks: Sequence[float]) -> list[tuple[str, str]]:
    """Role of each strong-motion channel from its header's location text (module docstring).

    Parameters
    ----------
    locations : sequence of str
        Sensor location as the header states it.
    orientations : sequence of str
        ``"Up"`` / ``"Long"`` / ``"Tran"`` or an azimuth in degrees (horizontal).
    peaks : sequence of float
        Peak absolute acceleration of each channel (any one unit), for rule 3.

    Returns
    -------
    list of (role, why)
        ``role`` is ``"input"``, ``"output"``, ``"reference"`` or ``""`` (cannot tell);
        ``why`` quotes the header words that decided it.
    """
    out = [_word_role(loc) for loc in locations]
    groups: dict[tuple[str, str], list[int]] = {}
    for k, (loc, ori) in enumerate(zip(locations, orientations, strict=True)):
        o, sup = ori.strip().lower(), _support(loc)
        if out[k][0] == "input" and sup:
            try:
                axis = f"{float(o) % 180.0:.0f}"
            except ValueError:
                axis = o
            groups.setdefault((sup, axis), []).append(k)
        elif out[k][0] == "output" and o in _VERTICAL and sup and not _MIDSPAN.search(loc):
            out[k] = ("reference", f"{out[k][1]}, vertical over support {sup!r}: follows "
                                   f"the support")
    supports = {sup for sup, _ in groups}
    up = {sup for sup, axis in groups if axis in _VERTICAL}
    partial = len(up) == 1 and len(supports) >= 2
    for (sup, axis), idx in groups.items():
        if axis in _VERTICAL and partial:
            for k in idx:
                out[k] = ("reference", f"{out[k][1]}; vertical base motion at {sup!r} only, "
                                       f"of {len(supports)} supports measured: a partial input")
        elif len(idx) > 1:
            _one_per_support(out, idx, f"{sup!r} {axis}", locations, peaks)
    return out


def _word_role(loc: str) -> tuple[str, str]:
    """Rules 1, 2 and 6 of the module docstring for one location."""
    top = _STRUCTURE.search(loc)
    base = _BASE.search(loc) or (None if top else _ABUTMENT.search(loc))
    if base and top:
        return "", f"both base {base.group(0)!r} and structure {top.group(0)!r} words in {loc!r}"
    if base:
        return "input", f"base word {base.group(0)!r}"
    if top:
        return "output", f"structure word {top.group(0)!r}"
    return "", f"no base or structure word in {loc!r}"


def _one_per_support(out: list[tuple[str, str]], idx: list[int], what: str,
                     locations: Sequence[str], peaks: Sequence[float]) -> None:
    """Rule 3: keep one input of the base sensors ``idx`` of one support and direction."""
    members = {_member(loc) for loc, r in zip(locations, out, strict=True) if r[0] == "output"}
    keep = max(idx, key=lambda k: (_member(locations[k]) not in members, peaks[k]))
    for k in idx:
        if k == keep:
            continue
        mk = _member(locations[k])
        because = (f"{mk!r} also carries a structure sensor: a drift pair"
                   if mk in members and _member(locations[keep]) not in members
                   else f"peak {peaks[keep]:.3g} > {peaks[k]:.3g}")
        out[k] = ("reference", f"{out[k][1]}; one input per support: {what} kept at "
                               f"{locations[keep]!r} ({because})")
