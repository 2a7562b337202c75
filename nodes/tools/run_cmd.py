"""``zenroid run FILE [ARGS ...]``: run a ROS 2 Python program (rclpy) on zenroid, as ``python FILE`` would;
``zenroid run PKG EXEC [ARGS ...]``: a package's executable (``ros2 run``)."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from nodes.tools.cli import UsageError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("target", help="a Python program file, or a package name followed by an executable")
    parser.add_argument("args", nargs=argparse.REMAINDER,
                        help="the program's arguments (--ros-args -r/-p/--params-file/--log-level ...)")


def run(args: argparse.Namespace) -> int:
    target = Path(args.target)
    if target.is_file():
        from rclpy.runner import run_file

        return run_file(target, list(args.args))
    if target.suffix == ".py" or os.sep in args.target:
        raise UsageError(f"no such program file: {args.target}")
    if not args.args:
        raise UsageError(f"'{args.target}' is not a file; to run a package's executable give PKG EXEC")
    try:
        from nodes.packages import find_executable
    except ImportError:
        raise UsageError(f"no such program file: {args.target}") from None
    try:
        executable = find_executable(args.target, args.args[0])
    except (KeyError, LookupError) as exc:
        raise UsageError(str(exc).strip("'\"")) from None
    command = executable.command(list(args.args[1:]))
    sys.stdout.flush()
    os.execvp(command[0], command)
    return 0   # not reached
