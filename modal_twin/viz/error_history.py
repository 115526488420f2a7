"""Plot the error history of a model line.

One line per channel group, one point per version: the picture of "add the effect and
watch the error fall".
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np

from modal_twin.models.versions import history

__all__ = ["plot_error_history"]


def plot_error_history(folder: str | Path, out_png: str | Path) -> Path:
    """Write a PNG of held-out NMSE per channel group against model version."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    versions = history(folder)
    groups: dict[str, list[list[float]]] = defaultdict(lambda: [[] for _ in versions])
    for i, v in enumerate(versions):
        for ch, e in v.errors.items():
            loc, _, d = ch.rpartition("_")
            groups[f"{loc.split('_')[0]} {d}"][i].append(e)
    fig, ax = plt.subplots(figsize=(8, 4.5))
    x = np.arange(len(versions))
    for key, per_version in sorted(groups.items()):
        y = [float(np.mean(vals)) if vals else np.nan for vals in per_version]
        if np.nanmax(y) > 0.05:
            ax.semilogy(x, y, marker="o", label=key)
    ax.set_xticks(x, [f"{v.label}\n{v.note[:28]}" for v in versions], fontsize=7)
    ax.set_ylabel("held-out NMSE, %")
    ax.set_title("error history per channel group")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=3)
    fig.tight_layout()
    out = Path(out_png)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
