"""``AsyncParameterClient``: another node's parameters through rcl_interfaces' six parameter services on the
ROS 2 wire, as rclpy's does. It reaches zenroid nodes, rclpy-on-zenroid nodes and real ROS 2 nodes over
rmw_zenoh alike. Futures complete on the spinning thread with the services' responses."""

from __future__ import annotations

import time
from typing import Any

import msgs
from nodes.core.params import load_params_file
from rclpy._entities import _calls
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_parameter_events
from rclpy.task import Future

_SERVICES = {
    "get_parameters": "GetParameters",
    "set_parameters": "SetParameters",
    "set_parameters_atomically": "SetParametersAtomically",
    "list_parameters": "ListParameters",
    "describe_parameters": "DescribeParameters",
    "get_parameter_types": "GetParameterTypes",
}
_TIMEOUT_S = 10.0


def _srv(name: str) -> Any:
    return msgs.get_type(f"rcl_interfaces/srv/{name}")


def _parameter_msgs(parameters: list[Any]) -> list[Any]:
    return [p.to_parameter_msg() if isinstance(p, Parameter) else p for p in parameters]


class AsyncParameterClient:
    def __init__(self, node: Any, remote_node_name: str, qos_profile: Any = None, callback_group: Any = None
                 ) -> None:
        self._node = node
        self.remote_node_name = remote_node_name
        self._group = node._zr_group(callback_group)
        self._clients: dict[str, Any] = {}
        for service, type_name in _SERVICES.items():
            key = node._zr_resolve(f"{remote_node_name}/{service}")
            self._clients[service] = node._zr.create_ros2_client(_srv(type_name), "/" + key)

    def services_are_ready(self) -> bool:
        return all(client.service_is_ready() for client in self._clients.values())

    def wait_for_services(self, timeout_sec: float | None = None) -> bool:
        deadline = None if timeout_sec is None else time.monotonic() + timeout_sec
        while not self.services_are_ready():
            if deadline is not None and time.monotonic() >= deadline:
                return False
            time.sleep(0.05)
        return True

    def _call(self, service: str, request: Any, callback: Any = None) -> Future:
        """The response on a Future completed on the node's spinning thread (the call waits on a thread of
        its own)."""
        future = Future()
        if callback is not None:
            future.add_done_callback(callback)
        executor = self._node._zr.executor
        client = self._clients[service]

        def run() -> None:
            try:
                result, error = client.call(request, timeout=_TIMEOUT_S), None
            except Exception as exc:  # noqa: BLE001 - the future carries it
                result, error = None, exc

            def done() -> None:
                if error is not None:
                    future.set_exception(error)
                else:
                    future.set_result(result)

            executor.put((done, (), "parameter client", self._group))

        _calls.submit(run)
        return future

    def list_parameters(self, prefixes: list[str] | None = None, depth: int | None = None,
                        callback: Any = None) -> Future:
        request = _srv("ListParameters").Request(prefixes=list(prefixes or []), depth=int(depth or 0))
        return self._call("list_parameters", request, callback)

    def get_parameters(self, names: list[str], callback: Any = None) -> Future:
        return self._call("get_parameters", _srv("GetParameters").Request(names=list(names)), callback)

    def set_parameters(self, parameters: list[Any], callback: Any = None) -> Future:
        request = _srv("SetParameters").Request(parameters=_parameter_msgs(parameters))
        return self._call("set_parameters", request, callback)

    def describe_parameters(self, names: list[str], callback: Any = None) -> Future:
        return self._call("describe_parameters", _srv("DescribeParameters").Request(names=list(names)), callback)

    def get_parameter_types(self, names: list[str], callback: Any = None) -> Future:
        return self._call("get_parameter_types", _srv("GetParameterTypes").Request(names=list(names)), callback)

    def set_parameters_atomically(self, parameters: list[Any], callback: Any = None) -> Future:
        request = _srv("SetParametersAtomically").Request(parameters=_parameter_msgs(parameters))
        return self._call("set_parameters_atomically", request, callback)

    def delete_parameters(self, names: list[str], callback: Any = None) -> Future:
        """Each name set to NOT_SET, as rclpy does: the remote node refuses it for a statically typed
        parameter ("Static parameter cannot be undeclared")."""
        request = _srv("SetParameters").Request(parameters=[Parameter(n).to_parameter_msg() for n in names])
        return self._call("set_parameters", request, callback)

    def _file_parameters(self, parameter_file: str) -> list[Parameter]:
        node_name = self.remote_node_name.rstrip("/").rsplit("/", 1)[-1]
        values = load_params_file(parameter_file, node_name)
        return [Parameter(n, value=v) for n, v in values.items() if not isinstance(v, dict)]

    def load_parameter_file(self, parameter_file: str, use_wildcard: bool = False, callback: Any = None) -> Future:
        return self.set_parameters(self._file_parameters(parameter_file), callback)

    def load_parameter_file_atomically(self, parameter_file: str, use_wildcard: bool = False,
                                       callback: Any = None) -> Future:
        return self.set_parameters_atomically(self._file_parameters(parameter_file), callback)

    def on_parameter_event(self, callback: Any, qos_profile: Any = qos_profile_parameter_events, *,
                           callback_group: Any = None, event_callbacks: Any = None,
                           qos_overriding_options: Any = None, raw: bool = False) -> Any:
        """A subscription to ``/parameter_events``: every node's events, not only the remote node's (as
        rclpy's)."""
        return self._node.create_subscription(
            msgs.get_type("rcl_interfaces/msg/ParameterEvent"), "/parameter_events", callback, qos_profile,
            callback_group=callback_group, event_callbacks=event_callbacks,
            qos_overriding_options=qos_overriding_options, raw=raw)

    def destroy(self) -> None:
        for client in self._clients.values():
            self._node._zr.destroy_entity(client)
        self._clients.clear()
