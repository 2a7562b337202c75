"""``AsyncParameterClient``: another node's parameters through the services every zenroid node offers
(``~/get_parameters``, ``~/set_parameters``: names and YAML values). Futures complete on the spinning thread
with rcl_interfaces-shaped responses (``.values``, ``.results``)."""

from __future__ import annotations

import time
from typing import Any

from msgs.zenroid_msgs import GetParameters, SetParameters
from nodes.core.params import dump_value, parse_value
from rclpy._entities import _calls
from rclpy.exceptions import not_implemented
from rclpy.parameter import Parameter
from rclpy.task import Future


class _Result:
    def __init__(self, **fields: Any) -> None:
        self.__dict__.update(fields)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.__dict__})"


class AsyncParameterClient:
    def __init__(self, node: Any, remote_node_name: str, qos_profile: Any = None, callback_group: Any = None
                 ) -> None:
        self._node = node
        name = remote_node_name if remote_node_name.startswith("/") else \
            "/" + "/".join(p for p in (node.get_namespace().strip("/"), remote_node_name) if p)
        self.remote_node_name = name
        self._get = node._zr.create_client(GetParameters, f"{name}/get_parameters")
        self._set = node._zr.create_client(SetParameters, f"{name}/set_parameters")
        self._group = node._zr_group(callback_group)

    def services_are_ready(self) -> bool:
        return self._get.service_is_ready() and self._set.service_is_ready()

    def wait_for_services(self, timeout_sec: float | None = None) -> bool:
        deadline = None if timeout_sec is None else time.monotonic() + timeout_sec
        while not self.services_are_ready():
            if deadline is not None and time.monotonic() >= deadline:
                return False
            time.sleep(0.05)
        return True

    def _async(self, work: Any, callback: Any = None) -> Future:
        future = Future()
        if callback is not None:
            future.add_done_callback(callback)
        executor = self._node._zr.executor

        def run() -> None:
            try:
                result, error = work(), None
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

    def get_parameters(self, names: list[str], callback: Any = None) -> Future:
        def work() -> Any:
            response = self._get.call(GetParameters.Request(names=list(names)), timeout=10.0)
            values = dict(zip(response.names, response.values_yaml))
            return _Result(values=[Parameter(n, value=parse_value(values[n])).get_parameter_value()
                                   if n in values else Parameter(n).get_parameter_value() for n in names])
        return self._async(work, callback)

    def set_parameters(self, parameters: list[Parameter], callback: Any = None) -> Future:
        def work() -> Any:
            response = self._set.call(SetParameters.Request(
                names=[p.name for p in parameters], values_yaml=[dump_value(p.value) for p in parameters]),
                timeout=10.0)
            from rclpy.node import SetParametersResult

            return _Result(results=[SetParametersResult(ok, reason)
                                    for ok, reason in zip(response.successful, response.reasons)])
        return self._async(work, callback)

    def list_parameters(self, prefixes: list[str] | None = None, depth: int = 0, callback: Any = None) -> Future:
        def work() -> Any:
            response = self._get.call(GetParameters.Request(names=[]), timeout=10.0)
            names = [n for n in response.names
                     if not prefixes or any(n == p or n.startswith(p + ".") for p in prefixes)]
            return _Result(result=_Result(names=names, prefixes=sorted({n.rsplit(".", 1)[0]
                                                                        for n in names if "." in n})))
        return self._async(work, callback)

    def set_parameters_atomically(self, parameters: list[Parameter], callback: Any = None) -> Future:
        raise not_implemented("AsyncParameterClient.set_parameters_atomically")

    def describe_parameters(self, names: list[str], callback: Any = None) -> Future:
        raise not_implemented("AsyncParameterClient.describe_parameters")

    def get_parameter_types(self, names: list[str], callback: Any = None) -> Future:
        raise not_implemented("AsyncParameterClient.get_parameter_types")

    def delete_parameters(self, names: list[str], callback: Any = None) -> Future:
        raise not_implemented("AsyncParameterClient.delete_parameters")

    def load_parameter_file(self, parameter_file: str, use_wildcard: bool = False, callback: Any = None) -> Future:
        from nodes.core.params import load_params_file

        node_name = self.remote_node_name.rsplit("/", 1)[-1]
        values = load_params_file(parameter_file, node_name)
        return self.set_parameters([Parameter(n, value=v) for n, v in values.items() if not isinstance(v, dict)],
                                   callback)

    def destroy(self) -> None:
        self._node._zr.destroy_entity(self._get)
        self._node._zr.destroy_entity(self._set)
