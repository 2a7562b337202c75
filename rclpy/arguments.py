"""``--ros-args`` as rcl parses them: ``-r``/``--remap``, ``-p``/``--param``, ``--params-file``, ``--log-level``,
``-e``/``--enclave`` (ignored), ending at ``--`` or the next ``--ros-args``."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from nodes.core.names import parse_assignment
from nodes.core.params import load_params_file, parse_value

ROS_ARGS = "--ros-args"


class RosArgumentError(ValueError):
    """A malformed ``--ros-args`` section (names the flag and what is wrong)."""


@dataclass
class RosArguments:
    remaps: list[tuple[str | None, str, str]] = field(default_factory=list)   # (node or None, from, to)
    params: list[tuple[str | None, str, Any]] = field(default_factory=list)   # (node or None, name, value)
    params_files: list[str] = field(default_factory=list)
    log_levels: dict[str, str] = field(default_factory=dict)   # "" : the default level
    node_name: str | None = None
    namespace: str | None = None

    def node_remaps(self, node_name: str) -> dict[str, str]:
        return {src: dst for node, src, dst in self.remaps if node in (None, node_name)}

    def node_params(self, node_name: str, namespace: str) -> dict[str, Any]:
        """Parameter overrides for one node: params files first, then ``-p``, later ones winning (rcl's order)."""
        values: dict[str, Any] = {}
        for path in self.params_files:
            values.update(load_params_file(path, node_name, namespace))
        for node, name, value in self.params:
            if node in (None, node_name):
                values[name] = value
        return values

    def merged(self, other: RosArguments) -> RosArguments:
        """``other`` (a node's own ``cli_args``) after these (the global ones)."""
        return RosArguments(
            self.remaps + other.remaps, self.params + other.params, self.params_files + other.params_files,
            {**self.log_levels, **other.log_levels}, other.node_name or self.node_name,
            other.namespace if other.namespace is not None else self.namespace)


def _split_node(name: str) -> tuple[str | None, str]:
    """``node:name`` → (node, name): a rule for one node only."""
    if ":" in name.split(":=", 1)[0]:   # a ':' before the ':=' ends the node's name
        node, rest = name.split(":", 1)
        return node, rest
    return None, name


def parse(argv: list[str]) -> tuple[RosArguments, list[str]]:
    """The ROS arguments in ``argv`` and the rest (what ``remove_ros_args`` returns)."""
    ros = RosArguments()
    rest: list[str] = []
    i, inside = 0, False
    while i < len(argv):
        arg = argv[i]
        if arg == ROS_ARGS:
            inside = True
            i += 1
            continue
        if not inside:
            rest.append(arg)
            i += 1
            continue
        if arg == "--":
            inside = False
            i += 1
            continue

        def value(i: int = i, arg: str = arg) -> str:
            if i + 1 >= len(argv):
                raise RosArgumentError(f"--ros-args: {arg} needs a value")
            return argv[i + 1]

        if arg in ("-r", "--remap"):
            _remap(ros, value())
            i += 2
        elif arg in ("-p", "--param"):
            node, assignment = _split_node(value())
            try:
                name, text = parse_assignment(assignment)
            except ValueError as exc:
                raise RosArgumentError(f"--ros-args {arg}: {exc}") from None
            ros.params.append((node, name, parse_value(text)))
            i += 2
        elif arg == "--params-file":
            ros.params_files.append(value())
            i += 2
        elif arg == "--log-level":
            text = value()
            name, _, level = text.rpartition(":=") if ":=" in text else ("", "", text)
            ros.log_levels[name] = level
            i += 2
        elif arg in ("-e", "--enclave", "--log-config-file"):
            i += 2
        elif arg in ("--enable-rosout-logs", "--disable-rosout-logs", "--enable-stdout-logs",
                     "--disable-stdout-logs", "--enable-external-lib-logs", "--disable-external-lib-logs"):
            i += 1
        else:
            raise RosArgumentError(f"--ros-args: unknown argument {arg!r} (zenroid knows -r, -p, --params-file, "
                                   "--log-level, -e)")
    return ros, rest


def _remap(ros: RosArguments, text: str) -> None:
    node, rule = _split_node(text)
    try:
        src, dst = parse_assignment(rule)
    except ValueError as exc:
        raise RosArgumentError(f"--ros-args -r: {exc}") from None
    if src == "__node" or src == "__name":
        if node is None:
            ros.node_name = dst
        return
    if src == "__ns":
        if node is None:
            ros.namespace = dst
        return
    ros.remaps.append((node, src, dst))


def remove_ros_args(args: list[str] | None) -> list[str]:
    import sys

    return parse(list(sys.argv if args is None else args))[1]
