"""rcl_interfaces' six parameter services of a node, on the ROS 2 wire (``ros2 param``, rclcpp/rclpy
parameter clients, ``AsyncParameterClient``).

``/<ns>/<node>/{get_parameters, set_parameters, set_parameters_atomically, list_parameters,
describe_parameters, get_parameter_types}`` exist on rmw_zenoh's wire only: our own keys of the same names
keep zenroid's YAML-valued ``get_parameters``/``set_parameters`` (``zenroid param``, the launcher's probe),
so the two never meet. Answers follow rclpy's ``ParameterService``: a name the node does not have makes
``get``/``describe``/``types`` answer an empty list, ``set_parameters`` sets each parameter on its own and
``set_parameters_atomically`` all or none.

The answers come from a ``ParameterBackend``: a ``nodes.core`` node's declared parameters by default;
an rclpy node puts its own (rclpy's descriptors and set-parameter callbacks) in its place.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

import msgs
from nodes.core import parameter_values as pv
from nodes.core.node_parameters import NodeParameters
from nodes.core.params import ParameterError

SetParametersResult = msgs.get_type("rcl_interfaces/msg/SetParametersResult")
GetParameters = msgs.get_type("rcl_interfaces/srv/GetParameters")
SetParameters = msgs.get_type("rcl_interfaces/srv/SetParameters")
SetParametersAtomically = msgs.get_type("rcl_interfaces/srv/SetParametersAtomically")
ListParameters = msgs.get_type("rcl_interfaces/srv/ListParameters")
DescribeParameters = msgs.get_type("rcl_interfaces/srv/DescribeParameters")
GetParameterTypes = msgs.get_type("rcl_interfaces/srv/GetParameterTypes")

SERVICES = ("get_parameters", "set_parameters", "set_parameters_atomically", "list_parameters",
            "describe_parameters", "get_parameter_types")


class ParameterBackend(Protocol):
    """What the services ask of a node, in rcl_interfaces messages (rclpy's ``ParameterService`` semantics:
    an undeclared name in get/describe/types gives an empty list)."""

    def get_values(self, names: list[str]) -> list[Any]: ...
    def get_types(self, names: list[str]) -> list[int]: ...
    def describe(self, names: list[str]) -> list[Any]: ...
    def list(self, prefixes: list[str], depth: int) -> Any: ...
    def set_each(self, parameters: list[Any]) -> list[Any]: ...
    def set_atomically(self, parameters: list[Any]) -> Any: ...


class CoreParameterBackend:
    """A ``nodes.core`` node's declared parameters: its descriptors check, its on-set callbacks may veto."""

    def __init__(self, parameters: NodeParameters) -> None:
        self._params = parameters

    def _declared(self, names: list[str]) -> list[tuple[str, Any]] | None:
        found = [(n, self._params.descriptor(n)) for n in names]
        return None if any(d is None for _, d in found) else found

    def get_values(self, names: list[str]) -> list[Any]:
        found = self._declared(names)
        return [] if found is None else [pv.value_msg(d, self._params.get(n)) for n, d in found]

    def get_types(self, names: list[str]) -> list[int]:
        found = self._declared(names)
        return [] if found is None else [pv.declared_type(d, self._params.get(n)) for n, d in found]

    def describe(self, names: list[str]) -> list[Any]:
        found = self._declared(names)
        return [] if found is None else [pv.describe(d, self._params.get(n)) for n, d in found]

    def list(self, prefixes: list[str], depth: int) -> Any:
        return pv.list_parameters(self._params.names(), prefixes, depth)

    def _values(self, parameters: list[Any]) -> dict[str, Any]:
        values = {}
        for p in parameters:
            desc = self._params.descriptor(p.name)
            if desc is None:
                raise ParameterError(f"parameter '{p.name}' is not declared")
            if p.value.type == pv.NOT_SET:
                raise ParameterError(f"parameter '{p.name}': static parameter cannot be undeclared")
            try:
                values[p.name] = pv.from_msg_for(desc, p.value)
            except ValueError as exc:
                raise ParameterError(f"parameter '{p.name}': {exc}") from None
        return values

    def set_each(self, parameters: list[Any]) -> list[Any]:
        return [self.set_atomically([p]) for p in parameters]

    def set_atomically(self, parameters: list[Any]) -> Any:
        try:
            self._params.set_all(self._values(parameters))
        except ParameterError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True, reason="")


class RosParameterServices:
    """The six services of one node, answered on its executor from ``backend`` (replaceable)."""

    def __init__(self, create_service: Callable[..., Any], destroy_entity: Callable[[Any], None],
                 backend: ParameterBackend, node_name: str, logger: Any) -> None:
        self.backend = backend
        self._destroy_entity = destroy_entity
        self._node_name = node_name.rstrip("/")
        self._logger = logger
        handlers = {
            "get_parameters": (GetParameters, self._get),
            "set_parameters": (SetParameters, self._set),
            "set_parameters_atomically": (SetParametersAtomically, self._set_atomically),
            "list_parameters": (ListParameters, self._list),
            "describe_parameters": (DescribeParameters, self._describe),
            "get_parameter_types": (GetParameterTypes, self._types),
        }
        self.servers = [create_service(srv, f"~/{name}", handler, ros2_only=True)
                        for name, (srv, handler) in handlers.items()]

    def close(self) -> None:
        """No parameter services (rclpy's ``start_parameter_services=False``)."""
        for server in self.servers:
            self._destroy_entity(server)
        self.servers = []

    def _get(self, request: Any) -> Any:
        return GetParameters.Response(values=self.backend.get_values(list(request.names)))

    def _set(self, request: Any) -> Any:
        results = self.backend.set_each(list(request.parameters))
        self._log_refusals("set_parameters", results)
        return SetParameters.Response(results=results)

    def _set_atomically(self, request: Any) -> Any:
        result = self.backend.set_atomically(list(request.parameters))
        self._log_refusals("set_parameters_atomically", [result])
        return SetParametersAtomically.Response(result=result)

    def _log_refusals(self, service: str, results: list[Any]) -> None:
        """A refused set is answered (``successful: false`` and the reason) and logged, as every refused
        request is: at most once a second per service, so a flood of bad requests does not flood rosout."""
        reasons = [r.reason for r in results if not r.successful]
        if reasons:
            where = f"{self._node_name}/{service}"
            self._logger.warn_throttle(1.0, f"{where} refused: {'; '.join(reasons)[:300]}", key=where,
                                       per_site=False)

    def _list(self, request: Any) -> Any:
        return ListParameters.Response(result=self.backend.list(list(request.prefixes), int(request.depth)))

    def _describe(self, request: Any) -> Any:
        return DescribeParameters.Response(descriptors=self.backend.describe(list(request.names)))

    def _types(self, request: Any) -> Any:
        return GetParameterTypes.Response(types=self.backend.get_types(list(request.names)))
