"""``zenroid node``: list and info, from the liveliness graph."""

from __future__ import annotations

import argparse

from nodes.tools.common import add_common, graph_entries

_SECTIONS = (("pub", "Publishers"), ("sub", "Subscribers"), ("srv", "Service Servers"), ("cli", "Service Clients"),
             ("act", "Action Servers"), ("actc", "Action Clients"))


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("list", help="running nodes")
    p.add_argument("-a", "--all", action="store_true", help="include zenroid CLI helper nodes")
    add_common(p)
    p = sub.add_parser("info", help="a node's endpoints")
    p.add_argument("node", help="fully qualified node name, e.g. /humanoid/controller_manager")
    add_common(p)


def run(args: argparse.Namespace) -> int:
    entries = graph_entries(args, "node")
    if args.cmd == "list":
        names = sorted({e.node for e in entries if e.kind == "node"})
        for name in names:
            if args.all or not name.lstrip("/").startswith("zenroid_"):
                print(name)
        return 0
    target = "/" + args.node.strip("/")
    mine = [e for e in entries if e.node == target]
    if not mine:
        print(f"zenroid node info: no node '{target}' (see `zenroid node list`)")
        return 1
    print(target)
    for kind, title in _SECTIONS:
        print(f"  {title}:")
        for e in sorted({(e.name, e.type_name) for e in mine if e.kind == kind}):
            print(f"    /{e[0]}: {e[1]}")
    return 0
