"""Excitation commands (message) -> a checked :class:`ExcitationConfig`."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from modal_twin.excitation.drive import ExcitationConfig
from modal_twin.validation import check_array_budget, check_field, check_request_path

__all__ = ["config_from_command"]


def config_from_command(msg: Any, base: ExcitationConfig,
                        record_roots: Sequence[str | Path]) -> ExcitationConfig:
    """``ExcitationCommand`` -> the configuration it asks for, on top of ``base``.

    Zero / empty fields (``kind`` too) keep the value of ``base``. Every field is checked against
    :data:`~modal_twin.validation.LIMITS` and the drive's size against the memory budget
    before anything is generated; ``record_path`` must be a regular file inside
    ``record_roots``.

    Raises
    ------
    OptionError
        Naming the first field out of its limits.
    """
    fields: dict[str, Any] = {"kind": str(msg.kind)} if msg.kind else {}
    if msg.channels:
        fields["channels"] = tuple(str(c) for c in msg.channels)
        check_field(len(fields["channels"]), "command.channels (count)", "n_channels")
    for name, key, kind in (("duration_s", "duration_s", "duration_s"),
                            ("sample_rate_hz", "fs_hz", "sample_rate_hz"),
                            ("f_min_hz", "f_min_hz", "frequency_hz"),
                            ("f_max_hz", "f_max_hz", "frequency_hz"),
                            ("amplitude", "rms", "amplitude")):
        value = getattr(msg, name)
        if value != 0:
            v = check_field(value, f"command.{name}", kind)
            fields[key] = (v,) if key == "rms" else v
    if msg.record_path:
        fields["record_path"] = str(check_request_path(msg.record_path, "command.record_path",
                                                       record_roots))
        fields["record_scale"] = check_field(msg.record_scale or 1.0, "command.record_scale",
                                             "record_scale")
    if msg.seed:
        fields["seed"] = check_field(msg.seed, "command.seed", "seed")
    cfg = dataclasses.replace(base, **fields)
    check_array_budget((len(cfg.channels), int(cfg.duration_s * cfg.fs_hz) + 1),
                       "command.duration_s x sample_rate_hz x channels")
    return cfg
