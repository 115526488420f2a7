"""``modal-twin identify BAG --method n4sid|ssi-cov|polymax``: modes of an imported record.

Inputs and outputs come from the roles of the bag's channel map (``--inputs`` /
``--outputs`` override them). The band, decimation, block rows and orders are chosen
from the record (:mod:`modal_twin.identification.auto`) and printed. When the default
stability thresholds (1 % frequency, 5 % damping, MAC 0.95) give no mode, the run is
repeated once with relaxed ones (2 %, 20 %, 0.9; short or weak records) and says so.
Writes ``modes.json``, ``modes.uff`` (UFF 55), ``stabilization.png`` and ``mac.png``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin.channels import ChannelSpec
from modal_twin.errors import OptionError, SignalError
from modal_twin.exit_codes import ExitCode

__all__ = ["register", "run"]

METHODS = ("n4sid", "ssi-cov", "polymax")
STRICT = {"rel_tol_f": 0.01, "rel_tol_zeta": 0.05, "mac_min": 0.95}
RELAXED = {"rel_tol_f": 0.02, "rel_tol_zeta": 0.2, "mac_min": 0.9}
NONSTATIONARY = 4.0
"""Largest / smallest window RMS above which output-only SSI is warned about."""


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``identify`` to the sub-commands."""
    p = sub.add_parser("identify", help="modes of a bag (N4SID, SSI-cov, PolyMAX)")
    p.add_argument("bag", type=Path, help="bag written by `modal-twin import` (or a run)")
    p.add_argument("--method", choices=METHODS, default=None,
                   help="default: n4sid when the bag has inputs, else ssi-cov")
    p.add_argument("--out", type=Path, default=None, help="folder for JSON, UFF 55, PNGs")
    p.add_argument("--f-max", type=float, default=None, help="upper band edge, Hz")
    p.add_argument("--inputs", default=None, help="comma list of input channels")
    p.add_argument("--outputs", default=None, help="comma list of output channels")
    p.add_argument("--directions", default=None,
                   help="keep only channels of these directions (e.g. x,y)")
    p.set_defaults(func=run)


def _pick(channels: list[ChannelSpec], role: str, names: str | None,
          dirs: set[str] | None) -> list[ChannelSpec]:
    by = {c.name: c for c in channels}
    if names:
        want = [n.strip() for n in names.split(",") if n.strip()]
        missing = [n for n in want if n not in by]
        if missing:
            msg = f"--{role}s: channels {missing} not in the bag (it has {sorted(by)})"
            raise OptionError(msg)
        return [by[n] for n in want]
    out = [c for c in channels if c.effective_role == role]
    return [c for c in out if dirs is None or c.direction in dirs]


def _corners(channels: list[ChannelSpec]) -> tuple[float, float]:
    lo, hi = [], []
    for c in channels:
        f = dict(c.meta).get("filter_hz")
        if f and len(f) == 2:
            lo.append(f[0] if f[0] is not None else math.nan)
            hi.append(f[1] if f[1] is not None else math.nan)
    lo_v = max((v for v in lo if math.isfinite(v)), default=math.nan)
    hi_v = min((v for v in hi if math.isfinite(v)), default=math.nan)
    return lo_v, hi_v


def _sweep(method: str, u: np.ndarray, y: np.ndarray, fs: float, s: Any) -> Any:
    try:
        return _run_method(method, u, y, fs, s)
    except np.linalg.LinAlgError as err:
        msg = (f"{method}: the data are rank-deficient at these settings ({err}); noise-free "
               f"or duplicated channels? Try fewer channels or a lower --f-max")
        raise SignalError(msg) from err


