"""``zenroid action``: list and send_goal (with --feedback)."""

from __future__ import annotations

import argparse
import sys

import msgs
from nodes.core import ServiceError
from nodes.core.action import STATUS_NAMES, ActionClient
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
    p = sub.add_parser("list", help="action servers")
    p.add_argument("-t", "--show-types", action="store_true")
    add_common(p)
    p = sub.add_parser("send_goal", help="send a goal given as YAML and wait for the result")
    p.add_argument("key")
    p.add_argument("type", help="e.g. control_msgs/action/FollowJointTrajectory")
    p.add_argument("values", nargs="?", default="{}")
    p.add_argument("-f", "--feedback", action="store_true", help="print feedback")
    p.add_argument("--timeout", type=float, default=60.0, help="seconds to wait for the result")
    add_common(p)


def run(args: argparse.Namespace) -> int:
    if args.cmd == "list":
        return print_endpoints(args, "act", "action")
    action = resolve_type(args.type)
    if not isinstance(action, msgs.Action):
        raise UsageError(f"'{args.type}' is not an action type")
    goal = message_from_yaml(action.Goal, args.values)
    node = cli_node(args, "action")
    try:
        client = ActionClient(node, action, key_of(args.key))
        on_feedback = (lambda fb: print("Feedback:\n" + to_yaml(msgs.to_dict(fb)), flush=True)) if args.feedback else None
        print("Waiting for an action server to become available...", flush=True)
        handle = client.send_goal(goal, feedback_callback=on_feedback, timeout=5.0)
        if not handle.accepted:
            print("Goal was rejected.")
            return 1
        print(f"Goal accepted with ID: {handle.goal_id.hex()}", flush=True)
        status, result = handle.get_result(timeout=args.timeout)
    except ServiceError as exc:
        print(f"zenroid action send_goal: {exc}", file=sys.stderr)
        return 1
    finally:
        node.destroy()
    print("Result:\n" + to_yaml(msgs.to_dict(result)))
    print(f"Goal finished with status: {STATUS_NAMES.get(status, status)}")
    return 0 if status == 4 else 1
