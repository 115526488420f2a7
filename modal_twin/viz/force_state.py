"""Residual force-state maps (Eq. (20) of [003]): which effect is missing.

The residual restoring force of the nominal law against drift, coloured by velocity, at a
component (a loop: hysteresis / friction; an odd curve: stiffness nonlinearity; a jump at
velocity reversal: friction; a line: a k or c error; a cloud: noise).
"""

from __future__ import annotations

from pathlib import Path

from modal_twin._types import FloatArray
from modal_twin.diagnosis.device_kind import measured_device
from modal_twin.diagnosis.fitting import simulate_record
from modal_twin.diagnosis.pipeline import Diagnosis
from modal_twin.diagnosis.record import Record
from modal_twin.models.loading import load_model
from modal_twin.models.versions import read_version
from modal_twin.validation import check_name

__all__ = ["plot_force_state"]


def plot_force_state(
    drift: FloatArray,
    force: FloatArray,
    k: FloatArray,
    c: FloatArray,
    fs_hz: float,
    out_png: str | Path,
    *,
    title: str = "",
    fitted_force: FloatArray | None = None,
) -> Path:
    """Write a PNG with one panel per direction (x, y).

    Residual ``f - (k u + c u')`` vs ``u``, coloured by ``u'``; with ``fitted_force`` a
    second row shows what is left after the candidate law.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from modal_twin.diagnosis.evidence import velocity_cutoff
    from modal_twin.diagnosis.screening import drift_velocity

    v = drift_velocity(drift, fs_hz, velocity_cutoff(drift, fs_hz))
    rows = 2 if fitted_force is not None else 1
    fig, axes = plt.subplots(rows, drift.shape[0], figsize=(9, 3.8 * rows), squeeze=False)
    step = max(1, drift.shape[1] // 8000)
    for d in range(drift.shape[0]):
        r = force[d] - (k[d] * drift[d] + c[d] * v[d])
        panels = [(r, "nominal law")]
        if fitted_force is not None:
            panels.append((force[d] - fitted_force[d], "with the candidate"))
        for row, (res, label) in enumerate(panels):
            ax = axes[row, d]
            sc = ax.scatter(1e3 * drift[d, ::step], 1e-3 * res[::step], c=v[d, ::step], s=2,
                            cmap="coolwarm")
            ax.set_xlabel(f"drift {'xy'[d]}, mm")
            ax.set_ylabel("residual force, kN")
            ax.set_title(f"{label} ({'xy'[d]})", fontsize=9)
            ax.grid(True, alpha=0.3)
            fig.colorbar(sc, ax=ax, label="velocity, m/s")
    fig.suptitle(title or "residual force-state map")
    fig.tight_layout()
    out = Path(out_png)
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return out


def force_state_plots(model_file: str | Path, diag: Diagnosis, rec: Record,
                      folder: str | Path, *, n: int = 2) -> list[Path]:
    """Write residual force-state maps (before / after) as PNG files in ``folder``.

    One per component of the top ``n`` fitted candidates.
    """
    mv = read_version(model_file)
    factory = load_model(mv.structure, theta=mv.theta or None)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    out: list[Path] = []
    chans = factory.plant().channels
    for f in diag.fitted[:n]:
        comp = f.effect.component
        cols = measured_device(chans, rec, comp)  # by role and place
        if cols is None:
            continue
        plant = factory.plant([*mv.effects, f.effect])
        fitted = simulate_record(plant, rec.with_channels(cols[1]))
        spec = factory.sites[comp]
        out.append(plot_force_state(
            rec.channels(cols[0]), rec.channels(cols[1]), spec.k, spec.c, rec.fs_hz,
            folder / check_name(f"force_state_{comp}_{f.effect.law}.png", "figure name"),
            title=f"{comp}: residual of the nominal law and with {f.effect.law}",
            fitted_force=fitted))
    return out
