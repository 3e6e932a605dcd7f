"""Parameter files and `-p` overrides as a node receives them, checked the way rcl applies them.

rcl applies a params file's section to a node when the section's key matches the node's fully qualified
name (`*` one namespace token, `**` any number), and silently ignores everything else: a typo such as
`pitch.kpp`, a section keyed `contoller_node`, or a file keyed `controller_node` given to a node started
in /robot1 leave the node running on its defaults. Here each of those stops the node at start-up with one
line naming the entry and the closest valid name. Pure Python (PyYAML), no rclpy.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import yaml

from twbr_common.params import ConfigError, closest_name

# The nodes of the twbr graph: a section keyed close to one of these is a typo, not another package's node.
KNOWN_NODES = ("sim_node", "controller_node", "planner_node", "world_node", "command_player", "torque_driver",
               "mujoco_driver", "viewer", "tracker_node")
# Parameters a node may receive without declaring them itself (rclpy's own, and QoS overrides).
IMPLICIT_PREFIXES = ("qos_overrides.",)
# Parameters rclpy declares itself, in Node.__init__, before any of ours: a value of the wrong type there
# ends in rclpy's traceback, so they are checked here first, with the same one-line refusal as ours.
RCLPY_PARAMETERS = {"use_sim_time": bool, "start_type_description_service": bool}


def ros_arguments(argv: Iterable[str]) -> list[str]:
    """The arguments between each `--ros-args` and its closing `--` (or the end)."""
    out: list[str] = []
    inside = False
    for arg in argv:
        if arg == "--ros-args":
            inside = True
        elif arg == "--":
            inside = False
        elif inside:
            out.append(arg)
    return out


def params_file_paths(argv: Iterable[str]) -> list[Path]:
    args = ros_arguments(argv)
    return [Path(args[i + 1]) for i, a in enumerate(args[:-1]) if a == "--params-file"]


def parameter_overrides(argv: Iterable[str]) -> list[tuple[str | None, str]]:
    """(node name or None, parameter name) of each `-p [node:]name:=value`."""
    return [(node, name) for node, name, _ in parameter_values(argv)]


def parameter_values(argv: Iterable[str]) -> list[tuple[str | None, str, Any]]:
    """(node name or None, parameter name, value) of each `-p [node:]name:=value`, the value read as YAML
    as rcl reads it (`1` an integer, `true` a boolean, `yes` a boolean, `"yes"` a string)."""
    args = ros_arguments(argv)
    out = []
    for i, a in enumerate(args[:-1]):
        if a in ("-p", "--param"):
            name, _, text = args[i + 1].partition(":=")
            node, _, param = name.rpartition(":")
            try:
                value = yaml.safe_load(text)
            except yaml.YAMLError:
                value = text
            out.append((node or None, param, value))
    return out


def check_rclpy_parameters(argv: Iterable[str]) -> None:
    """rclpy's own parameters (use_sim_time, ...) have the type rclpy declares them with, in every params
    file and `-p`; rclpy would otherwise refuse them with a traceback from inside Node()."""
    argv = list(argv)

    def check(name: str, value: Any, where: str) -> None:
        kind = RCLPY_PARAMETERS.get(name)
        if kind is not None and not isinstance(value, kind):
            raise ConfigError(f"invalid parameter '{name}' = {value!r} {where}: must be true or false"
                              f" (a {kind.__name__}, not a {type(value).__name__}; it is rclpy's own)")

    for path in params_file_paths(argv):
        for key, params in sections(load_params_file(path), path):
            for name, value in flatten(params).items():
                check(name, value, f"in params file {path} (section '{key}')")
    for _, name, value in parameter_values(argv):
        check(name, value, f"(-p {name}:=...)")


def load_params_file(path: Path) -> dict[str, Any]:
    """The YAML document of a params file, or ConfigError in one line."""
    try:
        text = Path(path).read_text()
    except OSError as e:
        raise ConfigError(f"cannot read params file {path}: {e.strerror or e}") from None
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as e:
        where = getattr(e, "problem_mark", None)
        at = f" at line {where.line + 1}, column {where.column + 1}" if where is not None else ""
        problem = getattr(e, "problem", None) or str(e).splitlines()[0]
        raise ConfigError(f"params file {path} is not valid YAML{at}: {problem}") from None
    if not isinstance(doc, dict):
        raise ConfigError(f"params file {path}: expected sections keyed by node name, found {type(doc).__name__}")
    return doc


def sections(doc: dict[str, Any], path: Path) -> Iterator[tuple[str, dict[str, Any]]]:
    """(node key, its ros__parameters) of every section, namespaces nested or written in the key."""

    def walk(prefix: str, node: Any) -> Iterator[tuple[str, dict[str, Any]]]:
        if not isinstance(node, dict):
            raise ConfigError(f"params file {path}: section '{prefix}' has no ros__parameters")
        if "ros__parameters" in node:
            params = node["ros__parameters"]
            if not isinstance(params, dict):
                raise ConfigError(f"params file {path}: '{prefix}/ros__parameters' must be a mapping")
            yield prefix, params
            return
        if not node or not all(isinstance(v, dict) for v in node.values()):
            raise ConfigError(f"params file {path}: section '{prefix}' has no ros__parameters"
                              " (expected '<node>: {ros__parameters: {...}}')")
        for key, child in node.items():
            yield from walk(f"{prefix}/{str(key).strip('/')}", child)

    for key, value in doc.items():
        yield from walk(str(key).rstrip("/") if str(key).startswith("/") else f"/{key}", value)


def key_matches(key: str, fully_qualified_name: str) -> bool:
    """rcl's rule: the key's tokens against the node's, `*` one token, `**` any number (none too)."""
    pattern = [t for t in key.split("/") if t]
    name = [t for t in fully_qualified_name.split("/") if t]

    def match(i: int, j: int) -> bool:
        if i == len(pattern):
            return j == len(name)
        if pattern[i] == "**":
            return any(match(i + 1, k) for k in range(j, len(name) + 1))
        return j < len(name) and pattern[i] in ("*", name[j]) and match(i + 1, j + 1)

    return match(0, 0)


