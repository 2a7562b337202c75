"""The launch plan: what a launch resolves to (processes with their full command lines, reactions, logs),
and the checks and conversions shared by whoever builds it (``launch.resolve``, ``launch.ros_resolve``).
Nothing here reads a launch file or starts a process."""

from __future__ import annotations

import importlib.util
import json
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from launch.yaml_source import LaunchError, Source

LAUNCH_DIR = Path(__file__).resolve().parent
NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_MODULE_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*$")
_TRUE = {"true", "1", "yes", "on"}
_FALSE = {"false", "0", "no", "off", ""}
DEFAULT_RESPAWN_MAX = 5
DEFAULT_WAIT_TIMEOUT = 60.0
# A node that stops answering its own get_parameters service for this long (hung, or its Zenoh link is
# gone) is restarted when it respawns; long enough that a busy shared machine or a short network
# partition that Zenoh rides out does not trigger it.
DEFAULT_HEALTH_TIMEOUT = 15.0  # s without a sign of life: docs/hardening.md has the silences measured at full load


CONTAINER_MODULE = "nodes.core.container"   # our component_container (python -m)
# launch_ros's container spellings we run as our container: (pkg, exec)
CONTAINER_PACKAGES = ("zenroid", "rclcpp_components")
CONTAINER_EXECUTABLES = ("component_container",)


def node_options(namespace: str, param_files: list[str], generated_params: Path | None,
                 remaps: list[tuple[str, str]]) -> list[str]:
    """A node's namespace, parameter files (the launch file's own, then the generated one) and remappings as
    its command line spells them, for a process and for a node in a container alike."""
    argv = ["--ns", namespace] if namespace else []
    for param_file in [*param_files, *([str(generated_params)] if generated_params is not None else [])]:
        argv += ["--params-file", param_file]
    for src, dst in remaps:
        argv += ["--remap", f"{src}:={dst}"]
    return argv


@dataclass
class ComposedNodeSpec:
    """One node loaded into a container process, fully resolved."""

    name: str
    namespace: str
    plugin: str            # python.module::NodeClass
    params: dict[str, Any]
    param_files: list[str]
    remaps: list[tuple[str, str]]
    source: str

    @property
    def full_name(self) -> str:
        return f"{self.namespace}/{self.name}" if self.namespace else self.name

    def node_argv(self, generated_params: Path | None) -> list[str]:
        """The node's own command line, as ``python -m MODULE`` would get it."""
        return ["--name", self.name, *node_options(self.namespace, self.param_files, generated_params, self.remaps)]

    def describe(self) -> dict[str, Any]:
        out: dict[str, Any] = {"name": self.name, "namespace": self.namespace, "plugin": self.plugin}
        for key in ("params", "param_files"):
            if getattr(self, key):
                out[key] = getattr(self, key)
        if self.remaps:
            out["remap"] = [f"{a}:={b}" for a, b in self.remaps]
        out["source"] = self.source
        return out


@dataclass
class NodeSpec:
    """One process to run, fully resolved (a node, a program, or a container of composed nodes)."""

    name: str
    namespace: str
    module: str | None
    executable: str | None
    args: list[str]
    params: dict[str, Any]
    param_files: list[str]
    remaps: list[tuple[str, str]]
    env: dict[str, str]
    respawn: bool
    respawn_delay: float
    respawn_max: int
    required: bool
    output: str
    wait_for: list[str]
    wait_timeout: float
    source: str
    health_timeout: float = DEFAULT_HEALTH_TIMEOUT
    exclusive_cpu: bool = False   # a CPU of its own for its stepping thread, the other processes off it
    composed: list[ComposedNodeSpec] = field(default_factory=list)   # a node_container's nodes
    # How the command line is built for a program (``executable``): "" its args only; "ros": ROS's trailing
    # ``--ros-args`` (name, namespace, parameter files, remappings); "node": our node options after its args
    style: str = ""
    node_name: str | None = None     # the ROS node name a launch file gave ("ros"/"node" styles)
    ros_args: list[str] = field(default_factory=list)
    cwd: str | None = None
    action: Any = None               # the ROS launch action it came from (event handlers match on it)

    @property
    def full_name(self) -> str:
        return f"{self.namespace}/{self.name}" if self.namespace else self.name

    def command(self, python: str, generated_params: Path | None,
                composed_params: Mapping[str, Path | None] | None = None) -> list[str]:
        """The argv of this node (no shell): ``python -m MODULE`` with the shared node CLI, or the program; a
        container gets one ``--composable`` JSON per node (``composed_params``: each one's generated file)."""
        if self.executable is not None:
            return [self.executable, *self.args, *self.ros_options(generated_params)]
        argv = [python, "-m", str(self.module), "--name", self.name]
        if self.composed:
            if self.namespace:
                argv += ["--ns", self.namespace]
            for node in self.composed:
                generated = (composed_params or {}).get(node.name)
                argv += ["--composable", json.dumps({"plugin": node.plugin, "argv": node.node_argv(generated)})]
            return argv
        return argv + node_options(self.namespace, self.param_files, generated_params, self.remaps) + self.args

    def ros_options(self, generated_params: Path | None) -> list[str]:
        files = [*self.param_files, *([str(generated_params)] if generated_params is not None else [])]
        if self.style == "node":
            named = ["--name", self.node_name] if self.node_name else []
            return [*named, *node_options(self.namespace, files, None, self.remaps), *self.ros_args]
        if self.style != "ros":
            return []
        argv = ["--ros-args"]
        if self.node_name:
            argv += ["-r", f"__node:={self.node_name}"]
        if self.namespace:
            argv += ["-r", f"__ns:=/{self.namespace}"]
        for file in files:
            argv += ["--params-file", file]
        for src, dst in self.remaps:
            argv += ["-r", f"{src}:={dst}"]
        argv += self.ros_args
        return argv if len(argv) > 1 else []

    def describe(self) -> dict[str, Any]:
        out: dict[str, Any] = {"name": self.name, "namespace": self.namespace}
        out["module" if self.module else "exec"] = self.module or self.executable
        for key in ("args", "params", "param_files", "env", "wait_for"):
            if getattr(self, key):
                out[key] = getattr(self, key)
        if self.remaps:
            out["remap"] = [f"{a}:={b}" for a, b in self.remaps]
        if self.respawn:
            out["respawn"] = {"delay": self.respawn_delay, "max": self.respawn_max}
        if self.required:
            out["required"] = True
        if self.health_timeout != DEFAULT_HEALTH_TIMEOUT:
            out["health_timeout"] = self.health_timeout
        if self.output != "screen":
            out["output"] = self.output
        if self.exclusive_cpu:
            out["exclusive_cpu"] = True
        if self.composed:
            out["composable_node"] = [node.describe() for node in self.composed]
        out["source"] = self.source
        return out


