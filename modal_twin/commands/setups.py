"""``modal-twin setups MODES MODES... [--references CH,CH] --out DIR``: roving setups joined.

A structure tested in setups (some sensors stay put, the **references**; the others rove)
is identified setup by setup (``identify --out``, or ``import`` of a UFF 55; the files
must name the channels of their shape entries, so a ``.mat`` is refused). This command

1. reads each setup's modes file (``modes.json`` / ``modes_*.json``, or UFF 55) and the
   channel names of its shape entries;
2. takes as references ``--references`` or, by default, the channels every setup measured,
   and refuses in one line, naming each setup's channels, when there is none;
3. prints the cross-MAC between the first setup's modes and every other setup's on their
   common channels (:func:`~modal_twin.identification.setups.cross_mac`): per mode of the
   first setup, its best partner, both frequencies and the MAC;
4. joins the setups by PoSER (:func:`~modal_twin.identification.setups.merge_setups`):
   the modes of every setup grouped by frequency and reference MAC, each member's shape
   scaled in least squares so that its reference part matches that of the setup that saw
   the mode first (the first setup's complex scale for every mode it holds), the roving
   parts side by side, f and zeta the means over the setups with their spreads; a mode
   some setups lack is kept and said with the setups that saw it, its entries at channels
   none of them measured left empty (null in ``modes.json``, NaN in ``modes.uff``);
5. writes ``modes.json`` and ``modes.uff`` (UFF 55) over every channel into ``--out``
   (``export modes``, ``report``, ``view --modes`` and ``update --modes`` read them;
   ``update`` leaves out the modes with empty entries, said).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from modal_twin.exit_codes import ExitCode

__all__ = ["OUTPUTS", "register", "run"]

OUTPUTS = ("modes.json", "modes.uff")
"""The files ``--out`` gets; an existing one is kept unless ``--force``."""
SCALING = ("PoSER: each setup's shapes scaled in least squares to the first setup's on the "
           "reference channels (the merged shapes keep the first setup's complex scale)")


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``setups`` parser."""
    p = sub.add_parser("setups", help="roving setups: cross-MAC and shapes merged through "
                                      "reference channels (PoSER)")
    p.add_argument("modes", type=Path, nargs="+",
                   help="one modes file per setup (identify's modes.json, an imported "
                        "modes_*.json, or UFF 55); each mode is scaled to the first setup "
                        "that saw it")
    p.add_argument("--references", default=None,
                   help="comma list of reference channels (default: the channels every "
                        "setup measured)")
    p.add_argument("--df-rel", type=float, default=0.05,
                   help="largest relative frequency difference of paired modes")
    p.add_argument("--min-mac", type=float, default=0.8,
                   help="smallest MAC of paired modes' reference parts")
    p.add_argument("--out", type=Path, default=None, help="folder for modes.json, modes.uff")
    p.add_argument("--force", action="store_true", help="--out: overwrite existing files")
    p.set_defaults(func=run)


def _names(text: str | None) -> list[str] | None:
    return None if text is None else [n.strip() for n in text.split(",") if n.strip()]


def _channel(d: dict[str, Any]) -> str | None:
    name = d.get("channel")
    if name:
        return str(name)
    if d.get("node") is not None and d.get("direction"):
        return f"{d['node']}{d['direction']}"
    return None


def read_setup(path: Path) -> tuple[Any, Any]:
    """Return the :class:`SetupModes` of a modes file and the file as read.

    Raises
    ------
    ConfigError
        The file does not read, or does not name the channels of its shape entries.
    """
    from modal_twin.errors import ConfigError
    from modal_twin.identification.setups import SetupModes
    from modal_twin.io.modes_file import read_modes

    m = read_modes(path)
    names = [_channel(d) for d in m.dofs]
    if len(names) != m.shapes.shape[0] or any(n is None for n in names):
        msg = (f"{path}: its shape entries name no channels (a .mat or a file without "
               "'dofs'); setups are joined by channel name")
        raise ConfigError(msg)
    if len(set(names)) != len(names):
        msg = f"{path}: a channel appears twice in its shape entries"
        raise ConfigError(msg)
    if m.f_hz.size == 0:
        msg = f"{path}: holds no mode"
        raise ConfigError(msg)
    return SetupModes(tuple(str(n) for n in names), m.f_hz, m.zeta, m.shapes), m


