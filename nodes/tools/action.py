"""``zenroid action``: list and send_goal (with --feedback)."""

from __future__ import annotations

import argparse
import threading
from typing import Any

import msgs
from nodes.core.action import STATUS_NAMES, ActionClient
from nodes.tools.common import (
    add_list_verb,
    add_verb,
    calling,
    endpoints_at,
    key_of,
    print_endpoints,
    typed_request,
    write_line,
    write_message,
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="cmd", required=True)
    add_list_verb(sub, "action servers")
    add_verb(sub, "info", "an action's servers and clients", "key", ("-t", "--show-types", {"action": "store_true"}))
    add_verb(sub, "send_goal", "send a goal given as YAML and wait for the result", "key",
             ("type", {"help": "e.g. control_msgs/action/FollowJointTrajectory"}),
             ("values", {"nargs": "?", "default": "{}"}),
             ("-f", "--feedback", {"action": "store_true", "help": "print feedback"}),
             ("--timeout", {"type": float, "default": 60.0, "help": "seconds to wait for the result"}))


def run(args: argparse.Namespace) -> int:
    if args.cmd == "list":
        return print_endpoints(args, "act", "action")
    if args.cmd == "info":
        return _info(args)
    action, goal, key = typed_request(args, msgs.Action)
    finished = threading.Event()
    outcome: dict[str, Any] = {}

    def on_feedback(feedback: Any) -> None:  # on a Zenoh thread: a closed pipe is handed to the main thread
        try:
            write_message("Feedback:", feedback)
        except BrokenPipeError as exc:
            outcome.setdefault("error", exc)
            finished.set()

    with calling(args, "action", "act", f"no action server for '{key}'") as node:
        client = ActionClient(node, action, key)
        write_line("Waiting for an action server to become available...")
        handle = client.send_goal(goal, feedback_callback=on_feedback if args.feedback else None, timeout=5.0)
        if not handle.accepted:
            write_line("Goal was rejected.")
            return 1
        write_line(f"Goal accepted with ID: {handle.goal_id.hex()}")

        def wait_for_result() -> None:
            try:
                outcome.setdefault("result", handle.get_result(timeout=args.timeout))
            except Exception as exc:  # noqa: BLE001 - handed to the main thread
                outcome.setdefault("error", exc)
            finally:
                finished.set()

        threading.Thread(target=wait_for_result, daemon=True, name="get_result").start()
        while not finished.wait(0.1):
            pass
        if "result" not in outcome:
            raise outcome["error"]
        status, result = outcome["result"]
    write_message("Result:", result)
    write_line(f"Goal finished with status: {STATUS_NAMES.get(status, status)}")
    return 0 if status == 4 else 1


def _info(args: argparse.Namespace) -> int:
    """``ros2 action info``: who serves the action and who uses it."""
    key = key_of(args.key)
    mine = endpoints_at(args, "action", key, ("act", "actc"), f"no action server or client for '{key}'")
    write_line(f"Action: /{key}")
    for kind, title in (("actc", "Action clients"), ("act", "Action servers")):
        found = sorted({(e.node, e.type_name) for e in mine if e.kind == kind})
        write_line(f"{title}: {len(found)}")
        for name, type_name in found:
            write_line(f"    {name} [{type_name}]" if args.show_types else f"    {name}")
    return 0
