"""A ROS 2 node played by zenoh-ros2-sdk (an independent rmw_zenoh client; nothing of zenroid is imported):
``listen TOPIC TYPE DEFINITION HASH SECONDS`` prints each message as a JSON line; ``talk TOPIC TYPE
DEFINITION HASH FIELDS_JSON SECONDS`` publishes the message every 0.1 s; ``call SERVICE TYPE REQUEST_DEF
RESPONSE_DEF HASH FIELDS_JSON`` prints the response as a JSON line; ``param DEFINITIONS NODE REQUESTS_JSON
[HASHES_JSON]`` calls a node's rcl_interfaces parameter services as ``ros2 param`` does and prints each
response as a JSON line. DEFINITIONS is a folder of rcl_interfaces' upstream .msg/.srv files: the peer builds
the message types and computes the type hashes from them itself, except for the services HASHES_JSON names
(``{"DescribeParameters": "RIHS01_..."}``). Each request is ``["get", [names]]``, ``["types", [names]]``,
``["describe", [names]]``, ``["list", [prefixes], depth]``, ``["set", [[name, type, value], ...]]`` or
``["set_atomically", [[name, type, value], ...]]`` (type: rcl_interfaces/ParameterType's number).
``param_server DEFINITIONS NODE PARAMETERS_JSON SECONDS [HASHES_JSON]`` plays a ROS 2 node's six parameter
services for SECONDS (PARAMETERS_JSON: ``{name: [type, value]}``; a set of a known name with its type is
applied, anything else refused) and prints each applied set as a JSON line. ``info TOPIC`` prints each
publisher and subscription of the topic with the QoS its liveliness token announces (``ros2 topic info -v``),
a JSON line each."""

from __future__ import annotations

import dataclasses
import json
import re
import sys
import time
from pathlib import Path

from zenoh_ros2_sdk import ROS2Publisher, ROS2ServiceClient, ROS2ServiceServer, ROS2Subscriber
from zenoh_ros2_sdk.discovery import get_topic_info
from zenoh_ros2_sdk.qos import QosProfile
from zenoh_ros2_sdk.utils import compute_service_type_hash


def plain(value):
    if dataclasses.is_dataclass(value):
        return {f.name: plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, bytes):
        return list(value)
    return value


_SERVICES = {"get": ("GetParameters", "get_parameters"), "types": ("GetParameterTypes", "get_parameter_types"),
             "describe": ("DescribeParameters", "describe_parameters"),
             "list": ("ListParameters", "list_parameters"), "set": ("SetParameters", "set_parameters"),
             "set_atomically": ("SetParametersAtomically", "set_parameters_atomically")}
_VALUE_FIELDS = [None, "bool_value", "integer_value", "double_value", "string_value", "byte_array_value",
                 "bool_array_value", "integer_array_value", "double_array_value", "string_array_value"]


def _strip(text: str) -> str:
    return "\n".join(line for line in text.splitlines() if line.strip() and not line.lstrip().startswith("#"))


def _used(definition: str, known: dict[str, str]) -> list[str]:
    """The rcl_interfaces messages a definition needs, transitively (each once, dependencies after)."""
    out: list[str] = []
    todo = [definition]
    while todo:
        for line in todo.pop().splitlines():
            base = re.split(r"[\[<]", line.split()[0])[0] if line.split() else ""
            if base in known and base not in out:
                out.append(base)
                todo.append(known[base])
    return out


def _qualified(definition: str, known: dict[str, str]) -> str:
    """Field types of the package spelled ``rcl_interfaces/Name`` (a service's own parts would otherwise
    look for them under ``srv``)."""
    return "\n".join(f"rcl_interfaces/{line}" if line.split() and re.split(r"[\[<]", line.split()[0])[0] in known
                     else line for line in definition.splitlines())


def _full(definition: str, known: dict[str, str]) -> str:
    """A definition followed by its dependencies' (``MSG: pkg/Name``), as ROS 2 bags store them."""
    parts = [_qualified(definition, known)]
    for name in _used(definition, known):
        parts.append("=" * 80 + f"\nMSG: rcl_interfaces/{name}\n{_qualified(known[name], known)}")
    return "\n".join(parts) + "\n"


