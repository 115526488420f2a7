"""``modal-twin identify BAG --method n4sid|ssi-cov|polymax``: modes of an imported record.

One call, :func:`modal_twin.identification.record.identify_record` (the node and
``campaign`` make the same one): inputs and outputs from the roles of the bag's channel
map (``--inputs`` / ``--outputs`` override them); band, decimation, block rows and orders
chosen from the record and printed; the modes by clustering the poles (``--selection
stability``: the stability rule of [004], relaxed when it gives no mode, and said),
each with its cluster's size, and every column of poles not reported in a table with the
reason. Writes ``modes.json`` and ``modes.uff`` (UFF 55,
:mod:`modal_twin.io.modes_file`), ``stabilization.png`` and ``mac.png`` into ``--out``
(each to a temporary name, then renamed; an existing one refused before the work unless
``--force``).

A UFF file of FRFs (a hammer test's ``impact/frf.uff``, UFF 58 function type 4) is
identified by PolyMAX + LSFD on the FRF matrix itself
(:func:`~modal_twin.identification.frf_modes.modes_from_frf`): the band from the second
line to 40 % of the last (the anti-alias rule), or to ``--f-max``, printed; the damping
corrected for the exponential window the ``hits.yaml`` beside the file names; ``--out``
receives ``modes.json`` (``update --modes`` reads it).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from modal_twin.exit_codes import ExitCode
from modal_twin.method_names import METHODS, SELECTIONS
from modal_twin.paths import check_new_in
from modal_twin.progress import step

__all__ = ["OUTPUTS", "register", "run"]

OUTPUTS = ("modes.json", "modes.uff", "stabilization.png", "mac.png")
"""The files ``--out`` gets; an existing one is kept unless ``--force``."""
FRF_SUFFIXES = (".uff", ".unv")
"""A file of these kinds is a FRF matrix (module docstring)."""
FRF_TOP = 0.4
"""Default upper band edge of a FRF file, as a share of its last line."""


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``identify`` to the sub-commands."""
    p = sub.add_parser("identify", help="modes of a bag (N4SID, SSI-cov, PolyMAX)")
    p.add_argument("bag", type=Path, help="bag written by `modal-twin import` (or a run), or "
                                          "a UFF file of FRFs (a hammer test's frf.uff)")
    p.add_argument("--method", choices=METHODS, default=None,
                   help="default: n4sid when the bag has driven inputs, else ssi-cov")
    p.add_argument("--selection", choices=SELECTIONS, default=None,
                   help="clusters: hierarchical clustering of the poles (default of n4sid "
                        "and ssi-cov); stability: the [004] stability rule, relaxed when it "
                        "finds none (default of polymax)")
    p.add_argument("--out", type=Path, default=None, help="folder for JSON, UFF 55, PNGs")
    p.add_argument("--force", action="store_true", help="--out: overwrite existing files")
    p.add_argument("--f-max", type=float, default=None, help="upper band edge, Hz")
    p.add_argument("--inputs", default=None, help="comma list of input channels")
    p.add_argument("--outputs", default=None, help="comma list of output channels")
    p.add_argument("--directions", default=None,
                   help="keep only channels of these directions (e.g. x,y)")
    p.set_defaults(func=run)


def _names(text: str | None) -> tuple[str, ...] | None:
    return None if not text else tuple(n.strip() for n in text.split(",") if n.strip())


def _no_record(folder: Path) -> None:
    """Refuse, saying what it holds, an imported folder with no time record (no bag).

    ``import`` of a UFF holding only spectra, FRFs or modes writes them beside no bag.
    """
    from modal_twin.errors import ConfigError

    if not folder.is_dir() or (folder / "metadata.yaml").exists() or any(folder.glob("*.mcap")):
        return
    held = sorted(p.name for p in (*folder.glob("spectra_*.npz"), *folder.glob("modes_*.json")))
    if held:
        msg = (f"{folder}: no time record to identify, only {held} of an imported UFF; "
               "identify a FRF file itself (modal-twin identify FILE.uff), modes go to "
               "report / view / update")
        raise ConfigError(msg)


def run(a: argparse.Namespace) -> int:
    """Identify the bag's modes (module docstring)."""
    from modal_twin.identification.record import IdentifyOptions, identify_record
    from modal_twin.io.imported import read_imported

    if a.bag.suffix.lower() in FRF_SUFFIXES and a.bag.is_file():
        return _identify_frf(a)
    _no_record(a.bag)
    if a.out is not None:
        check_new_in(a.out, OUTPUTS, a.force)  # before the work
    block, channels = read_imported(a.bag)
    opts = IdentifyOptions(method=a.method, inputs=_names(a.inputs),
                           outputs=_names(a.outputs), directions=_names(a.directions),
                           f_max_hz=a.f_max, selection=a.selection)
    with step(f"identify: {a.bag.name} ({block.n_samples / block.fs_hz:.0f} s, "
              f"{len(channels)} channels)"):
        rec = identify_record(block, channels, opts)
    s = rec.settings
    print(f"identify: {rec.method} on {len(rec.inputs)} inputs, {len(rec.outputs)} outputs, "
          f"{block.n_samples / block.fs_hz:.1f} s at {block.fs_hz:g} Hz")
    sw = rec.sweep.orders
    print(f"identify: {s.describe()} ({s.band_rule}; --f-max to change the band)"
          + (f"; PolyMAX polynomial orders {sw[0]}..{sw[-1]}, the block rows unused"
             if rec.method == "polymax" else ""))
    for w in rec.warnings:
        print(f"warning: {w}", file=sys.stderr)
    for n in rec.notes:
        print(f"identify: {n}")
    return _report(a, rec)


