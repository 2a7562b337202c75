"""``zenroid run PKG EXEC [args]`` (``ros2 run``): a package's executable, found through the package index
(docs/packages.md); ``zenroid run FILE [args]`` runs a ROS 2 Python program (rclpy) on zenroid, as
``python FILE`` would.

The executable replaces this process (as ``ros2 run``'s does in effect): Ctrl-C and the exit status are its own.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import nodes
from nodes.packages import ExecutableNotFoundError, PackageNotFoundError, find_executable
from nodes.tools.errors import Failed, UsageError

# The folder holding this distribution's top-level modules (rclpy, ament_index_python ...) for child processes.
OUR_ROOT = str(Path(nodes.__file__).resolve().parent.parent)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("package", metavar="PKG_OR_FILE", help="package name, or a Python file to run")
    parser.add_argument("rest", nargs=argparse.REMAINDER, metavar="EXEC [args]",
                        help="the executable and its arguments (--ros-args ... included)")
    parser.add_argument("--prefix", help="a command to run it under (e.g. 'gdb -ex run --args'): split on spaces")


def child_environment() -> dict[str, str]:
    """This environment, with our top-level modules reachable after whatever PYTHONPATH already has: where
    ROS 2 is sourced its own rclpy stays first, as intended (DESIGN §11)."""
    env = dict(os.environ)
    paths = [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p]
    if OUR_ROOT not in paths:
        paths.append(OUR_ROOT)
    env["PYTHONPATH"] = os.pathsep.join(paths)
    return env


def _exec(argv: list[str], prefix: str | None) -> int:
    argv = [*(prefix.split() if prefix else []), *argv]
    sys.stdout.flush()
    sys.stderr.flush()
    try:
        os.execvpe(argv[0], argv, child_environment())
    except OSError as exc:
        raise Failed(f"cannot start {argv[0]}: {exc}") from None
    return 0  # not reached


def run(args: argparse.Namespace) -> int:
    target = args.package
    if Path(target).is_file():
        from rclpy.runner import run_file  # the rclpy face's runner: our rclpy, in this process

        return int(run_file(Path(target), list(args.rest)) or 0)
    if target.endswith(".py") or os.sep in target:
        raise UsageError(f"no such program file: {target}")
    if not args.rest:
        raise UsageError(f"'{target}' is not a file; to run a package's executable give PKG EXEC "
                         f"(zenroid pkg executables {target} lists them)")
    name, rest = args.rest[0], args.rest[1:]
    try:
        executable = find_executable(target, name)
    except (PackageNotFoundError, ExecutableNotFoundError) as exc:
        raise Failed(str(exc)) from None
    return _exec(executable.command(rest), args.prefix)
