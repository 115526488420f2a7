"""Scenario files: which nodes a run starts, with which parameters, and what it records.

A scenario YAML is a ROS 2 parameters file (the layout ``--ros-args --params-file``
reads: ``<node>: {ros__parameters: {...}}``) plus one ``launch:`` section::

    launch:
      description: random table motion into the simulated rig
      duration_s: 15            # stop after this long (0: until Ctrl-C)
      ready_timeout_s: 30       # nodes up and topics matched within this
      nodes:
        - {name: excitation, executable: excitation_node}
        - {name: rig, executable: rig_node, one_shot: false}
      record: {topics: [/excitation/signal, /rig/raw]}
    excitation:
      ros__parameters: {kind: random, duration_s: 10.0}
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from modal_twin.errors import ConfigError, OptionError
from modal_twin.validation import check_name
from modal_twin.yaml_files import read_yaml

__all__ = ["NodeSpec", "Scenario", "load_scenario", "with_parameters"]


@dataclass(frozen=True, slots=True)
class NodeSpec:
    """One node process of a scenario."""

    name: str
    executable: str
    parameters: dict[str, Any]
    args: tuple[str, ...] = ()
    one_shot: bool = False  # may exit 0 before the run ends


@dataclass(frozen=True, slots=True)
class Scenario:
    """A launchable run."""

    path: Path
    name: str
    description: str
    nodes: tuple[NodeSpec, ...]
    duration_s: float
    ready_timeout_s: float
    record_topics: tuple[str, ...]
    global_parameters: dict[str, Any]
    extra: dict[str, Any]

    def params_file_text(self, node: str) -> str:
        """YAML params file for one node (its section and the ``/**`` section)."""
        spec = next(n for n in self.nodes if n.name == node)
        doc: dict[str, Any] = {node: {"ros__parameters": _ros_values(spec.parameters)}}
        if self.global_parameters:
            doc["/**"] = {"ros__parameters": _ros_values(self.global_parameters)}
        return yaml.safe_dump(doc, sort_keys=False)


def _ros_values(params: dict[str, Any]) -> dict[str, Any]:
    """ROS parameter arrays are homogeneous: a list mixing ints and floats becomes floats."""
    out: dict[str, Any] = {}
    for k, v in params.items():
        if isinstance(v, list) and v and all(
                isinstance(x, int | float) and not isinstance(x, bool) for x in v) and any(
                isinstance(x, float) for x in v):
            v = [float(x) for x in v]
        elif isinstance(v, dict):
            v = _ros_values(v)
        out[k] = v
    return out


def _err(path: Path, key: str, problem: str) -> ConfigError:
    return ConfigError(f"{path}: key {key!r}: {problem}")


def _params(path: Path, doc: dict[str, Any], key: str) -> dict[str, Any]:
    section = doc.get(key)
    if section is None:
        return {}
    if not isinstance(section, dict) or not isinstance(section.get("ros__parameters", {}), dict):
        raise _err(path, key, "expected a mapping with a 'ros__parameters' mapping")
    return dict(section.get("ros__parameters") or {})


PACKAGE_EXECUTABLES = (
    "excitation_node", "rig_node", "acquisition_node", "identification_node",
    "updating_node", "twin_node", "diagnosis_node", "recorder_node", "replay_node",
    "display_node",
)
"""The executables a scenario may start unless ``allow_external`` is given."""

_NODE_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,63}")


def _check_nodes(p: Path, nodes: list[NodeSpec], allow_external: bool) -> None:
    """Check that node names are plain ROS names and executables this package's nodes.

    Names become file names in the run folder; executables may be other programs only
    with ``allow_external``.
    """
    for i, n in enumerate(nodes):
        if not _NODE_NAME.fullmatch(n.name):
            raise _err(p, f"launch.nodes[{i}].name", f"expected letters, digits and _ "
                       f"(starting with a letter, at most 64), got {n.name!r}")
        if not allow_external and n.executable not in PACKAGE_EXECUTABLES:
            raise _err(p, f"launch.nodes[{i}].executable",
                       f"expected one of this package's nodes {list(PACKAGE_EXECUTABLES)} "
                       f"(or --allow-external), got {n.executable!r}")


def _node_spec(p: Path, doc: dict[str, Any], key: str, item: Any, nodes: list[NodeSpec]
               ) -> NodeSpec:
    """Check one entry of ``launch.nodes`` (against the nodes before it) and build it."""
    if not isinstance(item, dict):
        raise _err(p, key, "expected a mapping with 'name' and 'executable'")
    unknown = sorted(set(item) - {"name", "executable", "args", "one_shot"})
    if unknown:
        raise _err(p, f"{key}.{unknown[0]}",
                   "unknown key; valid: name, executable, args, one_shot")
    for field in ("name", "executable"):
        if not isinstance(item.get(field), str) or not item[field]:
            raise _err(p, f"{key}.{field}", "missing or not a string")
    if any(n.name == item["name"] for n in nodes):
        raise _err(p, f"{key}.name", f"node name {item['name']!r} used twice")
    args = item.get("args", [])
    if not isinstance(args, list):
        raise _err(p, f"{key}.args", "expected a list of strings")
    return NodeSpec(item["name"], item["executable"], _params(p, doc, item["name"]),
                    tuple(str(a) for a in args), bool(item.get("one_shot", False)))


def load_scenario(path: str | Path, *, allow_external: bool = False) -> Scenario:
    """Read and check a scenario file.

    ``allow_external``: let nodes run executables that are not this package's nodes
    (by default a scenario cannot start an arbitrary program).

    Raises
    ------
    ConfigError
        Naming the file, the key and the problem (YAML syntax errors give the line).
    """
    p = Path(path)
    doc = read_yaml(p, "scenario file")
    launch = doc.get("launch")
    if not isinstance(launch, dict):
        raise _err(p, "launch", "missing or not a mapping")
    raw_nodes = launch.get("nodes")
    if not isinstance(raw_nodes, list) or not raw_nodes:
        raise _err(p, "launch.nodes", "expected a non-empty list of {name, executable}")
    nodes: list[NodeSpec] = []
    for i, item in enumerate(raw_nodes):
        nodes.append(_node_spec(p, doc, f"launch.nodes[{i}]", item, nodes))
    names = {n.name for n in nodes}
    stray = sorted(k for k in doc if k not in names and k not in {"launch", "/**"})
    if stray:
        raise _err(p, stray[0], f"parameters for a node that is not launched; nodes: "
                                f"{sorted(names)}")
    numbers: dict[str, float] = {}
    for key, default in (("duration_s", 0.0), ("ready_timeout_s", 30.0)):
        value = launch.get(key, default)
        if not isinstance(value, int | float) or isinstance(value, bool) or value < 0:
            raise _err(p, f"launch.{key}", f"expected a number >= 0, got {value!r}")
        numbers[key] = float(value)
    record = launch.get("record") or {}
    if not isinstance(record, dict) or not isinstance(record.get("topics", []), list):
        raise _err(p, "launch.record", "expected {topics: [/topic, ...]}")
    extra = {k: v for k, v in launch.items()
             if k not in {"nodes", "duration_s", "ready_timeout_s", "record", "description",
                          "name"}}
    _check_nodes(p, nodes, allow_external)
    name = launch.get("name", p.stem)
    try:
        check_name(name, "name")  # it names the run folder
    except OptionError as err:
        raise _err(p, "launch.name", str(err).partition(": ")[2]) from err
    return Scenario(
        path=p,
        name=name,
        description=str(launch.get("description", "")),
        nodes=tuple(nodes),
        duration_s=numbers["duration_s"],
        ready_timeout_s=numbers["ready_timeout_s"],
        record_topics=tuple(str(t) for t in record.get("topics", [])),
        global_parameters=_params(p, doc, "/**"),
        extra=extra,
    )


def with_parameters(sc: Scenario, node: str, **params: Any) -> Scenario:
    """Return a copy of ``sc`` with parameters of ``node`` replaced.

    (ConfigError if not launched).
    """
    from dataclasses import replace

    names = [n.name for n in sc.nodes]
    if node not in names:
        msg = f"{sc.path}: no node {node!r} to set parameters on; nodes: {names}"
        raise ConfigError(msg)
    nodes = tuple(replace(n, parameters={**n.parameters, **params}) if n.name == node else n
                  for n in sc.nodes)
    return replace(sc, nodes=nodes)