def _report(a: argparse.Namespace, rec: Any) -> int:
    from modal_twin.identification import complexity, mpc
    from modal_twin.identification.auto import drifting_modes

    mm, s, diag = rec.modes, rec.settings, rec.diagram
    if rec.dropped:
        print(f"not reported: {len(rec.dropped)} columns of poles")
        print(f"{'f [Hz]':>9} {'zeta [%]':>8} {'poles':>5} {'orders':>7}  reason")
    for d in rec.dropped:
        print(f"{d.f_hz:9.4f} {100 * d.zeta:8.2f} {d.n_poles:5d} {d.orders[0]:>3}-"
              f"{d.orders[1]:<3}  {d.reason}")
    if mm.f_hz.size == 0:
        print(f"warning: no mode found in {s.band_hz[0]:.3g}-{s.band_hz[1]:.3g} Hz: no "
              f"cluster of poles stayed stable over orders {rec.sweep.orders[0]}.."
              f"{rec.sweep.orders[-1]}. Try a "
              f"narrower band (--f-max), another method (ssi-cov / n4sid with inputs), "
              f"or a longer record", file=sys.stderr)
        return ExitCode.FAILED
    mp, cx = mpc(mm.shapes), complexity(mm.shapes)
    print(f"{'mode':>4} {'f [Hz]':>9} {'std f':>8} {'zeta [%]':>8} {'std z':>7} "
          f"{'MPC':>5} {'MCF':>5} {'support':>7}")
    for k in range(mm.f_hz.size):
        print(f"{k + 1:>4} {mm.f_hz[k]:9.4f} {_or_dash(mm.std_f_hz[k], 8, 4)} "
              f"{100 * mm.zeta[k]:8.2f} {_or_dash(100 * mm.std_zeta[k], 7, 2)} "
              f"{mp[k]:5.2f} {cx[k]:5.2f} {mm.n_support[k]:7d}")
    if not any(math.isfinite(float(x)) for x in mm.std_f_hz):
        print(f"(std: not estimated by {rec.method})")
    for f, d, o0, o1 in drifting_modes(diag, mm):
        print(f"warning: the mode at {f:.3f} Hz comes from a drifting pole column: "
              f"{100 * d:.1f} % from order {o0} to {o1}; treat it with care",
              file=sys.stderr)
    if a.out is not None:
        _write(a.out, rec, a.bag, a.force)
    return ExitCode.OK


def _write(out: Path, rec: Any, bag: Path, force: bool) -> None:
    with step(f"identify: writing {out}"):
        _files(out, rec, bag, force)
    print(f"identify: wrote {out}/{', '.join(OUTPUTS)}")


def _files(out: Path, rec: Any, bag: Path, force: bool) -> None:
    from modal_twin.identification import automac
    from modal_twin.io.modes_file import read_geometry_files, write_modes
    from modal_twin.viz._figure import save_figure
    from modal_twin.viz.mac import plot_mac
    from modal_twin.viz.stabilization import plot_stabilization

    mm = rec.modes
    write_modes(out, rec, read_geometry_files(bag) if bag.is_dir() else None, force=force)
    save_figure(plot_stabilization(rec.diagram, selected_f_hz=mm.f_hz,
                                   f_max_hz=rec.settings.band_hz[1], spectrum=rec.spectrum,
                                   title=f"stabilization diagram ({rec.method})"),
                out / "stabilization.png", force=force)
    labels = [f"{f:.2f} Hz" for f in mm.f_hz]
    save_figure(plot_mac(automac(mm.shapes), labels, labels, title="auto-MAC"),
                out / "mac.png", force=force)


