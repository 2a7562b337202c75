"""``ParameterService``: an rclpy node's answers to rcl_interfaces' six parameter services, as rclpy's
ParameterService gives them. The services themselves are the node's ``nodes.core`` node's
(nodes/core/ros_parameters.py, on the ROS 2 wire); this object is what they ask."""

from __future__ import annotations

import weakref
from typing import Any

import msgs
from rclpy.exceptions import ParameterNotDeclaredException, ParameterUninitializedException
from rclpy.parameter import Parameter

ListParametersResult = msgs.get_type("rcl_interfaces/msg/ListParametersResult")
SetParametersResult = msgs.get_type("rcl_interfaces/msg/SetParametersResult")


def _failure(reason: str) -> Any:
    return SetParametersResult(successful=False, reason=reason)


class ParameterService:
    def __init__(self, node: Any) -> None:
        self._node_weak_ref = weakref.ref(node)

    def _get_node(self) -> Any:
        node = self._node_weak_ref()
        if node is None:
            raise ReferenceError("Expected valid node weak reference")
        return node

    def get_values(self, names: list[str]) -> list[Any]:
        node = self._get_node()
        values = []
        for name in names:
            try:
                values.append(node.get_parameter(name).get_parameter_value())
            except (ParameterNotDeclaredException, ParameterUninitializedException):
                return []
        return values

    def get_types(self, names: list[str]) -> list[int]:
        node = self._get_node()
        types = []
        for name in names:
            try:
                node.describe_parameter(name)
            except ParameterNotDeclaredException:
                return []
            types.append(node.get_parameter_types([name])[0].value)
        return types

    def describe(self, names: list[str]) -> list[Any]:
        node = self._get_node()
        descriptors = []
        for name in names:
            try:
                descriptors.append(node.describe_parameter(name))
            except ParameterNotDeclaredException:
                return []
        return descriptors

    def list(self, prefixes: list[str], depth: int) -> Any:
        try:
            return self._get_node().list_parameters(prefixes, depth)
        except (TypeError, ValueError):
            return ListParametersResult()

    def set_each(self, parameters: list[Any]) -> list[Any]:
        return [self.set_atomically([p]) for p in parameters]

    def set_atomically(self, parameters: list[Any]) -> Any:
        node = self._get_node()
        try:
            return node.set_parameters_atomically([Parameter.from_parameter_msg(p) for p in parameters])
        except ParameterNotDeclaredException as exc:
            return _failure(str(exc))
        except (TypeError, ValueError, RuntimeError) as exc:   # a value that does not match its type
            return _failure(f"{type(exc).__name__}: {exc}")
