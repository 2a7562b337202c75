"""``zenroid service``: list and call."""

from __future__ import annotations

import argparse
import sys

import msgs
from nodes.core import ServiceError
from nodes.core.endpoints import Client
from nodes.tools.cli import UsageError
from nodes.tools.common import (
    add_common,
    cli_node,
    key_of,
    message_from_yaml,
    print_endpoints,
    resolve_type,
    to_yaml,
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("list", help="services offered by running nodes")
    p.add_argument("-t", "--show-types", action="store_true")
    add_common(p)
    p = sub.add_parser("call", help="call a service with a YAML request")
    p.add_argument("key")
    p.add_argument("type", help="e.g. std_srvs/srv/Trigger")
    p.add_argument("values", nargs="?", default="{}")
    p.add_argument("--timeout", type=float, default=5.0)
    add_common(p)


def run(args: argparse.Namespace) -> int:
    if args.cmd == "list":
        return print_endpoints(args, "srv", "service")
    srv = resolve_type(args.type)
    if not isinstance(srv, msgs.Service):
        raise UsageError(f"'{args.type}' is not a service type")
    request = message_from_yaml(srv.Request, args.values)
    node = cli_node(args, "service")
    try:
        print(f"requester: making request: {request}", flush=True)
        response = Client(node, srv, key_of(args.key)).call(request, timeout=args.timeout)
    except ServiceError as exc:
        print(f"zenroid service call: {exc}", file=sys.stderr)
        return 1
    finally:
        node.destroy()
    print("response:")
    print(to_yaml(msgs.to_dict(response)))
    return 0
