"""Finds interface definitions on disk and turns them into typed message classes."""

from __future__ import annotations

import os
import threading
from pathlib import Path
from typing import Any

from msgs.classes import make_class
from msgs.idl import (
    FLOAT_TYPES,
    INT_RANGES,
    STRING_TYPES,
    DefinitionError,
    FieldSpec,
    MsgSpec,
    parse_message,
    split_sections,
)

BUILTIN_DIR = Path(__file__).resolve().parent / "definitions"
ENV_PATH = "ZENROID_MSG_PATH"

_search_paths: list[Path] = [BUILTIN_DIR]
_specs: dict[str, MsgSpec] = {}
_classes: dict[str, Any] = {}
_lock = threading.RLock()


def add_search_path(path: str | os.PathLike[str]) -> None:
    """Make ``path/<pkg>/{msg,srv,action}/*`` definitions available (user message packages)."""
    p = Path(path).resolve()
    if not p.is_dir():
        raise FileNotFoundError(f"message search path {p} is not a directory")
    with _lock:
        if p not in _search_paths:
            _search_paths.insert(0, p)


def _env_paths() -> list[Path]:
    raw = os.environ.get(ENV_PATH, "")
    return [Path(p) for p in raw.split(os.pathsep) if p]


def search_paths() -> list[Path]:
    return [*_env_paths(), *_search_paths]


def normalize(type_name: str) -> tuple[str, str, str]:
    """("pkg", "kind", "Name") for "pkg/kind/Name" or "pkg/Name" (kind found on disk)."""
    parts = type_name.strip().strip("/").split("/")
    if len(parts) == 3:
        return parts[0], parts[1], parts[2]
    if len(parts) == 2:
        pkg, name = parts
        for kind in ("msg", "srv", "action"):
            if _find_file(pkg, kind, name.split("_")[0]) is not None:
                return pkg, kind, name
        return pkg, "msg", name
    raise KeyError(f"bad type name '{type_name}': expected 'pkg/msg/Name' or 'pkg/Name'")


def _find_file(pkg: str, kind: str, name: str) -> Path | None:
    """The definition file: folders given explicitly first (ZENROID_MSG_PATH, ``add_search_path``), then the
    package index (the user's workspace overrides a package zenroid also ships, as humanoid_msgs), then ours."""
    for root in search_paths():
        if root == BUILTIN_DIR:
            continue
        candidate = root / pkg / kind / f"{name}.{kind}"
        if candidate.is_file():
            return candidate
    share = interface_packages().get(pkg)
    candidate = share / kind / f"{name}.{kind}" if share is not None else None
    if candidate is not None and candidate.is_file():
        return candidate
    candidate = BUILTIN_DIR / pkg / kind / f"{name}.{kind}"
    return candidate if candidate.is_file() else None


def definition_file(type_name: str) -> Path | None:
    """The ``.msg``/``.srv``/``.action`` file of a type ("pkg/kind/Name" or "pkg/Name"), or None."""
    pkg, kind, name = normalize(type_name)
    return _find_file(pkg, kind, name)


_interface_packages: tuple[Any, dict[str, Path]] | None = None


def interface_packages() -> dict[str, Path]:
    """ROS packages of the package index (the workspace's src/, ROS_PACKAGE_PATH, AMENT_PREFIX_PATH ...) that
    hold msg/, srv/ or action/ folders: user interface packages, found as ROS finds them (kept until the index
    scans again)."""
    from nodes.packages.index import index  # the index scans the disk once per directory and environment

    global _interface_packages
    current = index()
    known = _interface_packages
    if known is None or known[0] is not current:
        known = _interface_packages = (current, {
            name: package.share for name, package in sorted(current.packages.items())
            if any((package.share / kind).is_dir() for kind in ("msg", "srv", "action"))})
    return known[1]


def get_spec(full_name: str) -> MsgSpec:
    with _lock:
        spec = _specs.get(full_name)
        if spec is None:
            _load(full_name)
            spec = _specs.get(full_name)
        if spec is None:
            raise KeyError(f"unknown message type '{full_name}'")
        return spec


def _load(full_name: str) -> None:
    pkg, kind, name = full_name.split("/")
    base_name = name.split("_")[0] if kind in ("srv", "action") else name
    path = _find_file(pkg, kind, base_name)
    if path is None:
        raise KeyError(f"unknown type '{full_name}' (searched {', '.join(map(str, search_paths()))})")
    text = path.read_text()
    if kind == "msg":
        register_spec(parse_message(text, full_name))
    elif kind == "srv":
        req, resp = split_sections(text, 2, full_name)
        register_spec(parse_message(req, f"{pkg}/srv/{base_name}_Request"))
        register_spec(parse_message(resp, f"{pkg}/srv/{base_name}_Response"))
    elif kind == "action":
        _register_action(pkg, base_name, text)
    else:
        raise KeyError(f"bad interface kind '{kind}' in '{full_name}'")


