"""A ROS 2 node played by zenoh-ros2-sdk (an independent rmw_zenoh client; nothing of zenroid is imported):
``listen TOPIC TYPE DEFINITION HASH SECONDS`` prints each message as a JSON line; ``talk TOPIC TYPE
DEFINITION HASH FIELDS_JSON SECONDS`` publishes the message every 0.1 s; ``call SERVICE TYPE REQUEST_DEF
RESPONSE_DEF HASH FIELDS_JSON`` prints the response as a JSON line."""

from __future__ import annotations

import dataclasses
import json
import sys
import time

from zenoh_ros2_sdk import ROS2Publisher, ROS2ServiceClient, ROS2Subscriber


def plain(value):
    if dataclasses.is_dataclass(value):
        return {f.name: plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    return value


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
    print(f"unknown mode {mode}", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
