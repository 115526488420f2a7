"""``modal-twin ride [VEHICLE] --speed KMH``: ride indices and hunting of the 3D vehicle.

Runs the 3D vehicle file (default ``config/vehicles/trailer_car_3d.yaml``) over a random
German track (low or high interference) and prints, per floor point of [002] Sec. 5, the
Sperling indices Wz and Wy and the floor-PSD peaks, the carbody's modes beside them (the
carbody-shaking check) and the hunting critical speed from the eigenvalue sweep. With
``--sweep A:B:STEP`` (km/h) it prints one line per speed instead.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin.errors import OptionError
from modal_twin.exit_codes import ExitCode

__all__ = ["register", "run", "vehicle3d_info", "with_carbody_options"]

MAX_SWEEP = 60


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``ride`` parser."""
    p = sub.add_parser("ride", help="3D vehicle: Sperling indices, floor PSD, hunting speed")
    p.add_argument("vehicle", type=Path, nargs="?", default=None,
                   help="3D vehicle file (kind: vehicle3d; default trailer_car_3d.yaml)")
    p.add_argument("--speed", type=float, default=None, help="km/h (default: the file's)")
    p.add_argument("--duration", type=float, default=60.0, help="s of track (default 60)")
    p.add_argument("--fs", type=float, default=400.0, help="sample rate, Hz (default 400)")
    p.add_argument("--track", choices=("low", "high"), default="low",
                   help="German spectrum: low or high interference (default low)")
    p.add_argument("--seed", type=int, default=0, help="random phases of the track")
    p.add_argument("--sweep", default=None, metavar="A:B:STEP",
                   help="run each speed from A to B km/h in STEP and print one line each")
    p.add_argument("--carbody", choices=("rigid", "shell"), default=None,
                   help="carbody model: rigid (6 DOF) or the Craig-Bampton shell carbody "
                        "(default: the file's carbody.model)")
    p.add_argument("--carbody-params", type=Path, default=None, metavar="FILE",
                   help="zone factors of the shell carbody (carbody_zone_factors: the "
                        "carbody updating's result); implies --carbody shell")
    p.add_argument("--bending-hz", type=float, default=None, metavar="F",
                   help="add to the rigid carbody its first vertical bending (uniform "
                        "free-free beam mode at F Hz, 2 %% damping)")
    p.add_argument("--json", action="store_true", help="print the results as JSON")
    p.set_defaults(func=run)


def parse_sweep(text: str) -> list[float]:
    """``"200:400:50"`` -> ``[200, 250, ..., 400]`` km/h.

    Raises
    ------
    OptionError
        Not three numbers, ``0 < A <= B``, ``STEP > 0``, or more than :data:`MAX_SWEEP`.
    """
    parts = text.split(":")
    try:
        a, b, step = (float(x) for x in parts)
    except ValueError:
        msg = f"--sweep: expected A:B:STEP in km/h, got {text!r}"
        raise OptionError(msg) from None
    if not (all(math.isfinite(v) for v in (a, b, step)) and 0 < a <= b and step > 0):
        msg = f"--sweep: expected 0 < A <= B and STEP > 0, got {text!r}"
        raise OptionError(msg)
    n = math.floor((b - a) / step + 1e-9) + 1
    if n > MAX_SWEEP:
        msg = f"--sweep: expected at most {MAX_SWEEP} speeds, got {n}"
        raise OptionError(msg)
    return [a + k * step for k in range(n)]