def _service_args(definitions: Path, srv: str, hashes: dict) -> dict:
    """Definitions (with their dependencies) and type hash of one rcl_interfaces service."""
    known = {p.stem: _strip(p.read_text()) for p in sorted((definitions / "msg").glob("*.msg"))}
    request_def, response_def = (_strip(part) for part in
                                 (definitions / "srv" / f"{srv}.srv").read_text().split("---", 1))
    type_hash = hashes.get(srv) or compute_service_type_hash(
        f"rcl_interfaces/srv/{srv}", request_def, response_def,
        dependencies={f"rcl_interfaces/msg/{n}": known[n] for n in known})
    return {"request_definition": _full(request_def, known), "response_definition": _full(response_def, known),
            "type_hash": type_hash}


def _parameter_value(types: dict, ptype: int, value) -> object:
    import numpy as np

    fields = dict(type=ptype, bool_value=False, integer_value=0, double_value=0.0, string_value="",
                  byte_array_value=np.array([], np.uint8), bool_array_value=np.array([], bool),
                  integer_array_value=np.array([], np.int64), double_array_value=np.array([], np.float64),
                  string_array_value=[])
    field = _VALUE_FIELDS[ptype]
    if field is not None:
        kind = {5: np.uint8, 6: bool, 7: np.int64, 8: np.float64}.get(ptype)
        fields[field] = np.array(value, kind) if kind is not None else value
    return types["rcl_interfaces/msg/ParameterValue"](**fields)


def call_parameter_services(common: dict, definitions: Path, node: str, requests: list, hashes: dict) -> None:
    clients: dict[str, ROS2ServiceClient] = {}
    for op, *args in requests:
        srv, service = _SERVICES[op]
        if op not in clients:
            clients[op] = ROS2ServiceClient(f"{node}/{service}", f"rcl_interfaces/srv/{srv}", timeout=20.0,
                                            **_service_args(definitions, srv, hashes), **common)
        client = clients[op]
        if op in ("get", "types", "describe"):
            response = client.call(names=list(args[0]))
        elif op == "list":
            response = client.call(prefixes=list(args[0]), depth=int(args[1]))
        else:
            types = client.session_mgr.store.types
            parameter_cls = types["rcl_interfaces/msg/Parameter"]
            response = client.call(parameters=[parameter_cls(name=name, value=_parameter_value(types, ptype, value))
                                               for name, ptype, value in args[0]])
        if response is None:
            raise SystemExit(f"no response from {node}/{service}")
        print(json.dumps({"op": op, "response": plain(response)}), flush=True)


def serve_parameters(common: dict, definitions: Path, node: str, parameters: dict, hashes: dict) -> list:
    """A ROS 2 node's six parameter services over ``parameters`` ({name: [type, value]})."""
    namespace, _, name = node.rpartition("/")
    servers: list[ROS2ServiceServer] = []

    def make(srv: str, service: str, answer) -> None:
        made: list[ROS2ServiceServer] = []

        def respond(request):
            server = made[0]
            return server.response_msg_class(**answer(request, server.session_mgr.store.types))

        made.append(ROS2ServiceServer(f"{node}/{service}", f"rcl_interfaces/srv/{srv}", callback=respond,
                                      node_name=name, namespace=namespace or "/",
                                      **_service_args(definitions, srv, hashes), **common))
        servers.append(made[0])

    def result(types: dict, ok: bool, reason: str = "") -> object:
        return types["rcl_interfaces/msg/SetParametersResult"](successful=ok, reason=reason)

    def apply(p) -> tuple[bool, str]:
        ptype, value = int(p.value.type), plain(getattr(p.value, _VALUE_FIELDS[p.value.type] or "type"))
        if p.name not in parameters or parameters[p.name][0] != ptype:
            return False, f"{p.name}: not a {ptype} parameter of this node"
        parameters[p.name][1] = value
        print(json.dumps({"set": p.name, "value": value}), flush=True)
        return True, ""

    def values(request, types):
        if any(n not in parameters for n in request.names):
            return {"values": []}
        return {"values": [_parameter_value(types, *parameters[n]) for n in request.names]}

    def set_each(request, types):
        return {"results": [result(types, *apply(p)) for p in request.parameters]}

    def set_all(request, types):
        if any(p.name not in parameters or parameters[p.name][0] != p.value.type for p in request.parameters):
            return {"result": result(types, False, "refused: all or nothing")}
        for p in request.parameters:
            apply(p)
        return {"result": result(types, True)}

    def describe(request, types):
        return {"descriptors": [types["rcl_interfaces/msg/ParameterDescriptor"](
            name=n, type=parameters[n][0], description="played by zenoh-ros2-sdk", additional_constraints="",
            read_only=False, dynamic_typing=False, floating_point_range=[], integer_range=[])
            for n in request.names if n in parameters]}

    def listed(request, types):
        return {"result": types["rcl_interfaces/msg/ListParametersResult"](names=sorted(parameters), prefixes=[])}

    import numpy as np

    make("GetParameters", "get_parameters", values)
    make("SetParameters", "set_parameters", set_each)
    make("SetParametersAtomically", "set_parameters_atomically", set_all)
    make("ListParameters", "list_parameters", listed)
    make("DescribeParameters", "describe_parameters", describe)
    make("GetParameterTypes", "get_parameter_types",
         lambda request, types: {"types": np.array([parameters[n][0] for n in request.names
                                                    if n in parameters], np.uint8)})
    return servers