def references_of(setups: list[Any], paths: list[Path], given: list[str] | None) -> list[str]:
    """Return the reference channels: ``given``, else those every setup measured.

    Raises
    ------
    OptionError
        No common channel, or a given reference missing from a setup (the line names the
        channels of each setup).
    """
    from modal_twin.errors import OptionError

    def held() -> str:
        return "; ".join(f"{p.name}: {', '.join(s.channels)}" for p, s in zip(paths, setups,
                                                                               strict=True))

    if given is None:
        common = [c for c in setups[0].channels if all(c in s.channels for s in setups[1:])]
        if not common:
            msg = f"no reference channel common to every setup ({held()})"
            raise OptionError(msg)
        return common
    if not given:
        msg = "--references: expected a comma list of channel names"
        raise OptionError(msg)
    for p, s in zip(paths, setups, strict=True):
        missing = [r for r in given if r not in s.channels]
        if missing:
            msg = f"--references {','.join(missing)}: not measured in {p.name} ({held()})"
            raise OptionError(msg)
    return given


def _check_options(a: argparse.Namespace) -> None:
    from modal_twin.errors import OptionError

    if len(a.modes) < 2:
        msg = f"expected at least two setups' modes files, got {len(a.modes)}"
        raise OptionError(msg)
    if not 0.0 < a.df_rel < 1.0:
        msg = f"--df-rel: expected 0 < df_rel < 1, got {a.df_rel}"
        raise OptionError(msg)
    if not 0.0 <= a.min_mac <= 1.0:
        msg = f"--min-mac: expected 0 <= min_mac <= 1, got {a.min_mac}"
        raise OptionError(msg)


def _print_cross_mac(setups: list[Any], paths: list[Path]) -> None:
    from modal_twin.identification.setups import cross_mac

    a = setups[0]
    for s, p in zip(setups[1:], paths[1:], strict=True):
        common = [c for c in a.channels if c in s.channels]
        cm = cross_mac(a, s)
        print(f"cross-MAC {paths[0].name} x {p.name} on {len(common)} common channels "
              f"({', '.join(common)}):")
        print(f"{'mode A':>6} {'f A [Hz]':>9} {'mode B':>6} {'f B [Hz]':>9} {'df [%]':>7} "
              f"{'MAC':>6}")
        for i in range(cm.shape[0]):
            j = int(np.argmax(cm[i]))
            df = 100 * (s.f_hz[j] - a.f_hz[i]) / a.f_hz[i]
            print(f"{i + 1:>6} {a.f_hz[i]:9.4f} {j + 1:>6} {s.f_hz[j]:9.4f} {df:7.2f} "
                  f"{cm[i, j]:6.3f}")


def merged_document(merged: Any, files: list[Any], paths: list[Path], refs: list[str],
                    ) -> dict[str, Any]:
    """Return the ``modes.json`` content of merged setups (what ``read_modes`` reads).

    Each channel keeps the node label and direction of the first setup that measured it;
    the UFF node numbers are made anew over all channels (``uff_nodes``) and each setup's
    geometry nodes follow them.
    """
    from modal_twin.io.modes_file import uff_nodes

    info: dict[str, tuple[dict[str, Any], dict[str, Any] | None]] = {}
    for m in files:
        for d in m.dofs:
            info.setdefault(str(_channel(d)), (d, m.geometry))
    labels = {c: str(info[c][0].get("node_label") or info[c][0].get("node") or c)
              for c in merged.channels}
    number = uff_nodes(list(labels.values()))
    nodes: dict[str, list[float]] = {}
    for c in merged.channels:
        d, geo = info[c]
        xyz = (geo or {}).get("nodes", {}).get(str(d.get("node")))
        if xyz is not None:
            nodes.setdefault(str(number[labels[c]]), [float(v) for v in xyz])
    dofs = [{"channel": c, "node": number[labels[c]], "node_label": labels[c],
             "direction": info[c][0].get("direction") or "x"} for c in merged.channels]
    S = merged.shapes
    return {"method": "setups (PoSER)", "source": [str(p) for p in paths],
            "references": refs, "scaling": SCALING, "dofs": dofs,
            "geometry": {"nodes": nodes, "trace_lines": []} if nodes else None,
            "inputs": [], "notes": [], "not_reported": [],
            "modes": [{"f_hz": float(merged.f_hz[k]), "std_f_hz": None,
                       "zeta": float(merged.zeta[k]),
                       "f_spread_hz": float(merged.f_spread_hz[k]),
                       "zeta_spread": float(merged.zeta_spread[k]),
                       "reference_mac": [float(v) for v in merged.ref_mac[k]],
                       "seen_in": [paths[i].name for i in merged.seen_in[k]],
                       "not_measured": [c for i, c in enumerate(merged.channels)
                                        if not np.isfinite(S[i, k])],
                       "shape_re": S[:, k].real.tolist(), "shape_im": S[:, k].imag.tolist()}
                      for k in range(merged.f_hz.size)]}


