"""The package's import graph keeps the stage order of DESIGN.md (no loop, nothing upward).

Order, lowest first (a module may import its own stage and any lower one)::

    base modules (errors, _types, signal_block, channels, ...)
      <- models
      <- excitation, acquisition
      <- identification
      <- twin
      <- rig, updating
      <- diagnosis
      <- viz
      <- io                      (the edge: messages and files to the stages' types)
      <- node.py files, launch
      <- commands
      <- demo
      <- cli

A stage's ``node.py`` may import io and the base, its own stage and the stages below it,
never a stage above it (a node is wiring, not a way around the order).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "modal_twin"
BASE = 0
RANK: dict[str, int] = {
    "models": 1,
    "excitation": 2, "acquisition": 2,
    "identification": 3,
    "twin": 4,
    "rig": 5, "updating": 5,
    "diagnosis": 6,
    "viz": 7,
    "io": 8,
    "launch": 9,
    "commands": 10,
    "demo": 11,
    "cli": 12,
}
NODE_EXTRA = {"io"}  # what a node.py may import beyond its stage's rank


def _stage(rel: Path) -> str:
    return rel.parts[0] if len(rel.parts) > 1 else rel.stem


def _targets(rel: Path, tree: ast.AST) -> list[tuple[int, str]]:
    out: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = list(rel.parts[: len(rel.parts) - node.level])
                mod = ".".join([*base, *([node.module] if node.module else [])])
                out.append((node.lineno, mod))
            elif node.module == "modal_twin":
                out += [(node.lineno, a.name) for a in node.names]
            elif node.module and node.module.startswith("modal_twin."):
                out.append((node.lineno, node.module.removeprefix("modal_twin.")))
        elif isinstance(node, ast.Import):
            out += [(node.lineno, a.name.removeprefix("modal_twin."))
                    for a in node.names if a.name.startswith("modal_twin.")]
    return out


def violations() -> list[str]:
    """Every import that goes upward or sideways between stages, as text."""
    bad: list[str] = []
    for path in sorted(PKG.rglob("*.py")):
        rel = path.relative_to(PKG)
        stage = _stage(rel)
        rank = RANK.get(stage, BASE)
        is_node = rel.name == "node.py"
        for line, mod in _targets(rel, ast.parse(path.read_text(encoding="utf-8"))):
            target = mod.split(".")[0]
            if not target or target == stage:
                continue
            t_rank = RANK.get(target, BASE)
            if is_node and target in NODE_EXTRA:
                continue
            if t_rank >= rank and not (t_rank == BASE and rank == BASE):
                bad.append(f"{rel}:{line} ({stage}) imports {mod} ({target})")
            elif rank == BASE and t_rank > BASE:
                bad.append(f"{rel}:{line} (base) imports {mod} ({target})")
    return bad


def test_stages_depend_one_way() -> None:
    bad = violations()
    assert not bad, "imports against the stage order:\n" + "\n".join(bad)


def test_checker_sees_an_upward_import(tmp_path: Path) -> None:
    """The checker itself: an upward import in a model module is caught."""
    src = "from modal_twin.twin.simulator import Simulator\n"
    found = _targets(Path("models/x.py"), ast.parse(src))
    assert found == [(1, "twin.simulator")]
    assert RANK["twin"] > RANK["models"]


@pytest.mark.parametrize("stage", sorted({*RANK} - {"cli", "launch", "demo"}))
def test_every_ranked_stage_exists(stage: str) -> None:
    assert (PKG / stage).is_dir() or (PKG / f"{stage}.py").is_file()
