"""``launch_ros.descriptions``: a node to load into a container."""

from __future__ import annotations

from typing import Any

from launch.context import normalize
from launch_ros.parameter_descriptions import Parameter, ParameterFile, ParameterValue

__all__ = ["ComposableNode", "Parameter", "ParameterFile", "ParameterValue"]


class ComposableNode:
    def __init__(self, *, package: Any, plugin: Any, name: Any = None, namespace: Any = None,
                 parameters: list[Any] | None = None, remappings: list[Any] | None = None,
                 extra_arguments: list[Any] | None = None, condition: Any = None) -> None:
        self.package, self.plugin = normalize(package), normalize(plugin)
        self.name = None if name is None else normalize(name)
        self.namespace = None if namespace is None else normalize(namespace)
        self.parameters = list(parameters or [])
        self.remappings = list(remappings or [])
        self.extra_arguments = list(extra_arguments or [])
        self.condition = condition

    @classmethod
    def parse(cls, entity: Any) -> ComposableNode:
        params: list[Any] = []
        for param in entity.children_of("param"):
            params.append(param.sub("from") if param.has("from") else {param.sub("name"): param.value("value")})
        entity.children_of("extra_arg")   # in-process hand-off is how our container always runs its nodes
        node = cls(package=entity.sub("pkg"), plugin=entity.sub("plugin"), name=entity.sub("name", optional=True),
                   namespace=entity.sub("namespace", optional=True), parameters=params,
                   remappings=[(r.sub("from"), r.sub("to")) for r in entity.children_of("remap")])
        entity.check_used()
        return node