@dataclass
class ExitHandler:
    node: str
    log: str | None
    shutdown: bool
    source: str


@dataclass
class Expansion:
    """What resolving some actions yields: processes to start, lines to log, triggers, a shutdown."""

    nodes: list[NodeSpec] = field(default_factory=list)
    logs: list[tuple[str, str]] = field(default_factory=list)    # (level, text)
    triggers: list[Trigger] = field(default_factory=list)
    shutdown: str | None = None


@dataclass
class Trigger:
    """A reaction the supervisor runs: on a process's start / exit / output line, after a delay (timer), or
    at shutdown; ``fire(event)`` resolves its actions then (errors become LaunchError)."""

    kind: str                                  # start | exit | io | timer | shutdown
    fire: Callable[[Any], Expansion]
    matches: Callable[[NodeSpec], bool] | None = None   # which processes (None: every one)
    after: float = 0.0                         # timer: seconds after it was set
    source: str = ""
    handler: Any = None                        # the event handler object (UnregisterEventHandler)


@dataclass
class LaunchPlan:
    file: Path
    args: dict[str, str]
    nodes: list[NodeSpec] = field(default_factory=list)
    on_exit: list[ExitHandler] = field(default_factory=list)
    on_shutdown: list[str] = field(default_factory=list)
    logs: list[tuple[str, str]] = field(default_factory=list)    # LogInfo at the launch's start
    triggers: list[Trigger] = field(default_factory=list)
    shutdown: str | None = None                # a Shutdown action reached while resolving

    def describe(self) -> dict[str, Any]:
        return {
            "file": str(self.file),
            "args": dict(self.args),
            "nodes": [n.describe() for n in self.nodes],
            "on_exit": [{"node": h.node, "log": h.log, "shutdown": h.shutdown} for h in self.on_exit],
            "on_shutdown": list(self.on_shutdown),
            **({"log": [text for _, text in self.logs]} if self.logs else {}),
            **({"reactions": [f"{t.kind}{f' after {t.after:g} s' if t.kind == 'timer' else ''} ({t.source})"
                              for t in self.triggers]} if self.triggers else {}),
        }


def parse_bool(text: str, what: str, source: Source) -> bool:
    lowered = text.strip().lower()
    if lowered in _TRUE:
        return True
    if lowered in _FALSE:
        return False
    raise LaunchError(f"{what} must be true or false, got '{text}'", source)


def evaluate_condition(text: str, what: str, source: Source) -> bool:
    """``true``/``false`` (and 1/0, yes/no, on/off), or a text comparison ``A == B`` / ``A != B``."""
    for operator in ("==", "!="):
        if operator in text:
            left, _, right = text.partition(operator)
            if operator in right:
                raise LaunchError(f"{what}: one comparison only, got '{text}'", source)
            return (left.strip() == right.strip()) == (operator == "==")
    return parse_bool(text, what, source)


def join_namespace(parent: str, child: str | None) -> str:
    if not child:
        return parent
    if child.startswith("/"):
        return child.strip("/")
    return "/".join(part for part in (parent, child.strip("/")) if part)


def typed_value(text: str) -> Any:
    """A substituted parameter value gets its YAML type back ("0.5" -> 0.5, "true" -> True, "[a, b]" -> list)."""
    try:
        value = yaml.safe_load(text)
    except yaml.YAMLError:
        return text
    if isinstance(value, list) and text.lstrip().startswith("["):  # a flow list: "[point, sine]"
        return value
    return value if isinstance(value, (bool, int, float, str)) else text


def check_namespace(namespace: str, source: Source) -> None:
    if namespace and not all(NAME_RE.match(part) for part in namespace.split("/")):
        raise LaunchError(f"namespace '{namespace}' must be '/'-separated names of letters, digits and '_'", source)


def check_module(module: str, source: Source) -> None:
    if not _MODULE_RE.match(module):
        raise LaunchError(f"'{module}' is not a Python module name", source)
    try:
        spec = importlib.util.find_spec(module)
        if spec is not None and spec.submodule_search_locations is not None:  # a package runs its __main__
            if importlib.util.find_spec(f"{module}.__main__") is None:
                raise LaunchError(f"package '{module}' has no __main__ module to run", source)
    except (ImportError, ValueError):
        spec = None
    if spec is None:
        raise LaunchError(f"Python module '{module}' not found", source)