def run(a: argparse.Namespace) -> int:
    """Run the ride evaluation (module docstring)."""
    from modal_twin.models.carbody_interface import with_bending_mode
    from modal_twin.models.hunting import critical_speed, hunting_branch
    from modal_twin.models.vehicle3d import build_vehicle3d
    from modal_twin.models.vehicle3d_ride import ride_run
    from modal_twin.models.vehicle3d_spec import load_vehicle3d

    spec = with_carbody_options(load_vehicle3d(a.vehicle), a)
    if a.bending_hz is not None and spec.carbody_model != "rigid":
        msg = "--bending-hz: expected the rigid carbody (the shell has its own bending modes)"
        raise OptionError(msg)
    veh = build_vehicle3d(spec)
    if a.bending_hz is not None:
        cb = with_bending_mode(veh.carbody, length=spec.v("carbody", "length"),
                               f_hz=a.bending_hz, zeta=0.02, mass=spec.v("carbody", "mass"))
        veh = build_vehicle3d(spec, cb)
    speeds = parse_sweep(a.sweep) if a.sweep else [spec.speed_kmh if a.speed is None
                                                   else float(a.speed)]
    hunt = critical_speed(veh, np.arange(10.0, 300.01, 5.0))
    vc_kmh = 3.6 * hunt.v_critical
    branch = dict(zip(speeds, zip(*hunting_branch(veh, hunt, np.array(speeds) / 3.6),
                                  strict=True), strict=True))
    if not a.sweep:
        runs = [ride_run(veh, speeds[0], duration_s=a.duration, fs_hz=a.fs, level=a.track,
                         seed=a.seed)]
    else:  # speeds above the critical one are reported as unstable
        runs = [ride_run(veh, s, duration_s=a.duration, fs_hz=a.fs, level=a.track,
                         seed=a.seed) for s in speeds if veh.is_stable(s / 3.6)]
        unstable = [s for s in speeds if not veh.is_stable(s / 3.6)]
    if a.json:
        print(json.dumps({"vehicle": spec.name, "critical_speed_kmh": _finite(vc_kmh),
                          "hunting_f_hz": _finite(hunt.f_critical_hz),
                          "runs": [_run_dict(r) | {"hunting_mode": {
                              "zeta": _finite(float(branch[r.speed_kmh][0])),
                              "f_hz": _finite(float(branch[r.speed_kmh][1]))}} for r in runs],
                          "unstable_speeds_kmh": unstable if a.sweep else []}, indent=1))
        return ExitCode.OK
    print(f"{spec.name}: {veh.n_dof} DOFs ({veh.carbody.name} carbody), "
          f"{a.track}-interference track, seed {a.seed}, {a.duration:g} s at {a.fs:g} Hz")
    print("hunting: " + (f"critical speed {vc_kmh:.0f} km/h ({hunt.f_critical_hz:.2f} Hz)"
                         if math.isfinite(vc_kmh) else "stable up to 1080 km/h"))
    if a.sweep:
        if runs:
            _print_sweep(runs, branch)
        if unstable:
            print("unstable (hunting, no ride): " + ", ".join(f"{s:g}" for s in unstable)
                  + " km/h")
    else:
        _print_run(runs[0])
        zb, fb = branch[speeds[0]]
        if math.isfinite(fb):
            print(f"hunting mode (followed from the critical speed): {fb:.2f} Hz, zeta "
                  f"{100 * zb:.1f} %")
    return ExitCode.OK


def vehicle3d_info(a: argparse.Namespace) -> int:
    """``modal-twin model info`` of a 3D vehicle file: DOFs, carbody modes, hunting speed."""
    from modal_twin.models.hunting import critical_speed
    from modal_twin.models.vehicle3d import build_vehicle3d
    from modal_twin.models.vehicle3d_ride import carbody_modes
    from modal_twin.models.vehicle3d_spec import load_vehicle3d

    spec = with_carbody_options(load_vehicle3d(a.file), a)
    veh = build_vehicle3d(spec)
    hunt = critical_speed(veh, np.arange(10.0, 300.01, 5.0))
    modes = carbody_modes(veh, spec.speed)
    show = getattr(a, "show", None)
    if show is not None:
        modes = modes[: max(int(show), 0)]
    mass = (carbody_mass(veh) + 2 * spec.v("bogie", "mass") + 4 * spec.v("wheelset", "mass")
            + sum(e.mass for e in spec.hung_equipment))
    info = {"name": spec.name, "carbody": veh.carbody.name, "n_dof": veh.n_dof,
            "n_carbody_coordinates": veh.carbody.n, "n_state": veh.n_state,
            "maxwell_elements": list(veh.maxwell_names), "total_mass_kg": mass,
            "speed_kmh": spec.speed_kmh, "critical_speed_kmh": _finite(3.6 * hunt.v_critical),
            "hunting_f_hz": _finite(hunt.f_critical_hz),
            "carbody_modes": [{"label": m.label, "f_hz": m.f_hz, "zeta": m.zeta}
                              for m in modes]}
    if a.json:
        print(json.dumps(info, indent=1))
        return ExitCode.OK
    print(f"{spec.name}: 3D vehicle, {veh.n_dof} DOFs + {len(veh.maxwell_names)} Maxwell "
          f"states ({veh.carbody.name} carbody), total mass {mass / 1e3:.2f} t; hunting "
          f"critical speed " + (f"{3.6 * hunt.v_critical:.0f} km/h "
                                f"({hunt.f_critical_hz:.2f} Hz)" if math.isfinite(
                                    hunt.v_critical) else "above 1080 km/h"))
    print(f"carbody modes at {spec.speed_kmh:g} km/h:")
    print(f"{'mode':>4} {'f [Hz]':>9} {'zeta [%]':>8}  part")
    for k, m in enumerate(modes, 1):
        print(f"{k:>4d} {m.f_hz:9.4f} {100 * m.zeta:8.2f}  carbody {m.label}")
    return ExitCode.OK


