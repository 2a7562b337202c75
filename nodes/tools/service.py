"""``zenroid service``: list and call."""

from __future__ import annotations

import argparse

import msgs
from nodes.core import ServiceError
from nodes.core.endpoints import Client
from nodes.tools.common import (
    add_common,
    add_list_verb,
    call_failure,
    cli_node,
    interface_type,
    key_of,
    message_from_yaml,
    print_endpoints,
    snapshot_until,
    suggest,
    to_yaml,
    write_line,
)
from nodes.tools.errors import Failed


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="cmd", required=True)
    add_list_verb(sub, "services offered by running nodes")
    p = sub.add_parser("type", help="the type of a service")
    p.add_argument("key")
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
    if args.cmd == "type":
        return _type(args)
    srv = interface_type(args.type, msgs.Service)
    request = message_from_yaml(srv.Request, args.values)
    node = cli_node(args, "service")
    try:
        print(f"requester: making request: {request}", flush=True)
        response = Client(node, srv, key_of(args.key)).call(request, timeout=args.timeout)
    except ServiceError as exc:
        key = key_of(args.key)
        raise call_failure(node, "srv", key, exc, f"no service '{key}' is offered") from None
    finally:
        node.destroy()
    write_line("response:")
    write_line(to_yaml(msgs.to_dict(response)))
    return 0


def _type(args: argparse.Namespace) -> int:
    key = key_of(args.key)
    node = cli_node(args, "service")
    try:
        entries = snapshot_until(node, lambda es: any(e.kind == "srv" and e.name == key for e in es))
        servers = {e.name: e.type_name for e in entries if e.kind == "srv"}
    finally:
        node.destroy()
    if key not in servers:
        raise Failed(f"no service '{key}' is offered{suggest(key, servers)}")
    write_line(servers[key])
    return 0
