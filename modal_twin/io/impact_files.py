"""A hammer test's result on disk: the FRF matrix as UFF 58 and the hits' verdicts as YAML.

Written into a folder (a run's ``impact/``) under fixed names, each to a temporary path
and renamed, so a reader never sees half a file.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import yaml

from modal_twin.acquisition.hammer_test import HammerResult
from modal_twin.channels import ChannelSpec
from modal_twin.io.uff import AXIS_CODES, write_uff58_frf

__all__ = ["FRF_FILE", "SUMMARY_FILE", "dof_codes", "write_hammer_result"]

FRF_FILE = "frf.uff"
SUMMARY_FILE = "hits.yaml"


def dof_codes(channels: Sequence[ChannelSpec]) -> list[tuple[int, int]]:
    """(node, UFF direction code) of each channel: its node, else its index + 1; +x if unknown."""
    out = []
    for k, c in enumerate(channels):
        node = int(c.node) if c.node.isdigit() and int(c.node) > 0 else k + 1
        out.append((node, AXIS_CODES.get(c.direction, 1)))
    return out


def write_hammer_result(folder: str | Path, res: HammerResult) -> tuple[Path, Path]:
    """Write ``frf.uff`` (UFF 58, function type 4) and ``hits.yaml`` into ``folder``.

    The FRFs are written from the first line above 0 Hz; ``hits.yaml`` lists the counts,
    each point's hits with verdict and reason, and the channels' UFF node / direction.
    """
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    keep = res.f_hz > 0
    frf_path = out / FRF_FILE
    tmp = out / f".{FRF_FILE}.tmp"
    rsp, ref = dof_codes(res.outputs), dof_codes(res.inputs)
    write_uff58_frf(tmp, res.f_hz[keep], res.H[:, :, keep], rsp, ref)
    os.replace(tmp, frf_path)
    summary = {
        "estimator": res.estimator, "block_s": res.block_s,
        "hits_averaged": res.n_accepted, "hits_rejected": res.n_rejected,
        "outputs": [{"name": c.name, "node": n, "dir": d}
                    for c, (n, d) in zip(res.outputs, rsp, strict=True)],
        "points": [{"name": c.name, "node": n, "dir": d, "averaged": p.n_averages,
                    "min_coherence": float(np.min(p.coherence[:, keep])) if keep.any() else 0.0,
                    "hits": [{"start_sample": h.start, "accepted": h.accepted,
                              "reason": h.reason, "peak_n": round(h.peak_n, 6)}
                             for h in p.hits]}
                   for c, (n, d), p in zip(res.inputs, ref, res.per_point, strict=True)],
    }
    sum_path = out / SUMMARY_FILE
    tmp2 = out / f".{SUMMARY_FILE}.tmp"
    tmp2.write_text(yaml.safe_dump(summary, sort_keys=False))
    os.replace(tmp2, sum_path)
    return frf_path, sum_path