def _run_method(method: str, u: np.ndarray, y: np.ndarray, fs: float, s: Any) -> Any:
    from modal_twin.identification import n4sid, polymax, ssi_cov

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # fewer std blocks on short records
        if method == "n4sid":
            return n4sid(u, y, fs, orders=s.orders, block_rows=s.block_rows, n_blocks_std=4)
        if method == "ssi-cov":
            return ssi_cov(y, fs, orders=s.orders, block_rows=s.block_rows, n_blocks_std=4)
        from modal_twin.acquisition.frf import frf

        est = frf(u, y, fs, nperseg=min(y.shape[1], max(256, y.shape[1] // 8)))
        return polymax(est.H1, est.f_hz, orders=range(2, _p_max(s, u.shape[0]) + 1),
                       band_hz=s.band_hz)


def _p_max(s: Any, n_in: int) -> int:
    """Highest PolyMAX polynomial order: as many poles as the subspace methods' top order."""
    return max(4, math.ceil(s.orders[-1] / max(n_in, 1)))


def _modes(sweep: Any, band: tuple[float, float]) -> tuple[Any, Any, str]:
    from modal_twin.identification import select_modes, stabilization_diagram

    for label, th in (("default", STRICT), ("relaxed", RELAXED)):
        diag = stabilization_diagram(sweep, **th)
        mm = select_modes(diag, f_range_hz=band)
        if mm.f_hz.size:
            return diag, mm, label
    return diag, mm, "relaxed"


def run(a: argparse.Namespace) -> int:
    """Identify the bag's modes (module docstring)."""
    from modal_twin.acquisition.decimation import decimate
    from modal_twin.identification.auto import choose_settings, rms_spread
    from modal_twin.io.imported import read_imported

    block, channels = read_imported(a.bag)
    dirs = {d.strip() for d in a.directions.split(",")} if a.directions else None
    if a.method is None:
        has_in = bool(a.inputs) or any(c.effective_role == "input" for c in channels)
        a.method = "n4sid" if has_in else "ssi-cov"
    ins = [] if a.method == "ssi-cov" else _pick(channels, "input", a.inputs, dirs)
    outs = _pick(channels, "output", a.outputs, dirs)
    if not outs:
        msg = f"{a.bag}: no channel with role 'output'; give --outputs or a channel map"
        raise OptionError(msg)
    if a.method != "ssi-cov" and not ins:
        msg = (f"{a.bag}: --method {a.method} needs input channels (role 'input'), the bag "
               f"has none; use --method ssi-cov (output-only) or give --inputs")
        raise OptionError(msg)
    y = block.select([c.name for c in outs]).data
    u = block.select([c.name for c in ins]).data if ins else np.zeros((0, y.shape[1]))
    s = choose_settings(y, block.fs_hz, len(ins), f_max_hz=a.f_max,
                        corners_hz=_corners(outs + ins))
    print(f"identify: {a.method} on {len(ins)} inputs, {len(outs)} outputs, "
          f"{block.n_samples / block.fs_hz:.1f} s at {block.fs_hz:g} Hz")
    print(f"identify: {s.describe()} (from the record; --f-max to change the band)"
          + (f"; PolyMAX polynomial orders 2..{_p_max(s, len(ins))}, the block rows unused"
             if a.method == "polymax" else ""))
    if a.method == "ssi-cov" and (r := rms_spread(y)) > NONSTATIONARY:
        print(f"warning: output-only SSI on a non-stationary record: window RMS varies by "
              f"x{r:.1f} (> x{NONSTATIONARY:g}); its modes assume stationary excitation -- "
              f"use n4sid with the measured inputs if there are any", file=sys.stderr)
    yq = decimate(y, block.fs_hz, s.factor).x
    uq = decimate(u, block.fs_hz, s.factor).x if ins else u[:, :: s.factor]
    sweep = _sweep(a.method, uq, yq, s.fs_hz, s)
    diag, mm, label = _modes(sweep, s.band_hz)
    if label == "relaxed":
        print(f"identify: no mode with the default stability thresholds {STRICT}; "
              f"relaxed to {RELAXED}")
    return _report(a, block, outs, ins, s, sweep, diag, mm)


def _report(a: argparse.Namespace, block: Any, outs: list[ChannelSpec],
            ins: list[ChannelSpec], s: Any, sweep: Any, diag: Any, mm: Any) -> int:
    from modal_twin.identification import complexity, mpc
    from modal_twin.identification.auto import drifting_modes

    if mm.f_hz.size == 0:
        print(f"warning: no mode found in {s.band_hz[0]:.3g}-{s.band_hz[1]:.3g} Hz: no "
              f"cluster of poles stayed stable over {len(s.orders)} orders. Try a "
              f"narrower band (--f-max), another method (ssi-cov / n4sid with inputs), "
              f"or a longer record", file=sys.stderr)
        return ExitCode.FAILED
    mp, cx = mpc(mm.shapes), complexity(mm.shapes)
    print(f"{'mode':>4} {'f [Hz]':>9} {'std f':>8} {'zeta [%]':>8} {'std z':>7} "
          f"{'MPC':>5} {'MCF':>5} {'support':>7}")
    for k in range(mm.f_hz.size):
        print(f"{k + 1:>4} {mm.f_hz[k]:9.4f} {mm.std_f_hz[k]:8.4f} {100 * mm.zeta[k]:8.2f} "
              f"{100 * mm.std_zeta[k]:7.2f} {mp[k]:5.2f} {cx[k]:5.2f} {mm.n_support[k]:7d}")
    for f, d, o0, o1 in drifting_modes(diag, mm):
        print(f"warning: the mode at {f:.3f} Hz comes from a drifting pole column: "
              f"{100 * d:.1f} % from order {o0} to {o1}; treat it with care",
              file=sys.stderr)
    if a.out is not None:
        _write(a.out, a.method, outs, ins, s, diag, mm, mp, cx)
    return ExitCode.OK


def _write(out: Path, method: str, outs: list[ChannelSpec], ins: list[ChannelSpec], s: Any,
           diag: Any, mm: Any, mp: np.ndarray, cx: np.ndarray) -> None:
    from modal_twin.identification import automac
    from modal_twin.io.imported import atomic_file
    from modal_twin.io.uff import AXIS_CODES, write_uff55
    from modal_twin.viz._figure import save_figure
    from modal_twin.viz.mac import plot_mac
    from modal_twin.viz.stabilization import plot_stabilization

    out.mkdir(parents=True, exist_ok=True)
    nodes = sorted({c.node or c.location or c.name for c in outs})
    dofs = [{"channel": c.name, "node": nodes.index(c.node or c.location or c.name) + 1,
             "node_label": c.node or c.location, "direction": c.direction} for c in outs]
    doc = {"method": method, "settings": {"band_hz": list(s.band_hz), "decimation": s.factor,
                                          "fs_hz": s.fs_hz, "block_rows": s.block_rows,
                                          "orders": list(s.orders)},
           "thresholds": {"rel_tol_f": diag.rel_tol_f, "rel_tol_zeta": diag.rel_tol_zeta,
                          "mac_min": diag.mac_min},
           "inputs": [c.name for c in ins], "dofs": dofs,
           "modes": [{"f_hz": float(mm.f_hz[k]), "std_f_hz": float(mm.std_f_hz[k]),
                      "zeta": float(mm.zeta[k]), "std_zeta": float(mm.std_zeta[k]),
                      "mpc": float(mp[k]), "complexity": float(cx[k]),
                      "order": int(mm.mode_orders[k]), "support": int(mm.n_support[k]),
                      "shape_re": mm.shapes[:, k].real.tolist(),
                      "shape_im": mm.shapes[:, k].imag.tolist()}
                     for k in range(mm.f_hz.size)]}
    text = json.dumps(doc, indent=1).replace("NaN", "null")
    with atomic_file(out / "modes.json") as tmp:
        tmp.write_text(text)
    with atomic_file(out / "modes.uff") as tmp:
        tmp.unlink()
        write_uff55(tmp, mm.f_hz, mm.zeta, mm.shapes, [int(str(d["node"])) for d in dofs],
                    [AXIS_CODES.get(str(d["direction"]), 1) for d in dofs])
    save_figure(plot_stabilization(diag, selected_f_hz=mm.f_hz, f_max_hz=s.band_hz[1],
                                   title=f"stabilization diagram ({method})"),
                out / "stabilization.png")
    labels = [f"{f:.2f} Hz" for f in mm.f_hz]
    save_figure(plot_mac(automac(mm.shapes), labels, labels, title="auto-MAC"),
                out / "mac.png")
    print(f"identify: wrote {out}/modes.json, modes.uff, stabilization.png, mac.png")
