"""``zenroid log``: a running node's log level (ROS 2: ``ros2 service call /node/set_logger_levels``).

    zenroid log level /humanoid/joint_commander            # prints: info
    zenroid log level /humanoid/joint_commander debug      # from now on debug lines too
"""

from __future__ import annotations

import argparse

from msgs.rcl_interfaces import GetLoggerLevels as _Get
from msgs.rcl_interfaces import LoggerLevel as _Level
from msgs.rcl_interfaces import SetLoggerLevels as _Set
from nodes.core import ServiceError
from nodes.core.log import NAMES, parse_level
from nodes.tools.common import Failed, add_verb, cli_node, require_node
from nodes.tools.errors import UsageError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="cmd", required=True)
    add_verb(sub, "level", "print or set a node's log level", ("node", {"help": "e.g. /humanoid/joint_commander"}),
             ("level", {"nargs": "?", "help": "debug, info, warn, error or fatal (omit to print the current one)"}))


def run(args: argparse.Namespace) -> int:
    level = None
    if args.level is not None:
        try:
            level = parse_level(args.level)
        except ValueError as exc:
            raise UsageError(str(exc)) from None
    node = cli_node(args, "log")
    try:
        target = require_node(node, args.node)
        logger_name = target.lstrip("/")
        try:
            if level is None:
                response = node.create_client(_Get, f"{target}/get_logger_levels").call(
                    _Get.Request(names=[logger_name]))
                print(NAMES.get(response.levels[0].level, str(response.levels[0].level)).lower())
                return 0
            response = node.create_client(_Set, f"{target}/set_logger_levels").call(
                _Set.Request(levels=[_Level(name=logger_name, level=level)]))
        except ServiceError as exc:
            raise Failed(str(exc)) from None
    finally:
        node.destroy()
    result = response.results[0] if response.results else None
    if result is None or not result.successful:
        raise Failed(f"log level of {target} not changed: {result.reason if result else 'no answer'}")
    print(f"{target}: log level {NAMES[level].lower()}")
    return 0
