"""ROS's XML and YAML launch front ends (``<launch><node pkg= exec=/>``, ``launch: [- node: {pkg:, exec:}]``).

Both read into ``Entity`` objects; each tag's action class parses its own entity (``parse``), so the two
formats build the same ROS launch actions a ``.launch.py`` builds. Attribute text keeps its ``$(...)``
substitutions (``FrontendText``), performed when the launch is resolved.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from launch.context import LaunchContext, Substitution
from launch.yaml_source import LaunchError, LocatedDict, LocatedList, Source


class FrontendText(Substitution):
    """An attribute's text with ROS frontend substitutions (``$(var x)``, ``$(find-pkg-share p)``...)."""

    def __init__(self, text: str, source: Source) -> None:
        self.text, self.source = text, source

    def perform(self, context: LaunchContext) -> str:
        from launch._yaml_substitutions import SubstitutionContext, substitute

        if "$(" not in self.text:
            return self.text
        ctx = SubstitutionContext(variables=context.launch_configurations,
                                  current_file=context.current_file or self.source.file, environ=context.environment)
        return substitute(self.text, ctx, self.source)

    def describe(self) -> str:
        return repr(self.text)


def _actions_table() -> dict[str, Any]:
    from launch import actions as a
    from launch_ros import actions as r

    return {
        "arg": a.DeclareLaunchArgument, "let": a.SetLaunchConfiguration, "executable": a.ExecuteProcess,
        "include": a.IncludeLaunchDescription, "group": a.GroupAction, "timer": a.TimerAction, "log": a.LogInfo,
        "set_env": a.SetEnvironmentVariable, "unset_env": a.UnsetEnvironmentVariable, "shutdown": a.Shutdown,
        "node": r.Node, "push_ros_namespace": r.PushRosNamespace, "set_parameter": r.SetParameter,
        "set_remap": r.SetRemap, "node_container": r.ComposableNodeContainer,
        "load_composable_node": r.LoadComposableNodes,
    }


class Entity:
    """One tag of a ROS XML or YAML launch file: its attributes (text), child tags, and where it was."""

    def __init__(self, kind: str, attrs: dict[str, Any], children: list[Entity], source: Source,
                 attr_lines: dict[str, int] | None = None) -> None:
        self.kind = kind.replace("-", "_")
        self.attrs, self.children, self.source = attrs, children, source
        self.attr_lines = attr_lines or {}
        self.used: set[str] = set()

    def at(self, name: str) -> Source:
        return Source(self.source.file, self.attr_lines.get(name, self.source.line))

    def has(self, name: str) -> bool:
        return name in self.attrs

    def get(self, name: str, optional: bool = False, text: bool = False) -> Any:
        self.used.add(name)
        if name not in self.attrs:
            if optional:
                return None
            raise LaunchError(f"<{self.kind}> needs the attribute '{name}'", self.source)
        value = self.attrs[name]
        if text and not isinstance(value, str):
            value = _scalar(value)
        return value

    def sub(self, name: str, optional: bool = False) -> FrontendText | None:
        value = self.get(name, optional=optional)
        if value is None:
            return None
        if not isinstance(value, (str, int, float, bool)):
            raise LaunchError(f"<{self.kind}> attribute '{name}' must be a scalar, not {type(value).__name__}",
                              self.at(name))
        return FrontendText(_scalar(value), self.at(name))

    def value(self, name: str) -> Any:
        """A parameter value: text (typed when it is resolved) or, from YAML, the typed value itself; with a
        ``NAME-sep`` attribute (launch_xml's list spelling, ``value="1,2" value-sep=","``), the text split on
        it into a list whose items are typed one by one."""
        raw = self.get(name)
        separator = self.get(f"{name}-sep", optional=True)
        if separator is not None:
            if not isinstance(raw, str) or not isinstance(separator, str) or not separator:
                raise LaunchError(f"<{self.kind}> attribute '{name}-sep' needs a text '{name}' and a separator "
                                  f"that is not empty", self.at(f"{name}-sep"))
            # each item its own substitution list: a flat list of substitutions would be one text, joined
            return [[FrontendText(part, self.at(name))] for part in raw.split(separator)]
        if isinstance(raw, str):
            return FrontendText(raw, self.at(name))
        if isinstance(raw, list):
            return [[FrontendText(v, self.at(name))] if isinstance(v, str) else v for v in raw]
        return raw

    def children_of(self, kind: str) -> list[Entity]:
        self.used.add(kind)
        return [child for child in self.children if child.kind == kind]

    def actions(self) -> list[Any]:
        self.used.add("children")
        return [parse_entity(child) for child in self.children]

    def condition(self) -> dict[str, Any]:
        from launch.conditions import IfCondition, UnlessCondition

        if "if" in self.attrs and "unless" in self.attrs:
            raise LaunchError(f"<{self.kind}> has both 'if' and 'unless'", self.source)
        for key, kind in (("if", IfCondition), ("unless", UnlessCondition)):
            if key in self.attrs:
                return {"condition": kind(self.sub(key))}
        return {}

    def check_used(self) -> None:
        unknown = sorted(set(self.attrs) - self.used - {"if", "unless"})
        if unknown:
            raise LaunchError(f"unknown attribute(s) of <{self.kind}>: {', '.join(unknown)}", self.at(unknown[0]))


