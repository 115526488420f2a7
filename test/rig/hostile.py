"""Hostile message and request values for the fuzz test and the reliability benchmark."""

from __future__ import annotations

import contextlib
import copy
import math
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

HUGE_DOUBLES = 2_000_000  # 16 MB of samples in one message

EXTREME: dict[str, list[Any]] = {
    "double": [math.inf, -math.inf, math.nan, 1e308, -1e308, 0.0, -1.0, 5e-324],
    "uint32": [0, 4294967295, 1],
    "uint64": [0, 2**64 - 1],
    "boolean": [True, False],
    "string": ["", "../../../tmp/escape", "/dev/zero", "x" * 100_000, "\u00e9\u4e2d", "*"],
    "sequence<string>": [[], ["a"] * 10_000, ["", ""], ["x" * 1000], ["ax", "ax"]],
    "sequence<double>": [[], [math.nan] * 10, [math.inf], "huge"],
}


def _value(kind: str, v: Any) -> Any:
    if v == "huge":
        return np.ones(HUGE_DOUBLES).tolist()
    return copy.deepcopy(v)


def _random(kind: str, rng: np.random.Generator) -> Any:
    if kind == "double":
        scale = 10.0 ** int(rng.integers(-5, 12))
        return float(rng.choice([rng.normal() * scale, rng.uniform(-1e3, 1e3)]))
    if kind == "uint32":
        return int(rng.integers(0, 2**32))
    if kind == "uint64":
        return int(rng.integers(0, 2**63))
    if kind == "boolean":
        return bool(rng.integers(0, 2))
    if kind == "string":
        return "".join(chr(int(c)) for c in rng.integers(32, 0x2FF, size=rng.integers(0, 40)))
    if kind == "sequence<string>":
        return [f"c{int(i)}" for i in rng.integers(0, 50, size=rng.integers(0, 80))]
    if kind == "sequence<double>":
        return rng.normal(size=int(rng.integers(0, 500))).tolist()
    return None


def hostile(make: Callable[[], Any], rng: np.random.Generator, n_random: int = 5
            ) -> Iterator[Any]:
    """Messages from ``make()`` with one field at a time set to each extreme value of its
    type, then ``n_random`` with every field random (values the type cannot hold skipped)."""
    fields = make().get_fields_and_field_types()
    for name, kind in fields.items():
        for v in EXTREME.get(kind, []):
            msg = make()
            try:
                setattr(msg, name, _value(kind, v))
            except (AssertionError, ValueError, TypeError, OverflowError):
                continue
            yield msg
    for _ in range(n_random):
        msg = make()
        for name, kind in fields.items():
            v = _random(kind, rng)
            if v is None:
                continue
            with contextlib.suppress(AssertionError, ValueError, TypeError, OverflowError):
                setattr(msg, name, v)
        yield msg