def _register_action(pkg: str, name: str, text: str) -> None:
    goal, result, feedback = split_sections(text, 3, f"{pkg}/action/{name}")
    prefix = f"{pkg}/action/{name}"
    register_spec(parse_message(goal, f"{prefix}_Goal"))
    register_spec(parse_message(result, f"{prefix}_Result"))
    register_spec(parse_message(feedback, f"{prefix}_Feedback"))
    uuid = FieldSpec("goal_id", "unique_identifier_msgs/msg/UUID")
    # The ROS 2 action layout (docs/architecture.md, Services and actions): send_goal / get_result services and the feedback topic.
    register_spec(MsgSpec(f"{prefix}_SendGoal_Request", (uuid, FieldSpec("goal", f"{prefix}_Goal"))))
    register_spec(MsgSpec(f"{prefix}_SendGoal_Response", (
        FieldSpec("accepted", "bool"), FieldSpec("stamp", "builtin_interfaces/msg/Time"))))
    register_spec(MsgSpec(f"{prefix}_GetResult_Request", (uuid,)))
    register_spec(MsgSpec(f"{prefix}_GetResult_Response", (
        FieldSpec("status", "int8"), FieldSpec("result", f"{prefix}_Result"))))
    register_spec(MsgSpec(f"{prefix}_FeedbackMessage", (uuid, FieldSpec("feedback", f"{prefix}_Feedback"))))


def register_spec(spec: MsgSpec) -> None:
    with _lock:
        _specs[spec.type_name] = spec


def register_message(type_name: str, definition: str) -> Any:
    """Define a message type from text at run time ("pkg/msg/Name")."""
    spec = parse_message(definition, type_name)
    register_spec(spec)
    _classes.pop(type_name, None)
    return get_class(type_name)


# ---------------------------------------------------------------- classes

def default_value(f: FieldSpec) -> Any:
    """A fresh ROS default for a field (what a missing field decodes to)."""
    if f.default is not None:
        return bytes(f.default) if f.is_bytes else (list(f.default) if f.is_array else f.default)
    if f.is_array:
        n = f.array_size or 0
        if f.is_bytes:
            return bytes(n)
        if f.is_primitive:
            return [_scalar_default(f.base)] * n
        cls = get_class(f.base)
        return [cls() for _ in range(n)]
    if f.is_primitive:
        return _scalar_default(f.base)
    return get_class(f.base)()


def _scalar_default(base: str) -> Any:
    if base == "bool":
        return False
    if base in FLOAT_TYPES:
        return 0.0
    if base in INT_RANGES:
        return 0
    if base in STRING_TYPES:
        return ""
    raise DefinitionError(f"no default for {base}")


def get_class(full_name: str) -> Any:
    """The message class of ``full_name`` (msgs/classes.py), made on first use."""
    with _lock:
        cls = _classes.get(full_name)
        if cls is not None:
            return cls
        cls, resolve = make_class(get_spec(full_name), default_value)
        _classes[full_name] = cls
        try:
            resolve(get_class)   # nested classes; a type may refer back to this one, now registered
        except BaseException:
            del _classes[full_name]
            raise
        return cls


class Service:
    """A ``.srv`` type: ``Request`` and ``Response`` classes."""

    def __init__(self, full_name: str) -> None:
        self._type = full_name
        self.Request = get_class(f"{full_name}_Request")
        self.Response = get_class(f"{full_name}_Response")

    def __repr__(self) -> str:
        return f"<service {self._type}>"


class Action:
    """An ``.action`` type: ``Goal``/``Result``/``Feedback`` and the wire-level wrappers."""

    def __init__(self, full_name: str) -> None:
        self._type = full_name
        self.Goal = get_class(f"{full_name}_Goal")
        self.Result = get_class(f"{full_name}_Result")
        self.Feedback = get_class(f"{full_name}_Feedback")
        self.SendGoalRequest = get_class(f"{full_name}_SendGoal_Request")
        self.SendGoalResponse = get_class(f"{full_name}_SendGoal_Response")
        self.GetResultRequest = get_class(f"{full_name}_GetResult_Request")
        self.GetResultResponse = get_class(f"{full_name}_GetResult_Response")
        self.FeedbackMessage = get_class(f"{full_name}_FeedbackMessage")

    def __repr__(self) -> str:
        return f"<action {self._type}>"


_interfaces: dict[str, Any] = {}


def get_type(type_name: str) -> Any:
    """The class (msg) or Service/Action object for "pkg/kind/Name" or "pkg/Name"."""
    pkg, kind, name = normalize(type_name)
    full = f"{pkg}/{kind}/{name}"
    with _lock:
        if kind == "msg" or "_" in name:
            return get_class(full)
        if full not in _interfaces:
            _interfaces[full] = Service(full) if kind == "srv" else Action(full)
        return _interfaces[full]


def list_types() -> list[str]:
    """Every interface found on the search paths, as "pkg/kind/Name"."""
    found: set[str] = set()
    for root in search_paths():
        if not root.is_dir():
            continue
        for path in root.glob("*/*/*.*"):
            kind = path.parent.name
            if kind in ("msg", "srv", "action") and path.suffix == f".{kind}":
                found.add(f"{path.parent.parent.name}/{kind}/{path.stem}")
    for pkg, share in interface_packages().items():
        for kind in ("msg", "srv", "action"):
            found.update(f"{pkg}/{kind}/{path.stem}" for path in (share / kind).glob(f"*.{kind}"))
    return sorted(found)


def package_names() -> list[str]:
    return sorted({t.split("/")[0] for t in list_types()})
