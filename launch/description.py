"""The inert launch description: a YAML launch file parsed and checked, nothing substituted or started.

Format (docs/launch.md, Format)::

    launch:
      - arg: {name: x, default: "0.0", description: "...", choices: [...]}
      - node: {name: sim, module: nodes.sim, namespace: humanoid, params: {...}, ...}
      - include: {file: other.yaml, args: {x: "1"}}
      - group: {namespace: ns, actions: [...]}
      - on_exit: {node: spawner, log: "...", shutdown: false}
      - on_shutdown: {log: "..."}
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from launch.yaml_source import LaunchError, LocatedDict, LocatedList, Source, load_located

CONDITION_KEYS = ("if", "unless")

# Old spellings still read, with a warning naming the new one: old key -> new key.
DEPRECATED_NODE_KEYS = {"param_file": "params_file"}
NODE_KEYS = (
    "name", "module", "exec", "args", "namespace", "params", "params_file", "remap", "env",
    "respawn", "respawn_delay", "respawn_max", "required", "output", "wait_for", "wait_timeout",
    "health_timeout", "exclusive_cpu", *CONDITION_KEYS,
)
ARG_KEYS = ("name", "default", "description", "choices")
INCLUDE_KEYS = ("file", "args", *CONDITION_KEYS)
GROUP_KEYS = ("namespace", "actions", *CONDITION_KEYS)
ON_EXIT_KEYS = ("node", "log", "shutdown", *CONDITION_KEYS)
ON_SHUTDOWN_KEYS = ("log", *CONDITION_KEYS)
# action -> (allowed keys, the key it cannot do without, how the error says so)
_ACTION_KEYS = {
    "arg": (ARG_KEYS, "name", "a 'name'"),
    "include": (INCLUDE_KEYS, "file", "a 'file'"),
    "group": (GROUP_KEYS, "", ""),
    "on_exit": (ON_EXIT_KEYS, "node", "the 'node' it watches"),
    "on_shutdown": (ON_SHUTDOWN_KEYS, "", ""),
}


class LaunchDeprecationWarning(UserWarning):
    """An old spelling in a launch file: it still works; the launcher prints the warning with file:line."""


@dataclass
class Action:
    """Base of every action: where it was written and its raw ``if`` / ``unless`` conditions."""

    source: Source
    condition_if: Any = None
    condition_unless: Any = None


@dataclass
class ArgDecl(Action):
    name: str = ""
    default: str | None = None
    description: str = ""
    choices: list[str] | None = None


@dataclass
class NodeDecl(Action):
    """A node with its raw (unsubstituted) fields; ``fields`` is the YAML mapping itself."""

    fields: LocatedDict = field(default_factory=LocatedDict)

    def line_source(self, key: str) -> Source:
        return Source(self.source.file, self.fields.line_of(key))


@dataclass
class IncludeDecl(Action):
    file: str = ""
    args: LocatedDict | None = None


@dataclass
class GroupDecl(Action):
    namespace: Any = None
    actions: list[Action] = field(default_factory=list)


@dataclass
class OnExitDecl(Action):
    node: str = ""
    log: Any = None
    shutdown: Any = False


@dataclass
class OnShutdownDecl(Action):
    log: Any = None


@dataclass
class LaunchDescription:
    file: Path
    actions: list[Action]

    def declared_args(self) -> list[ArgDecl]:
        """Top-level argument declarations (what ``--show-args`` prints)."""
        return [a for a in self.actions if isinstance(a, ArgDecl)]


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


def _parse_action(item: Any, file: Path, line: int) -> Action:
    source = Source(file, line)
    if not isinstance(item, LocatedDict) or len(item) != 1:
        raise LaunchError("each launch action must be a mapping with one key "
                          "(arg, node, include, group, on_exit, on_shutdown)", source)
    (kind, body), = item.items()
    source = Source(file, item.line_of(kind))
    if kind not in ("arg", "node", "include", "group", "on_exit", "on_shutdown"):
        raise LaunchError(f"unknown action '{kind}' (allowed: arg, node, include, group, on_exit, on_shutdown)",
                          source)
    body = _require_mapping(body, f"'{kind}'", source)
    at = lambda key: Source(file, body.line_of(key))  # noqa: E731 - tiny local helper
    if kind == "node":
        return _parse_node(body, file, source)
    allowed, required, needs = _ACTION_KEYS[kind]
    _check_keys(body, allowed, kind, file)
    if required and required not in body:
        raise LaunchError(f"{kind} needs {needs}", source)
    if kind == "arg":
        choices = body.get("choices")
        if choices is not None:
            if not isinstance(choices, list) or not choices:
                raise LaunchError("arg 'choices' must be a non-empty list", at("choices"))
            choices = [_scalar_text(c, "a choice", at("choices")) for c in choices]
        return ArgDecl(
            source=source,
            name=_scalar_text(body["name"], "arg 'name'", at("name")),
            default=_scalar_text(body.get("default"), "arg 'default'", at("default"), allow_none=True),
            description=_scalar_text(body.get("description", ""), "arg 'description'", at("description")),
            choices=choices,
        )
    if kind == "include":
        args = body.get("args")
        if args is not None:
            _require_mapping(args, "include 'args'", at("args"))
        return IncludeDecl(source=source, file=_scalar_text(body["file"], "include 'file'", at("file")),
                           args=args, **_conditions(body, file))
    if kind == "group":
        actions = body.get("actions")
        if not isinstance(actions, LocatedList):
            raise LaunchError("group needs 'actions': a list of actions", source)
        namespace = _scalar_text(body.get("namespace"), "group 'namespace'", at("namespace"), allow_none=True)
        return GroupDecl(source=source, namespace=namespace, actions=parse_actions(actions, file),
                         **_conditions(body, file))
    if kind == "on_exit":
        return OnExitDecl(source=source, node=_scalar_text(body["node"], "on_exit 'node'", at("node")),
                          log=_scalar_text(body.get("log"), "'log'", at("log"), allow_none=True),
                          shutdown=_scalar_text(body.get("shutdown", False), "'shutdown'", at("shutdown")),
                          **_conditions(body, file))
    return OnShutdownDecl(source=source, log=_scalar_text(body.get("log"), "'log'", at("log"), allow_none=True),
                          **_conditions(body, file))


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