def run(a: argparse.Namespace) -> int:
    """Cross-MAC, merge and write (module docstring)."""
    from modal_twin.identification.setups import merge_setups
    from modal_twin.io.modes_file import write_modes_uff
    from modal_twin.paths import atomic_file, check_new_in

    _check_options(a)
    if a.out is not None:
        check_new_in(a.out, OUTPUTS, a.force)  # before the work
    paths = list(a.modes)
    read = [read_setup(p) for p in paths]
    setups, files = [r[0] for r in read], [r[1] for r in read]
    for p, s in zip(paths, setups, strict=True):
        print(f"setups: {p.name}: {s.f_hz.size} modes at {len(s.channels)} channels")
    refs = references_of(setups, paths, _names(a.references))
    print(f"setups: references {', '.join(refs)}"
          + ("" if a.references else " (the channels every setup measured)"))
    _print_cross_mac(setups, paths)
    merged = merge_setups(setups, refs, df_rel=a.df_rel, min_mac=a.min_mac)
    full = merged.complete()
    print(f"setups: {merged.f_hz.size} modes (paired within {100 * a.df_rel:g} % and reference "
          f"MAC >= {a.min_mac:g}): {int(full.sum())} seen in every setup, "
          f"{int((~full).sum())} in some only; merged over {len(merged.channels)} channels; "
          f"{SCALING}")
    print(f"{'mode':>4} {'f [Hz]':>9} {'spread f':>9} {'zeta [%]':>8} {'min ref MAC':>11} "
          "seen in setups")
    for k in range(merged.f_hz.size):
        seen = "all" if full[k] else ", ".join(str(i + 1) for i in merged.seen_in[k])
        print(f"{k + 1:>4} {merged.f_hz[k]:9.4f} {merged.f_spread_hz[k]:9.4f} "
              f"{100 * merged.zeta[k]:8.2f} {np.nanmin(merged.ref_mac[k]):11.4f} {seen}")
    for k in map(int, np.flatnonzero(~full)):
        absent = [c for i, c in enumerate(merged.channels)
                  if not np.isfinite(merged.shapes[i, k])]
        print(f"  mode {k + 1} ({merged.f_hz[k]:.4f} Hz): seen in "
              f"{', '.join(paths[i].name for i in merged.seen_in[k])} only; not measured "
              f"there: {', '.join(absent) or 'none'} (left empty, not zero)")
    if a.out is not None:
        doc = merged_document(merged, files, paths, refs)
        a.out.mkdir(parents=True, exist_ok=True)
        with atomic_file(a.out / "modes.json", force=a.force) as tmp:
            tmp.write_text(json.dumps(doc, indent=1).replace("NaN", "null"))
        with atomic_file(a.out / "modes.uff", force=a.force) as tmp:
            tmp.unlink()
            write_modes_uff(tmp, merged.f_hz, merged.zeta, merged.shapes, doc["dofs"],
                            doc["geometry"])
        print(f"setups: wrote {a.out}/{', '.join(OUTPUTS)}")
    return ExitCode.OK
