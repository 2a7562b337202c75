"""``zenroid node``: list and info, from the liveliness graph."""

from __future__ import annotations

import argparse

from nodes.tools.common import add_verb, graph_entries, is_cli_node, suggest, write_line
from nodes.tools.errors import Failed

_SECTIONS = (("pub", "Publishers"), ("sub", "Subscribers"), ("srv", "Service Servers"), ("cli", "Service Clients"),
             ("act", "Action Servers"), ("actc", "Action Clients"))


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="cmd", required=True)
    add_verb(sub, "list", "running nodes",
             ("-a", "--all", {"action": "store_true", "help": "include zenroid CLI helper nodes"}))
    add_verb(sub, "info", "a node's endpoints",
             ("node", {"help": "fully qualified node name, e.g. /humanoid/controller_manager"}))


def run(args: argparse.Namespace) -> int:
    entries = graph_entries(args, "node")
    if args.cmd == "list":
        names = sorted({e.node for e in entries if e.kind == "node"})
        for name in names:
            if args.all or not is_cli_node(name):
                write_line(name)
        return 0
    target = "/" + args.node.strip("/")
    mine = [e for e in entries if e.node == target]
    if not mine:
        others = [e.node for e in entries if e.kind == "node" and not is_cli_node(e.node)]
        hint = suggest(target, others, prefix="/")
        raise Failed(f"no node '{target}' is running{hint or ' (see `zenroid node list`)'}")
    write_line(target)
    for kind, title in _SECTIONS:
        write_line(f"  {title}:")
        for e in sorted({(e.name, e.type_name) for e in mine if e.kind == kind}):
            write_line(f"    /{e[0]}: {e[1]}")
    return 0
