"""``zenroid lifecycle``: nodes, get, list (available transitions) and set of managed nodes (``ros2 lifecycle``)."""

from __future__ import annotations

import argparse

from msgs.lifecycle_msgs import ChangeState, Transition
from msgs.lifecycle_msgs import GetState as _GetState
from nodes.core import ServiceError
from nodes.core.endpoints import Client
from nodes.core.lifecycle import STATE_LABELS, TRANSITIONS
from nodes.tools.common import add_verb, cli_node, require_node, snapshot, write_line
from nodes.tools.errors import Failed, UsageError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="cmd", required=True)
    add_verb(sub, "nodes", "the lifecycle (managed) nodes that are running")
    add_verb(sub, "get", "a node's current state", "node")
    add_verb(sub, "list", "the transitions available from the node's current state", "node")
    add_verb(sub, "set", "trigger a transition", "node",
             ("transition", {"help": "configure, activate, deactivate, cleanup, shutdown"}))


def run(args: argparse.Namespace) -> int:
    if args.cmd == "set" and args.transition not in {t[0] for t in TRANSITIONS.values()}:
        raise UsageError(f"unknown transition '{args.transition}' (choose from "
                         f"{', '.join(sorted({t[0] for t in TRANSITIONS.values()}))})")
    node = cli_node(args, "lifecycle")
    try:
        if args.cmd == "nodes":
            managed = sorted({e.node for e in snapshot(node) if e.kind == "srv" and e.name.endswith("/get_state")
                              and e.type_name == "lifecycle_msgs/srv/GetState"})
            for name in managed:
                write_line(name)
            return 0
        target = require_node(node, args.node)
        base = target.lstrip("/")
        try:
            if args.cmd in ("get", "list"):
                state = Client(node, _GetState, f"{base}/get_state").call().current_state
                if args.cmd == "get":
                    write_line(f"{state.label} [{state.id}]")
                    return 0
                for tid, (label, sources, _, goal) in TRANSITIONS.items():
                    if state.id in sources:
                        write_line(f"- {label} [{tid}]\n\tStart: {state.label}\n\tGoal: {STATE_LABELS[goal]}")
                return 0
            ok = Client(node, ChangeState, f"{base}/change_state").call(
                ChangeState.Request(transition=Transition(label=args.transition))).success
        except ServiceError as exc:
            raise Failed(f"{target} is not a lifecycle node or does not answer: {exc}") from None
    finally:
        node.destroy()
    if not ok:
        raise Failed(f"Transitioning failed: '{args.transition}' is not possible from the current state of {target} "
                     f"(see `zenroid lifecycle list {target}`) or the node refused it (see its log)")
    write_line("Transitioning successful")
    return 0
