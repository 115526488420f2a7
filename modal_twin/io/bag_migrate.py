"""Read bags written with older definitions of our messages (fields added since).

A bag stores the definition each topic was recorded with. When it differs from the
project's ``.msg`` files (a field added since, e.g. ``ChannelInfo.role``), every message of
that topic is decoded with the bag's own definition and re-encoded with the project's: the
fields both know keep their values, new fields get their zero value ("" / 0 / empty), and
fields the project dropped are left out. Replay and the readers then see one definition.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import numpy as np
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Nodetype

__all__ = ["migrator"]

log = logging.getLogger(__name__)

_NUMERIC = {"bool": np.bool_, "byte": np.uint8, "char": np.uint8, "int8": np.int8,
            "uint8": np.uint8, "int16": np.int16, "uint16": np.uint16, "int32": np.int32,
            "uint32": np.uint32, "int64": np.int64, "uint64": np.uint64,
            "float32": np.float32, "float64": np.float64}


def _strip(text: str) -> str:
    return "\n".join(ln.split("#", 1)[0].strip() for ln in text.splitlines()
                     if ln.split("#", 1)[0].strip())


def migrator(msgtype: str, bag_definition: str, store: Any) -> Callable[[bytes], bytes] | None:
    """Re-encoder of ``msgtype`` messages from the bag's definition to ``store``'s.

    None when nothing needs doing: the definitions agree, the bag has none, or the type
    is not one ``store`` knows (then the bytes are passed on as they are).
    """
    if not bag_definition or msgtype not in store.fielddefs:
        return None
    ours = store.generate_msgdef(msgtype, ros_version=2)[0]
    if _strip(ours) == _strip(bag_definition):
        return None
    old = get_typestore(Stores.EMPTY)
    old.register(get_types_from_msg(bag_definition, msgtype))
    log.info("bag topic of %s was recorded with an older definition: converting its "
             "messages (new fields empty)", msgtype)

    def convert(raw: bytes) -> bytes:
        value = _build(msgtype, store, old.deserialize_cdr(raw, msgtype))
        return bytes(store.serialize_cdr(value, msgtype))

    return convert


def _default(node: tuple[Any, Any], store: Any) -> Any:
    kind, detail = node
    if kind == Nodetype.BASE:
        name = detail[0]
        return "" if name in ("string", "wstring") else _NUMERIC[name](0).item()
    if kind == Nodetype.NAME:
        return _build(detail, store, None)
    sub, n = detail
    if sub[0] == Nodetype.BASE and sub[1][0] in _NUMERIC:
        return np.zeros(n if kind == Nodetype.ARRAY else 0, dtype=_NUMERIC[sub[1][0]])
    return [_default(sub, store) for _ in range(n if kind == Nodetype.ARRAY else 0)]


def _value(node: tuple[Any, Any], value: Any, store: Any) -> Any:
    kind, detail = node
    if kind == Nodetype.NAME:
        return _build(detail, store, value)
    if kind in (Nodetype.ARRAY, Nodetype.SEQUENCE) and detail[0][0] == Nodetype.NAME:
        return [_build(detail[0][1], store, v) for v in value]
    return value


def _build(msgtype: str, store: Any, old: Any) -> Any:
    fields = store.fielddefs[msgtype][1]
    kwargs = {name: (_value(node, getattr(old, name), store)
                     if old is not None and hasattr(old, name) else _default(node, store))
              for name, node in fields}
    return store.types[msgtype](**kwargs)

