"""``zenroid param``: list, get and set parameters of a running node."""

from __future__ import annotations

import argparse
import sys

import msgs
from nodes.core import ServiceError
from nodes.core.endpoints import Client
from nodes.tools.common import add_common, cli_node

_Get = msgs.get_type("zenroid_msgs/srv/GetParameters")
_Set = msgs.get_type("zenroid_msgs/srv/SetParameters")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("list")
    p.add_argument("node")
    add_common(p)
    p = sub.add_parser("get")
    p.add_argument("node")
    p.add_argument("name")
    add_common(p)
    p = sub.add_parser("set")
    p.add_argument("node")
    p.add_argument("name")
    p.add_argument("value", help="YAML value")
    add_common(p)


def run(args: argparse.Namespace) -> int:
    base = args.node.strip("/")
    node = cli_node(args, "param")
    try:
        if args.cmd == "set":
            response = Client(node, _Set, f"{base}/set_parameters").call(
                _Set.Request(names=[args.name], values_yaml=[args.value]))
            if response.successful and response.successful[0]:
                print("Set parameter successful")
                return 0
            print(f"Setting parameter failed: {response.reasons[0] if response.reasons else 'unknown'}")
            return 1
        names = [] if args.cmd == "list" else [args.name]
        response = Client(node, _Get, f"{base}/get_parameters").call(_Get.Request(names=names))
    except ServiceError as exc:
        print(f"zenroid param: {exc}", file=sys.stderr)
        return 1
    finally:
        node.destroy()
    if args.cmd == "get":
        if not response.names:
            print(f"Parameter not set: {args.name}")
            return 1
        print(f"{response.values_yaml[0]}")
        return 0
    print(f"/{base}:")
    for name, value in zip(response.names, response.values_yaml):
        print(f"  {name}: {value}")
    return 0
