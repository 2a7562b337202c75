"""``zenroid graph``: who publishes and subscribes what (rqt_graph as text, or Graphviz dot)."""

from __future__ import annotations

import argparse
from collections import defaultdict

from nodes.core import graph
from nodes.tools.common import add_common, graph_entries


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--dot", action="store_true", help="print Graphviz dot instead of text")
    parser.add_argument("-a", "--all", action="store_true", help="include rosout, parameter_events, parameter services and CLI nodes")
    add_common(parser)


def run(args: argparse.Namespace) -> int:
    entries = graph_entries(args, "graph")

    def shown(e: graph.GraphEntry) -> bool:
        if args.all:
            return True
        return not e.node.lstrip("/").startswith("zenroid_") and e.name not in ("rosout", "parameter_events")

    pubs: dict[str, set[str]] = defaultdict(set)
    subs: dict[str, set[str]] = defaultdict(set)
    for e in filter(shown, entries):
        if e.kind == "pub":
            pubs[e.name].add(e.node)
        elif e.kind == "sub":
            subs[e.name].add(e.node)
    topics = sorted(set(pubs) | set(subs))
    if args.dot:
        print("digraph zenroid {\n  rankdir=LR;")
        for t in topics:
            print(f'  "/{t}" [shape=box];')
            for n in sorted(pubs[t]):
                print(f'  "{n}" -> "/{t}";')
            for n in sorted(subs[t]):
                print(f'  "/{t}" -> "{n}";')
        print("}")
        return 0
    for t in topics:
        print(f"/{t}")
        print(f"  publishers:  {', '.join(sorted(pubs[t])) or '-'}")
        print(f"  subscribers: {', '.join(sorted(subs[t])) or '-'}")
    return 0