def main(argv: list[str]) -> int:
    mode, port = argv[0], int(argv[1])
    common = {"router_ip": "127.0.0.1", "router_port": port, "domain_id": 0}
    if mode == "listen":
        topic, type_name, definition, type_hash, seconds = argv[2:7]
        sub = ROS2Subscriber(topic, type_name, lambda m: print(json.dumps(plain(m)), flush=True),
                             msg_definition=definition, type_hash=type_hash, **common)
        time.sleep(float(seconds))
        sub.close() if hasattr(sub, "close") else None
        return 0
    if mode == "talk":
        topic, type_name, definition, type_hash, fields, seconds = argv[2:8]
        pub = ROS2Publisher(topic, type_name, msg_definition=definition, type_hash=type_hash, **common)
        end = time.monotonic() + float(seconds)
        while time.monotonic() < end:
            pub.publish(**json.loads(fields))
            time.sleep(0.1)
        return 0
    if mode == "call":
        service, type_name, request_def, response_def, type_hash, fields = argv[2:8]
        client = ROS2ServiceClient(service, type_name, request_definition=request_def,
                                   response_definition=response_def, type_hash=type_hash, timeout=20.0, **common)
        response = client.call(**json.loads(fields))
        print(json.dumps(plain(response)), flush=True)
        return 0 if response is not None else 1
    if mode == "param_server":
        definitions, node, parameters, seconds = argv[2:6]
        hashes = json.loads(argv[6]) if len(argv) > 6 else {}
        servers = serve_parameters(common, Path(definitions), node, json.loads(parameters), hashes)
        time.sleep(float(seconds))
        for server in servers:
            server.close()
        return 0
    if mode == "param":
        definitions, node, requests = argv[2:5]
        hashes = json.loads(argv[5]) if len(argv) > 5 else {}
        call_parameter_services(common, Path(definitions), node, json.loads(requests), hashes)
        return 0
    if mode == "info":
        info = get_topic_info(argv[2], domain_id=0, router_port=port, timeout=2.0, verbose=True)
        for kind, endpoints in (("publisher", info.publishers if info else []),
                                ("subscription", info.subscribers if info else [])):
            for endpoint in endpoints:
                qos = QosProfile.decode(endpoint.qos)
                print(json.dumps({"kind": kind, "node": endpoint.node_name, "namespace": endpoint.node_namespace,
                                  "type": endpoint.topic_type, "qos": {
                                      "reliability": qos.reliability.name, "durability": qos.durability.name,
                                      "depth": qos.history_depth, "liveliness": qos.liveliness.name,
                                      "deadline": [qos.deadline.sec, qos.deadline.nsec],
                                      "lifespan": [qos.lifespan.sec, qos.lifespan.nsec],
                                      "lease": [qos.liveliness_lease_duration.sec,
                                                qos.liveliness_lease_duration.nsec]}}), flush=True)
        return 0
    print(f"unknown mode {mode}", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
