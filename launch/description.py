"""The inert launch description: a YAML launch file parsed and checked, nothing substituted or started.

Format (docs/launch.md, Format)::

    launch:
      - arg: {name: x, default: "0.0", description: "...", choices: [...]}
      - node: {name: sim, module: nodes.sim, namespace: humanoid, params: {...}, ...}
      - include: {file: other.yaml, args: {x: "1"}}
      - group: {namespace: ns, actions: [...]}
      - on_exit: {node: spawner, log: "...", shutdown: false}
      - on_shutdown: {log: "..."}
      - node_container: {name: c, composable_node: [{pkg: nodes.sim, plugin: nodes.sim.node::SimulatorNode,
                                                      name: simulator, param: [{name: mode, value: lockstep}]}]}
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

from launch.yaml_source import LaunchError, LocatedDict, LocatedList, Source, load_located

CONDITION_KEYS = ("if", "unless")

# Old spellings still read, with a warning naming the new one: old key -> new key.
DEPRECATED_NODE_KEYS = {"param_file": "params_file"}
NODE_KEYS = (
    "name", "module", "exec", "args", "namespace", "params", "params_file", "remap", "env",
    "respawn", "respawn_delay", "respawn_max", "required", "output", "wait_for", "wait_timeout",
    "health_timeout", "exclusive_cpu", *CONDITION_KEYS,
)
# node_container / composable_node: launch_ros's YAML front end spells them so (pkg, exec, name, namespace,
# composable_node: [{pkg, plugin, name, namespace, param: [{name, value}], remap: [{from, to}], extra_arg}]).
# The container also takes our process keys (respawn, required, exclusive_cpu, ...): it is the process.
CONTAINER_KEYS = (
    "pkg", "exec", "name", "namespace", "composable_node", "env", "respawn", "respawn_delay", "respawn_max",
    "required", "output", "wait_for", "wait_timeout", "health_timeout", "exclusive_cpu", *CONDITION_KEYS,
)
COMPOSABLE_KEYS = ("pkg", "plugin", "name", "namespace", "param", "params", "params_file", "remap", "extra_arg")


class LaunchDeprecationWarning(UserWarning):
    """An old spelling in a launch file: it still works; the launcher prints the warning with file:line."""


# Our YAML format's action kinds: each class below owns its key (``KIND``), its parsing (``parse``) and what
# it resolves to (``resolve``, using the resolver's services in ``launch.resolve``), so a new kind is one
# class here; ROS's actions do the same in ``launch.actions`` / ``launch_ros.actions``.
KINDS: dict[str, type[Action]] = {}


@dataclass
class Action:
    """Base of every action: where it was written and its raw ``if`` / ``unless`` conditions."""

    source: Source
    condition_if: Any = None
    condition_unless: Any = None

    KIND: ClassVar[str] = ""
    KEYS: ClassVar[tuple[str, ...]] = ()
    REQUIRED: ClassVar[tuple[str, str]] = ("", "")     # (key, how the error names it)

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if cls.__dict__.get("KIND"):
            KINDS[cls.KIND] = cls

    @classmethod
    def parse(cls, body: LocatedDict, file: Path, source: Source) -> Action:
        raise NotImplementedError

    @classmethod
    def checked(cls, body: LocatedDict, file: Path, source: Source) -> None:
        """The keys every kind checks the same way: none unknown, the required one present."""
        _check_keys(body, cls.KEYS, cls.KIND, file)
        key, needs = cls.REQUIRED
        if key and key not in body:
            raise LaunchError(f"{cls.KIND} needs {needs}", source)

    def resolve(self, resolver: Any, scope: Any) -> None:
        raise NotImplementedError

    def enabled(self, resolver: Any, scope: Any) -> bool:
        return resolver.condition(self, scope)


@dataclass
class ArgDecl(Action):
    name: str = ""
    default: str | None = None
    description: str = ""
    choices: list[str] | None = None

    KIND: ClassVar[str] = "arg"
    KEYS: ClassVar[tuple[str, ...]] = ("name", "default", "description", "choices")
    REQUIRED: ClassVar[tuple[str, str]] = ("name", "a 'name'")

    @classmethod
    def parse(cls, body: LocatedDict, file: Path, source: Source) -> ArgDecl:
        cls.checked(body, file, source)
        at = lambda key: Source(file, body.line_of(key))  # noqa: E731 - tiny local helper
        choices = body.get("choices")
        if choices is not None:
            if not isinstance(choices, list) or not choices:
                raise LaunchError("arg 'choices' must be a non-empty list", at("choices"))
            choices = [_scalar_text(c, "a choice", at("choices")) for c in choices]
        return cls(source=source, name=_scalar_text(body["name"], "arg 'name'", at("name")),
                   default=_scalar_text(body.get("default"), "arg 'default'", at("default"), allow_none=True),
                   description=_scalar_text(body.get("description", ""), "arg 'description'", at("description")),
                   choices=choices)

    def enabled(self, resolver: Any, scope: Any) -> bool:
        return True   # an argument is declared whatever the conditions around it

    def resolve(self, resolver: Any, scope: Any) -> None:
        resolver.declare(self, scope)


@dataclass
class NodeDecl(Action):
    """A node with its raw (unsubstituted) fields; ``fields`` is the YAML mapping itself."""

    fields: LocatedDict = field(default_factory=LocatedDict)

    KIND: ClassVar[str] = "node"

    def line_source(self, key: str) -> Source:
        return Source(self.source.file, self.fields.line_of(key))

    @classmethod
    def parse(cls, body: LocatedDict, file: Path, source: Source) -> NodeDecl:
        return _parse_node(body, file, source)

    def resolve(self, resolver: Any, scope: Any) -> None:
        resolver.add_node(self, scope)


@dataclass
class ComposableDecl:
    """One ``composable_node`` of a container, raw (unsubstituted) as ``NodeDecl``."""

    source: Source
    fields: LocatedDict = field(default_factory=LocatedDict)

    def line_source(self, key: str) -> Source:
        return Source(self.source.file, self.fields.line_of(key))


@dataclass
class ContainerDecl(NodeDecl):
    """A ``node_container``: one process (``fields``: its keys) running ``composables`` in it."""

    composables: list[ComposableDecl] = field(default_factory=list)

    KIND: ClassVar[str] = "node_container"

    @classmethod
    def parse(cls, body: LocatedDict, file: Path, source: Source) -> ContainerDecl:
        return _parse_container(body, file, source)

    def resolve(self, resolver: Any, scope: Any) -> None:
        resolver.add_container(self, scope)


@dataclass
class IncludeDecl(Action):
    file: str = ""
    args: LocatedDict | None = None

    KIND: ClassVar[str] = "include"
    KEYS: ClassVar[tuple[str, ...]] = ("file", "args", *CONDITION_KEYS)
    REQUIRED: ClassVar[tuple[str, str]] = ("file", "a 'file'")

    @classmethod
    def parse(cls, body: LocatedDict, file: Path, source: Source) -> IncludeDecl:
        cls.checked(body, file, source)
        args = body.get("args")
        if args is not None:
            _require_mapping(args, "include 'args'", Source(file, body.line_of("args")))
        return cls(source=source, file=_scalar_text(body["file"], "include 'file'", Source(file, body.line_of("file"))),
                   args=args, **_conditions(body, file))

    def resolve(self, resolver: Any, scope: Any) -> None:
        resolver.include(self, scope)


@dataclass
class GroupDecl(Action):
    namespace: Any = None
    actions: list[Action] = field(default_factory=list)

    KIND: ClassVar[str] = "group"
    KEYS: ClassVar[tuple[str, ...]] = ("namespace", "actions", *CONDITION_KEYS)

    @classmethod
    def parse(cls, body: LocatedDict, file: Path, source: Source) -> GroupDecl:
        cls.checked(body, file, source)
        actions = body.get("actions")
        if not isinstance(actions, LocatedList):
            raise LaunchError("group needs 'actions': a list of actions", source)
        namespace = _scalar_text(body.get("namespace"), "group 'namespace'", Source(file, body.line_of("namespace")),
                                 allow_none=True)
        return cls(source=source, namespace=namespace, actions=parse_actions(actions, file), **_conditions(body, file))

    def resolve(self, resolver: Any, scope: Any) -> None:
        # A group scopes its namespace, not its arguments (like ROS 2's GroupAction).
        inner = scope.child(variables=scope.variables)
        namespace = resolver.maybe_text(self.namespace, scope, self.source, "group 'namespace'")
        if namespace:
            resolver.push_namespace(inner, namespace, self.source)
        resolver.walk(self.actions, inner)


@dataclass
class OnExitDecl(Action):
    node: str = ""
    log: Any = None
    shutdown: Any = False

    KIND: ClassVar[str] = "on_exit"
    KEYS: ClassVar[tuple[str, ...]] = ("node", "log", "shutdown", *CONDITION_KEYS)
    REQUIRED: ClassVar[tuple[str, str]] = ("node", "the 'node' it watches")

    @classmethod
    def parse(cls, body: LocatedDict, file: Path, source: Source) -> OnExitDecl:
        cls.checked(body, file, source)
        at = lambda key: Source(file, body.line_of(key))  # noqa: E731 - tiny local helper
        return cls(source=source, node=_scalar_text(body["node"], "on_exit 'node'", at("node")),
                   log=_scalar_text(body.get("log"), "'log'", at("log"), allow_none=True),
                   shutdown=_scalar_text(body.get("shutdown", False), "'shutdown'", at("shutdown")),
                   **_conditions(body, file))

    def resolve(self, resolver: Any, scope: Any) -> None:
        resolver.add_exit_handler(self, scope)


@dataclass
class OnShutdownDecl(Action):
    log: Any = None

    KIND: ClassVar[str] = "on_shutdown"
    KEYS: ClassVar[tuple[str, ...]] = ("log", *CONDITION_KEYS)

    @classmethod
    def parse(cls, body: LocatedDict, file: Path, source: Source) -> OnShutdownDecl:
        cls.checked(body, file, source)
        return cls(source=source, log=_scalar_text(body.get("log"), "'log'", Source(file, body.line_of("log")),
                                                   allow_none=True), **_conditions(body, file))

    def resolve(self, resolver: Any, scope: Any) -> None:
        log = resolver.maybe_text(self.log, scope, self.source, "'log'")
        if log:
            resolver.plan.on_shutdown.append(log)


@dataclass
class LaunchDescription:
    """A launch file loaded and checked, nothing run: our YAML's actions (the classes above) or, for ROS's
    formats (``format``: python, xml, ros-yaml), the ROS launch actions the file built (``launch.actions``)."""

    file: Path
    actions: list[Any]
    format: str = "zenroid"

    def declared_args(self) -> list[ArgDecl]:
        """Top-level argument declarations (what ``--show-args`` prints)."""
        from launch.actions import DeclareLaunchArgument
        from launch.context import perform_substitutions

        out = []
        for action in self.actions:
            if isinstance(action, ArgDecl):
                out.append(action)
            elif isinstance(action, DeclareLaunchArgument):
                default = action.default_value
                if default is not None and not all(isinstance(d, str) for d in default):
                    default = " + ".join(d if isinstance(d, str) else d.describe() for d in default)
                elif default is not None:
                    default = perform_substitutions(None, default)  # type: ignore[arg-type]
                out.append(ArgDecl(source=action.source, name=action.name, default=default,
                                   description=action.description, choices=action.choices))
        return out


def _check_keys(mapping: LocatedDict, allowed: tuple[str, ...], what: str, file: Path) -> None:
    for key in mapping:
        if key not in allowed:
            raise LaunchError(f"unknown key '{key}' in {what} (allowed: {', '.join(allowed)})",
                              Source(file, mapping.line_of(key)))


def _scalar_text(value: Any, what: str, source: Source, allow_none: bool = False) -> str | None:
    """Launch values are text (like ROS launch configurations): scalars become strings."""
    if value is None:
        if allow_none:
            return None
        raise LaunchError(f"{what} must have a value", source)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (str, int, float)):
        return str(value)
    raise LaunchError(f"{what} must be a scalar, not a {type(value).__name__}", source)


def _require_mapping(value: Any, what: str, source: Source) -> LocatedDict:
    if not isinstance(value, LocatedDict):
        raise LaunchError(f"{what} must be a mapping, not {_kind(value)}", source)
    return value


def _kind(value: Any) -> str:
    if value is None:
        return "empty"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, dict):
        return "a mapping"
    return f"'{value}'"


def _conditions(mapping: LocatedDict, file: Path) -> dict[str, Any]:
    out = {}
    for key, attr in (("if", "condition_if"), ("unless", "condition_unless")):
        if key in mapping:
            out[attr] = _scalar_text(mapping[key], f"'{key}'", Source(file, mapping.line_of(key)))
    return out


def _rename_deprecated_keys(body: LocatedDict, file: Path) -> None:
    """Read an old key as its new spelling (same value, same line), warning once per use."""
    for old, new in DEPRECATED_NODE_KEYS.items():
        if old not in body:
            continue
        where = Source(file, body.line_of(old))
        if new in body:
            raise LaunchError(f"node has both '{new}' and its old spelling '{old}': keep '{new}'", where)
        warnings.warn(LaunchDeprecationWarning(f"{where}: node key '{old}' is deprecated: use '{new}' (the "
                                               f"spelling of --params-file)"), stacklevel=2)
        body[new] = body.pop(old)
        body.key_lines[new] = where.line


def _parse_node(body: LocatedDict, file: Path, source: Source) -> NodeDecl:
    _rename_deprecated_keys(body, file)
    _check_keys(body, NODE_KEYS, "node", file)
    at = lambda key: Source(file, body.line_of(key))  # noqa: E731 - tiny local helper
    if "name" not in body:
        raise LaunchError("node needs a 'name'", source)
    has_module, has_exec = "module" in body, "exec" in body
    if has_module == has_exec:
        raise LaunchError("node needs exactly one of 'module' (python -m MODULE) or 'exec' (a program)", source)
    for key in ("params", "env"):
        if key in body:
            _require_mapping(body[key], f"node '{key}'", at(key))
    if "remap" in body and not isinstance(body["remap"], (LocatedDict, LocatedList)):
        raise LaunchError("node 'remap' must be a mapping {from: to} or a list of 'from:=to'", at("remap"))
    for key in ("args", "params_file", "wait_for"):
        if key in body and not isinstance(body[key], (LocatedList, str)):
            raise LaunchError(f"node '{key}' must be a list or a string, not {_kind(body[key])}", at(key))
    return NodeDecl(source=source, fields=body, **_conditions(body, file))


def _check_name_value_list(value: Any, what: str, source: Source, allowed: tuple[tuple[str, ...], ...]) -> None:
    """launch_ros's list of small mappings (``param: [{name: x, value: 1}]``, ``remap: [{from: a, to: b}]``):
    each item has exactly one of the ``allowed`` key sets."""
    if not isinstance(value, LocatedList):
        raise LaunchError(f"{what} must be a list of mappings "
                          f"({' or '.join('{' + ', '.join(keys) + '}' for keys in allowed)})", source)
    for i, item in enumerate(value):
        at = Source(source.file, value.line_of(i))
        if not isinstance(item, LocatedDict) or tuple(sorted(item)) not in {tuple(sorted(k)) for k in allowed}:
            raise LaunchError(f"{what} item must be a mapping "
                              f"{' or '.join('{' + ', '.join(keys) + '}' for keys in allowed)}, got {_kind(item)}"
                              f"{': ' + ', '.join(map(str, item)) if isinstance(item, dict) else ''}", at)


def _parse_composable(item: Any, file: Path, source: Source) -> ComposableDecl:
    body = _require_mapping(item, "each composable_node", source)
    _check_keys(body, COMPOSABLE_KEYS, "composable_node", file)
    at = lambda key: Source(file, body.line_of(key))  # noqa: E731 - tiny local helper
    for key, needs in (("plugin", "a 'plugin' (python.module::NodeClass)"), ("name", "a 'name'")):
        if key not in body:
            raise LaunchError(f"composable_node needs {needs}", source)
    if "param" in body:
        _check_name_value_list(body["param"], "composable_node 'param'", at("param"), (("name", "value"), ("from",)))
    if "params" in body:
        _require_mapping(body["params"], "composable_node 'params'", at("params"))
    if "params_file" in body and not isinstance(body["params_file"], (LocatedList, str)):
        raise LaunchError(f"composable_node 'params_file' must be a list or a string, not {_kind(body['params_file'])}",
                          at("params_file"))
    remap = body.get("remap")
    if isinstance(remap, LocatedList) and any(isinstance(r, LocatedDict) for r in remap):
        _check_name_value_list(remap, "composable_node 'remap'", at("remap"), (("from", "to"),))
    elif "remap" in body and not isinstance(remap, (LocatedDict, LocatedList)):
        raise LaunchError("composable_node 'remap' must be a list of {from, to}, a mapping {from: to} or a list "
                          "of 'from:=to'", at("remap"))
    if "extra_arg" in body:
        _check_name_value_list(body["extra_arg"], "composable_node 'extra_arg'", at("extra_arg"), (("name", "value"),))
    return ComposableDecl(source=source, fields=body)


def _parse_container(body: LocatedDict, file: Path, source: Source) -> ContainerDecl:
    _check_keys(body, CONTAINER_KEYS, "node_container", file)
    at = lambda key: Source(file, body.line_of(key))  # noqa: E731 - tiny local helper
    if "name" not in body:
        raise LaunchError("node_container needs a 'name'", source)
    nodes = body.get("composable_node")
    if not isinstance(nodes, LocatedList) or not nodes:
        raise LaunchError("node_container needs 'composable_node': a non-empty list of composable nodes",
                          at("composable_node") if "composable_node" in body else source)
    if "env" in body:
        _require_mapping(body["env"], "node_container 'env'", at("env"))
    if "wait_for" in body and not isinstance(body["wait_for"], (LocatedList, str)):
        raise LaunchError(f"node_container 'wait_for' must be a list or a string, not {_kind(body['wait_for'])}",
                          at("wait_for"))
    composables = [_parse_composable(item, file, Source(file, nodes.line_of(i))) for i, item in enumerate(nodes)]
    return ContainerDecl(source=source, fields=body, composables=composables, **_conditions(body, file))


def _parse_action(item: Any, file: Path, line: int) -> Action:
    source = Source(file, line)
    if not isinstance(item, LocatedDict) or len(item) != 1:
        raise LaunchError(f"each launch action must be a mapping with one key ({', '.join(ACTION_KINDS)})", source)
    (kind, body), = item.items()
    source = Source(file, item.line_of(kind))
    if kind not in KINDS:
        raise LaunchError(f"unknown action '{kind}' (allowed: {', '.join(ACTION_KINDS)})", source)
    return KINDS[kind].parse(_require_mapping(body, f"'{kind}'", source), file, source)


def parse_actions(items: LocatedList, file: Path) -> list[Action]:
    return [_parse_action(item, file, items.line_of(i)) for i, item in enumerate(items)]


def parse_file(path: Path) -> LaunchDescription:
    """Parse and check a launch file's structure (keys, shapes); substitutions stay unevaluated."""
    data = load_located(path)
    if not isinstance(data, LocatedDict):
        raise LaunchError("a launch file is a mapping with one key 'launch' (a list of actions)", Source(path, 1))
    _check_keys(data, ("launch",), "the launch file", path)
    actions = data.get("launch")
    if not isinstance(actions, LocatedList):
        raise LaunchError("'launch' must be a list of actions", Source(path, data.line_of("launch")))
    return LaunchDescription(file=path, actions=parse_actions(actions, path))


ACTION_KINDS = tuple(KINDS)   # in the order the classes above are written