def _scalar(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)


def parse_entity(entity: Entity) -> Any:
    table = _actions_table()
    kind = table.get(entity.kind)
    if kind is None:
        raise LaunchError(f"unknown launch action <{entity.kind}> (known: {', '.join(sorted(table))})", entity.source)
    action = kind.parse(entity)
    entity.check_used()
    action.source = entity.source
    return action


# -- XML ------------------------------------------------------------------------------------------------
def load_xml(path: Path, text: str) -> list[Any]:
    from lxml import etree

    parser = etree.XMLParser(resolve_entities=False, no_network=True, remove_comments=True)
    try:
        root = etree.fromstring(text.encode("utf-8"), parser)
    except etree.XMLSyntaxError as exc:
        raise LaunchError(f"invalid XML: {exc.msg}", Source(path, exc.lineno or 0)) from None
    if root.tag != "launch":
        raise LaunchError(f"a ROS XML launch file's root is <launch>, not <{root.tag}>", Source(path, root.sourceline))
    return [parse_entity(_xml_entity(child, path)) for child in root if isinstance(child.tag, str)]


def _xml_entity(element: Any, path: Path) -> Entity:
    children = [_xml_entity(child, path) for child in element if isinstance(child.tag, str)]
    return Entity(element.tag, dict(element.attrib), children, Source(path, element.sourceline or 0))


# -- ROS YAML -------------------------------------------------------------------------------------------
def load_ros_yaml(path: Path, data: LocatedDict) -> list[Any]:
    items = data.get("launch")
    if not isinstance(items, LocatedList):
        raise LaunchError("'launch' must be a list of actions", Source(path, data.line_of("launch")))
    return [parse_entity(_yaml_entity(item, path, items.line_of(i))) for i, item in enumerate(items)]


# keys whose list of mappings are child tags (not actions): node's param/remap/env, include's arg, ...
_NESTED = ("param", "remap", "env", "arg", "choice", "composable_node", "extra_arg")


def _yaml_entity(item: Any, path: Path, line: int) -> Entity:
    if not isinstance(item, LocatedDict) or len(item) != 1:
        raise LaunchError("each launch action must be a mapping with one key (its tag)", Source(path, line))
    (kind, body), = item.items()
    source = Source(path, item.line_of(kind))
    if isinstance(body, LocatedList):   # group: [actions...]
        return Entity(kind, {}, [_yaml_entity(c, path, body.line_of(i)) for i, c in enumerate(body)], source)
    if body is None:
        body = LocatedDict()
        body.key_lines = {}
    if not isinstance(body, LocatedDict):
        raise LaunchError(f"'{kind}' must be a mapping of its attributes", source)
    attrs: dict[str, Any] = {}
    children: list[Entity] = []
    for key, value in body.items():
        if key == "children" and isinstance(value, LocatedList):
            children += [_yaml_entity(c, path, value.line_of(i)) for i, c in enumerate(value)]
        elif key in _NESTED and isinstance(value, LocatedList) and all(isinstance(v, LocatedDict) for v in value):
            for i, sub in enumerate(value):
                nested = Entity(key, dict(sub), [], Source(path, value.line_of(i)), dict(sub.key_lines))
                if key == "composable_node":
                    nested.children = [Entity(k, dict(x), [], Source(path, sub.line_of(k)))
                                       for k in ("param", "remap", "extra_arg") if isinstance(sub.get(k), list)
                                       for x in sub[k]]
                    for k in ("param", "remap", "extra_arg"):
                        nested.attrs.pop(k, None)
                children.append(nested)
        else:
            attrs[key] = value
    return Entity(kind, attrs, children, source, dict(body.key_lines))
