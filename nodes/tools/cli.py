"""``zenroid``: the ROS-style command line (docs/cli.md).

Each verb lives in its own module exposing ``add_arguments(parser)`` and ``run(args) -> int``; modules are
imported lazily so ``zenroid check_urdf`` never pays for zenoh or DART.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from nodes.tools.errors import Failed, UsageError

# verb -> (module, one-line help)
VERBS: dict[str, tuple[str, str]] = {
    "launch": ("nodes.tools.launch_cmd", "run a YAML launch file"),
    "topic": ("nodes.tools.topic", "list/echo/pub/hz/bw/info/type topics"),
    "node": ("nodes.tools.node_cmd", "list/info nodes"),
    "service": ("nodes.tools.service", "list/type/call services"),
    "action": ("nodes.tools.action", "list/info actions, send goals"),
    "control": ("nodes.tools.control", "controller manager commands and the spawner"),
    "lifecycle": ("nodes.tools.lifecycle", "nodes/get/list/set of lifecycle nodes"),
    "param": ("nodes.tools.param", "list/get/set/dump/load node parameters"),
    "log": ("nodes.tools.log_cmd", "print or change a running node's log level"),
    "spawn": ("nodes.tools.spawn", "spawn an entity in the simulator (spawn_entity.py)"),
    "sim": ("nodes.tools.sim", "pause/unpause/reset/step/gravity"),
    "check_urdf": ("nodes.tools.check_urdf", "validate a URDF and print its tree"),
    "xacro": ("nodes.tools.xacro_cmd", "expand a xacro file to URDF"),
    "setup_robot": ("nodes.tools.setup_robot", "write a robot's ros2_control block and controllers file"),
    "urdf_to_graphviz": ("nodes.tools.urdf_graph", "draw a URDF's link/joint tree (.gv, and .pdf with Graphviz)"),
    "urdf_to_graphiz": ("nodes.tools.urdf_graph", "the same (ROS's older spelling)"),
    "graph": ("nodes.tools.graph", "print the node graph"),
    "doctor": ("nodes.tools.doctor", "check the installation and the network"),
    "router": ("nodes.tools.router", "run a standalone Zenoh router (zenohd stand-in)"),
    "run": ("nodes.tools.run_cmd", "run a ROS 2 Python program (rclpy) or a package's executable"),
    "bag": ("nodes.tools.bag", "record/play/info bags"),
    "pkg": ("nodes.tools.pkg_cmd", "list packages, their prefix and executables"),
    "interface": ("nodes.tools.interface_cmd", "list and show message, service and action types"),
    "teleop": ("nodes.tools.teleop", "nudge a trajectory controller's joints from the keyboard"),
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="zenroid", description="ROS-style tools for the zenroid stack")
    sub = parser.add_subparsers(dest="verb", metavar="VERB")
    for verb, (_, help_text) in VERBS.items():
        sub.add_parser(verb, help=help_text, add_help=False)
    return parser


def main(argv: list[str] | None = None, prog: str = "zenroid") -> int:
    """Run one verb; ``prog`` is the name errors and usage give (``ros2`` when nodes/tools/ros2.py calls)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help") or argv[0] not in VERBS:
        parser = build_parser()
        if argv and argv[0] not in ("-h", "--help"):
            print(f"{prog}: unknown verb '{argv[0]}' (choose from {', '.join(VERBS)})", file=sys.stderr)
            return 2
        parser.print_help()
        return 0
    verb, rest = argv[0], argv[1:]
    module_name, help_text = VERBS[verb]
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        if exc.name and module_name.startswith(exc.name):
            print(f"{prog} {verb}: not available in this build", file=sys.stderr)
            return 2
        raise
    parser = argparse.ArgumentParser(prog=f"{prog} {verb}", description=help_text)
    module.add_arguments(parser)
    try:
        args = parser.parse_args(rest)
        return int(module.run(args) or 0)
    except UsageError as exc:
        print(f"{prog} {verb}: {exc}", file=sys.stderr)
        return 2
    except Failed as exc:
        print(f"{prog} {verb}: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        # `zenroid topic echo ... | head`: the reader left; exit quietly like other Unix tools
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


__all__ = ["VERBS", "Failed", "UsageError", "main"]

if __name__ == "__main__":
    sys.exit(main())