def _identify_frf(a: argparse.Namespace) -> int:
    """PolyMAX + LSFD on a UFF file's FRF matrix (module docstring)."""
    import json

    from modal_twin.acquisition.impact import exponential_damping
    from modal_twin.errors import OptionError
    from modal_twin.identification.frf_modes import modes_from_frf
    from modal_twin.io.impact_files import frf_modes_document, read_frf_matrix, read_window_tau
    from modal_twin.io.uff import read_uff
    from modal_twin.paths import atomic_file

    unused = [o for o in ("inputs", "outputs", "directions", "selection")
              if getattr(a, o) is not None]
    if a.method not in (None, "polymax") or unused:
        given = ([f"--method {a.method}"] if a.method not in (None, "polymax") else []) + [
            f"--{o}" for o in unused]
        msg = (f"{a.bag}: a FRF file is identified by PolyMAX + LSFD on its FRFs; "
               f"{', '.join(given)} {'does' if len(given) == 1 else 'do'} not apply")
        raise OptionError(msg)
    if a.out is not None:
        check_new_in(a.out, ("modes.json",), a.force)
    uff = read_uff(a.bag)  # once: the FRFs and the file's own geometry (UFF 164 / 15 / 82)
    f, H, outs, _ = read_frf_matrix(a.bag, uff)
    lo, top = float(f[1]), float(f[-1])
    hi = FRF_TOP * top if a.f_max is None else float(a.f_max)
    if not lo < hi <= top:
        msg = (f"--f-max {a.f_max}: expected above {lo:.4g} Hz (the second line) and at most "
               f"{top:.4g} Hz (the last line of the FRFs)")
        raise OptionError(msg)
    rule = "--f-max" if a.f_max is not None else f"{100 * FRF_TOP:.0f} % of the last line"
    print(f"identify: PolyMAX + LSFD on {H.shape[0]} responses x {H.shape[1]} references, "
          f"lines every {f[1] - f[0]:.4g} Hz; band {lo:.4g}-{hi:.4g} Hz ({rule})")
    with step(f"identify: {a.bag.name}, PolyMAX"):
        mm = modes_from_frf(H, f, band_hz=(lo, hi))
    zeta = mm.zeta
    tau = read_window_tau(a.bag)
    if tau is not None:
        zeta = exponential_damping(mm.zeta, mm.f_hz, tau)
        print(f"identify: damping corrected for the exponential window of {tau:g} s "
              f"(hits.yaml): zeta - 1 / (tau w)")
    if mm.f_hz.size == 0:
        print(_no_frf_mode(uff, f, outs, (lo, hi)), file=sys.stderr)
        return ExitCode.FAILED
    print(f"{'mode':>4} {'f [Hz]':>9} {'zeta [%]':>8}")
    for k in range(mm.f_hz.size):
        print(f"{k + 1:>4} {mm.f_hz[k]:9.4f} {100 * zeta[k]:8.2f}")
    if a.out is not None:
        g = uff.geometry
        geo = ({k: g[k] for k in ("nodes", "trace_lines", "units")} if g["nodes"] else None)
        doc = frf_modes_document(mm.f_hz, zeta, mm.shapes,
                                 [(f"{n}_{d}", n, d) for n, d in outs], str(a.bag),
                                 geometry=geo)
        a.out.mkdir(parents=True, exist_ok=True)
        with atomic_file(a.out / "modes.json") as tmp:
            tmp.write_text(json.dumps(doc, indent=1))
        print(f"identify: wrote {a.out / 'modes.json'}")
    return ExitCode.OK


def _no_frf_mode(uff: Any, f: Any, outs: list[tuple[str, str]],
                 band: tuple[float, float]) -> str:
    """One line: why PolyMAX found no mode in a FRF file's band, as far as the file tells.

    A file with each output's multiple coherence (``export frf``) below
    :data:`~modal_twin.identification.record.COHERENT` (debiased) is the inputs' fault: H1
    of inputs that explain that little of the response (ground motion at several supports,
    unmeasured excitation) holds no consistent poles, and the record itself identifies
    output-only.
    """
    from modal_twin.identification.record import COHERENT, debiased_coherence
    from modal_twin.io.impact_files import read_frf_coherence

    where = (f"no mode found in {band[0]:.4g}-{band[1]:.4g} Hz: no column of PolyMAX poles "
             "is stable")
    got = read_frf_coherence(uff, outs, f)
    if got is None:
        return (f"warning: {where} (the file holds no coherence to tell why); try another "
                "band (--f-max)")
    coh, n_avg, n_in = got
    sel = (f >= band[0]) & (f <= band[1])
    raw = float(coh[:, sel].mean())
    c = debiased_coherence(raw, n_in, n_avg)
    said = (f"the FRFs' multiple coherence in the band is {c:.2f} (debiased; {raw:.2f} over "
            f"{n_avg} averages of {n_in} inputs)")
    if c < COHERENT:
        return (f"warning: {where}; {said}, below {COHERENT:g}: the inputs explain too little "
                "of the response (ground motion at several supports, unmeasured excitation) "
                "for H1 to hold consistent poles -- identify the record itself, output-only "
                "(modal-twin identify BAG)")
    return f"warning: {where}, though {said}; try another band (--f-max)"


def _or_dash(x: float, width: int, decimals: int) -> str:
    """``x`` in a column of ``width``, or a dash where it is not estimated (NaN)."""
    return f"{x:{width}.{decimals}f}" if math.isfinite(x) else "-".rjust(width)
