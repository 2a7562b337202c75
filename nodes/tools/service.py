"""``zenroid service``: list and call."""

from __future__ import annotations

import argparse

import msgs
from nodes.core.endpoints import Client
from nodes.tools import common


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="cmd", required=True)
    common.add_list_verb(sub, "services offered by running nodes")
    common.add_verb(sub, "type", "the type of a service", "key")
    common.add_verb(sub, "call", "call a service with a YAML request", "key", ("type", {"help": "e.g. std_srvs/srv/Trigger"}),
             ("values", {"nargs": "?", "default": "{}"}), ("--timeout", {"type": float, "default": 5.0}))


def run(args: argparse.Namespace) -> int:
    if args.cmd == "list":
        return common.print_endpoints(args, "srv", "service")
    if args.cmd == "type":
        return _type(args)
    srv, request, key = common.typed_request(args, msgs.Service)
    with common.calling(args, "service", "srv", f"no service '{key}' is offered") as node:
        print(f"requester: making request: {request}", flush=True)
        response = Client(node, srv, key).call(request, timeout=args.timeout)
    common.write_message("response:", response)
    return 0


def _type(args: argparse.Namespace) -> int:
    key = common.key_of(args.key)
    common.write_line(common.endpoints_at(args, "service", key, ("srv",), f"no service '{key}' is offered")[0].type_name)
    return 0
