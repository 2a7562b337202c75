"""``zenroid lifecycle``: get and set the state of a managed node."""

from __future__ import annotations

import argparse
import sys

import msgs
from nodes.core import ServiceError
from nodes.core.endpoints import Client
from nodes.core.lifecycle import TRANSITIONS
from nodes.tools.cli import UsageError
from nodes.tools.common import add_common, cli_node

_GetState = msgs.get_type("lifecycle_msgs/srv/GetState")
_ChangeState = msgs.get_type("lifecycle_msgs/srv/ChangeState")
_Transition = msgs.get_type("lifecycle_msgs/msg/Transition")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("get")
    p.add_argument("node")
    add_common(p)
    p = sub.add_parser("set")
    p.add_argument("node")
    p.add_argument("transition", help="configure, activate, deactivate, cleanup, shutdown")
    add_common(p)


def run(args: argparse.Namespace) -> int:
    base = args.node.strip("/")
    if args.cmd == "set" and args.transition not in {t[0] for t in TRANSITIONS.values()}:
        raise UsageError(f"unknown transition '{args.transition}'")
    node = cli_node(args, "lifecycle")
    try:
        if args.cmd == "get":
            state = Client(node, _GetState, f"{base}/get_state").call().current_state
            print(f"{state.label} [{state.id}]")
            return 0
        ok = Client(node, _ChangeState, f"{base}/change_state").call(
            _ChangeState.Request(transition=_Transition(label=args.transition))).success
    except ServiceError as exc:
        print(f"zenroid lifecycle: {exc}", file=sys.stderr)
        return 1
    finally:
        node.destroy()
    print("Transitioning successful" if ok else "Transitioning failed")
    return 0 if ok else 1
