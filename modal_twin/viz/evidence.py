"""Evidence plots for the missing effect (Sec. "Diagnosis" of the design card).

* force-state map (Eq. (20) of [003]): restoring force against drift and velocity -- a
  loop means hysteresis or friction, an odd curve a stiffness nonlinearity, a jump at
  velocity reversal friction, a line a k or c error;
* amplitude dependence: energy dissipated per cycle and secant stiffness against drift
  amplitude -- flat for a linear law, rising energy / falling stiffness for friction and
  hysteresis (the numbers come from the caller; here only the pictures).
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import ArrayLike

from modal_twin.errors import ShapeError
from modal_twin.viz._figure import new_figure

__all__ = ["plot_amplitude_dependence", "plot_force_state_surface"]


def plot_force_state_surface(drift_m: ArrayLike, velocity_m_s: ArrayLike, force_n: ArrayLike,
                             *, max_points: int = 8000, title: str = "force-state map"
                             ) -> Figure:
    """Force against drift (coloured by velocity) and against velocity (coloured by drift).

    Parameters
    ----------
    drift_m, velocity_m_s, force_n : (n,) array_like
        Samples of one device direction (the force may be a residual force).
    max_points : int
        Samples drawn (evenly thinned).
    title : str

    Returns
    -------
    matplotlib.figure.Figure
        Two scatter axes (and their colour bars).

    Raises
    ------
    ShapeError
        Arrays of different lengths.
    """
    u, v, f = (np.ravel(np.asarray(a, dtype=float)) for a in (drift_m, velocity_m_s, force_n))
    if not (u.size == v.size == f.size):
        msg = f"drift, velocity, force: expected equal lengths, got {u.size}, {v.size}, {f.size}"
        raise ShapeError(msg)
    step = max(1, u.size // max_points)
    u, v, f = u[::step], v[::step], f[::step]
    fig = new_figure(10.0, 4.0)
    a1, a2 = fig.subplots(1, 2)
    s1 = a1.scatter(1e3 * u, 1e-3 * f, c=v, s=2, cmap="coolwarm")
    a1.set_xlabel("drift, mm")
    a1.set_ylabel("force, kN")
    fig.colorbar(s1, ax=a1, label="velocity, m/s")
    s2 = a2.scatter(v, 1e-3 * f, c=1e3 * u, s=2, cmap="viridis")
    a2.set_xlabel("velocity, m/s")
    fig.colorbar(s2, ax=a2, label="drift, mm")
    for ax in (a1, a2):
        ax.grid(True, alpha=0.3)
    fig.suptitle(title, fontsize=10)
    return fig


def plot_amplitude_dependence(amplitude_m: ArrayLike, energy_j: ArrayLike,
                              k_secant_n_m: ArrayLike, *,
                              model_energy_j: ArrayLike | None = None,
                              model_k_n_m: ArrayLike | None = None,
                              title: str = "amplitude dependence") -> Figure:
    """Dissipated energy per cycle and secant stiffness against drift amplitude.

    Returns
    -------
    matplotlib.figure.Figure
        Two axes (energy, stiffness); measured points black, model red.
    """
    a = np.ravel(np.asarray(amplitude_m, dtype=float))
    e = np.ravel(np.asarray(energy_j, dtype=float))
    k = np.ravel(np.asarray(k_secant_n_m, dtype=float))
    if not (a.size == e.size == k.size):
        msg = (f"amplitude, energy, k_secant: expected equal lengths, got {a.size}, "
               f"{e.size}, {k.size}")
        raise ShapeError(msg)
    fig = new_figure(10.0, 3.8)
    a1, a2 = fig.subplots(1, 2, sharex=True)
    o = np.argsort(a)
    a1.plot(1e3 * a[o], e[o], "ko-", ms=3, lw=0.8, label="measured")
    a2.plot(1e3 * a[o], 1e-3 * k[o], "ko-", ms=3, lw=0.8, label="measured")
    if model_energy_j is not None:
        a1.plot(1e3 * a[o], np.ravel(np.asarray(model_energy_j, float))[o], "r--", label="model")
    if model_k_n_m is not None:
        a2.plot(1e3 * a[o], 1e-3 * np.ravel(np.asarray(model_k_n_m, float))[o], "r--",
                label="model")
    a1.set_ylabel("energy dissipated per cycle, J")
    a2.set_ylabel("secant stiffness, kN/m")
    for ax in (a1, a2):
        ax.set_xlabel("drift amplitude, mm")
        ax.grid(True, alpha=0.3)
    a2.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8, frameon=False)
    fig.suptitle(title, fontsize=10)
    return fig