def flatten(params: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested mappings as rcl names them: {'pitch': {'kp': 1}} -> {'pitch.kp': 1}."""
    out: dict[str, Any] = {}
    for key, value in params.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(flatten(value, f"{name}."))
        else:
            out[name] = value
    return out


def preflight(argv: Iterable[str]) -> None:
    """Every params file exists, reads, parses and has only sections with ros__parameters, and rclpy's own
    parameters have their type."""
    argv = list(argv)
    for path in params_file_paths(argv):
        list(sections(load_params_file(path), path))
    check_rclpy_parameters(argv)


def node_parameters(path: Path, node_name: str, namespace: str = "/") -> dict[str, Any]:
    """What a params file gives the node `namespace/node_name` (flattened names), as rcl would apply it."""
    fqn = f"{namespace.rstrip('/')}/{node_name}"
    out: dict[str, Any] = {}
    for key, params in sections(load_params_file(path), path):
        if key_matches(key, fqn):
            out.update(flatten(params))
    return out


def check_overrides(argv: Iterable[str], node_name: str, namespace: str, declared: Iterable[str]) -> None:
    """Refuse what would be silently ignored: a file with no section for this node, a section for a node
    name close to one of ours, a parameter the node does not declare (file or -p)."""
    argv = list(argv)
    declared = set(declared)
    fqn = f"{namespace.rstrip('/')}/{node_name}"

    def check_known(name: str, where: str) -> None:
        if name in declared or name.startswith(IMPLICIT_PREFIXES):
            return
        guess = closest_name(name, declared)
        hint = f"; did you mean '{guess}'?" if guess else ""
        raise ConfigError(f"unknown parameter '{name}' {where}: {node_name} declares no such parameter{hint}")

    for path in params_file_paths(argv):
        found = list(sections(load_params_file(path), path))
        applying = []
        for key, params in found:
            last = key.rsplit("/", 1)[-1]
            if key_matches(key, fqn):
                applying.append((key, params))
            elif "*" not in last and last not in KNOWN_NODES:
                # a node's name mistyped by a letter or two (contoller_node: 0.97), not another package's
                # node that shares "_node" with ours (other_package_node ~ tracker_node: 0.73)
                guess = closest_name(last, (*KNOWN_NODES, node_name), cutoff=0.8)
                if guess is not None:
                    raise ConfigError(f"params file {path}: section '{key}' names no node; did you mean '{guess}'?")
        if not applying:
            keys = ", ".join(f"'{k}'" for k, _ in found)
            raise ConfigError(
                f"params file {path} has no section for {fqn} (its sections: {keys}); key a section"
                f" '/**/{node_name}' to apply it in any namespace"
            )
        for key, params in applying:
            for name in flatten(params):
                check_known(name, f"in params file {path} (section '{key}')")
    for node, name in parameter_overrides(argv):
        if node is None or node == node_name:
            check_known(name, f"(-p {name}:=...)")
