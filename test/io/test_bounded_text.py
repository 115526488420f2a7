"""JSON and YAML files are bounded before parsing; a YAML alias bomb before constructing.

The size is checked with ``fstat`` on the open file (a sparse file of 65 MiB takes no disk
and is never read); a YAML document is refused by its node, alias and nesting counts,
aliases expanded, so a "billion laughs" of 500 bytes never becomes 10^9 objects.
"""

from __future__ import annotations

import tracemalloc
from collections.abc import Callable
from pathlib import Path

import pytest
from bombs import sparse_file, yaml_alias_bomb

import modal_twin.yaml_files as yf
from modal_twin.errors import ConfigError
from modal_twin.io.channel_map import read_channel_map
from modal_twin.io.modes_file import read_modes
from modal_twin.validation import TEXT_FILE_MAX_BYTES
from modal_twin.yaml_files import read_text, read_yaml

OVER = TEXT_FILE_MAX_BYTES + 2**20  # 65 MiB


def _refused(f: Callable[[], object], match: str) -> float:
    """Peak traced allocation (MB) while ``f`` raises ConfigError matching ``match``."""
    tracemalloc.start()
    try:
        with pytest.raises(ConfigError, match=match):
            f()
        return tracemalloc.get_traced_memory()[1] / 1e6
    finally:
        tracemalloc.stop()


def test_a_billion_laughs_is_refused_before_it_is_constructed(tmp_path: Path) -> None:
    bomb = yaml_alias_bomb(tmp_path / "lol.yaml")  # 9 ** 9 = 387,420,489 strings
    assert bomb.stat().st_size < 600
    peak = _refused(lambda: read_yaml(bomb), "aliases that expand it to more than 500000 nodes")
    assert peak < 5.0
    assert _refused(lambda: read_channel_map(bomb), "YAML_MAX_NODES") < 5.0


def test_expanded_nodes_counted_exactly(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Root 1 + key x 1 + [0, 0, 0, 0] 5 + key y 1 + [*x, *x] 1 + 2 x 5 = 19 nodes."""
    doc = tmp_path / "shared.yaml"
    doc.write_text("x: &x [0, 0, 0, 0]\ny: [*x, *x]\n")
    monkeypatch.setattr(yf, "YAML_MAX_NODES", 19)
    assert read_yaml(doc) == {"x": [0, 0, 0, 0], "y": [[0, 0, 0, 0], [0, 0, 0, 0]]}
    monkeypatch.setattr(yf, "YAML_MAX_NODES", 18)
    with pytest.raises(ConfigError, match="expand it to more than 18 nodes"):
        read_yaml(doc)
    monkeypatch.setattr(yf, "YAML_MAX_NODES", 8)  # 9 nodes as written: refused unexpanded
    with pytest.raises(ConfigError, match="with more than 8 nodes"):
        read_yaml(doc)
    monkeypatch.setattr(yf, "YAML_MAX_NODES", 19)
    monkeypatch.setattr(yf, "YAML_MAX_ALIASES", 1)
    with pytest.raises(ConfigError, match=r"more than 1 aliases \(YAML_MAX_ALIASES\)"):
        read_yaml(doc)


def test_an_alias_loop_is_refused(tmp_path: Path) -> None:
    loop = tmp_path / "loop.yaml"
    loop.write_text("a: &a [1, *a]\n")
    with pytest.raises(ConfigError, match=r"an alias inside the node it names \(a loop\)"):
        read_yaml(loop)


def test_nesting_is_bounded_written_and_through_aliases(tmp_path: Path) -> None:
    ok, deep = tmp_path / "ok.yaml", tmp_path / "deep.yaml"
    ok.write_text("[" * 100 + "]" * 100 + "\n")
    deep.write_text("[" * 101 + "]" * 101 + "\n")
    nested = read_yaml(ok, mapping=False)
    for _ in range(99):
        nested = nested[0]
    assert nested == []
    with pytest.raises(ConfigError, match="more than 100 levels of nesting"):
        read_yaml(deep, mapping=False)
    chain = tmp_path / "chain.yaml"  # 2 levels as written, 102 once expanded
    chain.write_text("l0: &l0 [1]\n" + "".join(f"l{k}: &l{k} [*l{k - 1}]\n"
                                              for k in range(1, 101)))
    with pytest.raises(ConfigError, match="aliases that nest it more than 100 levels"):
        read_yaml(chain)


@pytest.mark.parametrize(("name", "reader", "what"), [
    ("big.yaml", read_yaml, "file"),
    ("big.yaml", read_channel_map, "channel map"),
    ("big.json", read_channel_map, "channel map"),
    ("big.json", read_modes, "modes file"),
    ("big.txt", read_text, "file"),
])
def test_an_oversized_text_file_is_refused_unread(tmp_path: Path, name: str,
                                                 reader: Callable[[Path], object],
                                                 what: str) -> None:
    big = sparse_file(tmp_path / name, OVER)
    peak = _refused(lambda: reader(big), f"a {what} of 65 MiB; expected at most 64 MiB "
                                         r"\(TEXT_FILE_MAX_BYTES\)")
    assert peak < 1.0


def test_a_text_file_at_the_limit_is_read(tmp_path: Path) -> None:
    f = tmp_path / "at.txt"
    f.write_text("x" * 1000)
    assert read_text(f, max_bytes=1000) == "x" * 1000
    with pytest.raises(ConfigError, match="a file of 0 MiB; expected at most 0 MiB"):
        read_text(f, max_bytes=999)


def test_the_pure_python_loader_is_held_to_the_same_limits(tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch
                                                          ) -> None:
    """Where PyYAML lacks libyaml: the same refusals, the same document."""
    import yaml

    monkeypatch.setattr(yf, "_LOADER", yaml.SafeLoader)
    with pytest.raises(ConfigError, match="expand it to more than 500000 nodes"):
        read_yaml(yaml_alias_bomb(tmp_path / "lol.yaml"))
    deep = tmp_path / "deep.yaml"  # would exceed Python's recursion limit unchecked
    deep.write_text("[" * 2000 + "]" * 2000 + "\n")
    with pytest.raises(ConfigError, match="more than 100 levels of nesting"):
        read_yaml(deep, mapping=False)
    doc = tmp_path / "shared.yaml"
    doc.write_text("x: &x [0, 0, 0, 0]\ny: [*x, *x]\n")
    assert read_yaml(doc) == {"x": [0, 0, 0, 0], "y": [[0, 0, 0, 0], [0, 0, 0, 0]]}
