"""``python -m launch_ros.lifecycle_change NODE TRANSITION... [--timeout S]``: what ``EmitEvent(ChangeState(...))``
runs. Waits for the lifecycle node's ``change_state`` service (launch_ros waits for it too: the node may still be
starting), triggers each transition in turn and prints ``lifecycle transition: NODE TRANSITION START -> GOAL`` after
each, the line ``OnStateTransition`` handlers react to. Exit status 1, with the reason, when the node never answers or refuses."""

from __future__ import annotations

import argparse
import sys
import time

from msgs.lifecycle_msgs import ChangeState, GetState, Transition
from nodes.core import Node, ServiceError
from nodes.core.endpoints import Client


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="launch_ros.lifecycle_change")
    parser.add_argument("node", help="the lifecycle node's fully qualified name")
    parser.add_argument("transitions", nargs="+", metavar="TRANSITION",
                        help="configure, activate, deactivate, cleanup, shutdown")
    parser.add_argument("--timeout", type=float, default=120.0, help="s to wait for the node's services")
    args = parser.parse_args(argv)
    base = args.node.strip("/")
    node = Node(f"launch_lifecycle_change_{int(time.monotonic() * 1000) % 100000}", log_level="warn")
    try:
        get_state = Client(node, GetState, f"{base}/get_state")
        change = Client(node, ChangeState, f"{base}/change_state")
        if not change.wait_for_service(args.timeout):
            print(f"{args.node}: no change_state service after {args.timeout:g} s (is it a lifecycle node?)",
                  flush=True)
            return 1
        for transition in args.transitions:
            try:
                start = get_state.call(timeout=10.0).current_state.label
                ok = change.call(ChangeState.Request(transition=Transition(label=transition)), timeout=60.0).success
                goal = get_state.call(timeout=10.0).current_state.label
            except ServiceError as exc:
                print(f"{args.node}: {exc}", flush=True)
                return 1
            if not ok:
                print(f"{args.node}: transition '{transition}' refused in state '{start}'", flush=True)
                return 1
            print(f"lifecycle transition: /{base} {transition} {start} -> {goal}", flush=True)
        return 0
    finally:
        node.destroy()


if __name__ == "__main__":
    sys.exit(main())