def with_carbody_options(spec: Any, a: argparse.Namespace) -> Any:
    """Apply ``--carbody`` and ``--carbody-params FILE`` (zone factors: the shell carbody).

    Raises
    ------
    OptionError
        ``--carbody-params`` with ``--carbody rigid``, or a bad factor in the file.
    ConfigError
        An unreadable or malformed zone-factor file.
    """
    from modal_twin.models.carbody3d_file import load_zone_factors

    carbody = getattr(a, "carbody", None)
    path = getattr(a, "carbody_params", None)
    if path is not None and carbody == "rigid":
        msg = "--carbody-params: expected the shell carbody (zone factors), got --carbody rigid"
        raise OptionError(msg)
    if carbody is not None or path is not None:
        spec = spec.with_carbody("shell" if path is not None else carbody)
    if path is not None:
        spec = spec.with_zone_factors(load_zone_factors(path))
    return spec


def carbody_mass(veh: Any) -> float:
    """Return the carbody's mass in the vehicle, kg (a shell carbody's rigid-body mass)."""
    src = veh.carbody.source
    rigid_mass = getattr(src, "rigid_mass", None)
    if rigid_mass is not None:
        return float(rigid_mass[0, 0])
    return float(np.trace(veh.M[:3, :3]) / 3)


def _finite(v: float) -> float | None:
    return v if math.isfinite(v) else None


def _run_dict(r: Any) -> dict[str, Any]:
    return {"speed_kmh": r.speed_kmh,
            "sperling": dict(zip(r.channels, [float(w) for w in r.W], strict=True)),
            "psd_peaks_hz": {c: [float(f) for f in p] for c, p in zip(
                r.channels, r.psd.peaks_hz, strict=True)},
            "carbody_modes": [{"label": m.label, "f_hz": m.f_hz, "zeta": m.zeta}
                              for m in r.modes],
            "kinematic_mode": {"zeta": _finite(r.kinematic[0]), "f_hz": _finite(r.kinematic[1])}}


def _print_run(r: Any) -> None:
    print(f"speed {r.speed_kmh:g} km/h; Sperling W > 3.00 is unqualified ([002] Sec. 5.2)")
    print(f"{'point':<10} {'Wz':>5} {'Wy':>5}  PSD peaks z [Hz]      PSD peaks y [Hz]")
    labels = list(dict.fromkeys(c[len("floor_"):-2] for c in r.channels))
    for lab in labels:
        iz, iy = r.channels.index(f"floor_{lab}_z"), r.channels.index(f"floor_{lab}_y")
        pz = " ".join(f"{f:5.2f}" for f in r.psd.peaks_hz[iz])
        py = " ".join(f"{f:5.2f}" for f in r.psd.peaks_hz[iy])
        print(f"{lab:<10} {r.W[iz]:5.2f} {r.W[iy]:5.2f}  {pz:<20}  {py}")
    shown = [m for m in r.modes if m.f_hz <= 20.0]  # the ride band's (all of a rigid car's)
    more = f" and {len(r.modes) - len(shown)} above 20 Hz" if len(shown) < len(r.modes) else ""
    print("carbody modes (shaking check: PSD peaks near these): " + ", ".join(
        f"{m.label} {m.f_hz:.2f} Hz ({100 * m.zeta:.0f} %)" for m in shown) + more)
    if math.isfinite(r.kinematic[0]):
        print(f"least-damped kinematic mode: {r.kinematic[1]:.2f} Hz, zeta "
              f"{100 * r.kinematic[0]:.1f} %")


def _print_sweep(runs: list[Any], branch: dict[float, tuple[float, float]]) -> None:
    mid = [c for c in runs[0].channels if "_mid_" in c] or list(runs[0].channels[:2])
    head = " ".join(f"{'W ' + c[len('floor_'):]:>9}" for c in mid)
    bend = next((m for m in runs[0].modes  # the beam mode, or the shell's first bending
                 if m.label.startswith(("bending", "vertical bending"))), None)
    extra = f"  PSD mid_z at {bend.f_hz:.2f} Hz" if bend is not None else ""
    print(f"{'km/h':>6} {head}  lateral peak [Hz]  hunting f [Hz] zeta [%]{extra}")
    for r in runs:
        ys = [i for i, c in enumerate(r.channels) if c.endswith("_y")]
        top = max(ys, key=lambda i: float(np.max(r.psd.psd[i])))
        peak = r.psd.peaks_hz[top][0] if r.psd.peaks_hz[top].size else float("nan")
        ws = " ".join(f"{r.index(c):9.2f}" for c in mid)
        tail = ""
        if bend is not None and "floor_mid_z" in r.channels:
            i = r.channels.index("floor_mid_z")
            tail = f"  {np.interp(bend.f_hz, r.psd.f_hz, r.psd.psd[i]):.2e} (m/s^2)^2/Hz"
        zb, fb = branch[r.speed_kmh]
        print(f"{r.speed_kmh:6.0f} {ws}  {peak:17.2f}  {fb:14.2f} {100 * zb:8.1f}{tail}")
