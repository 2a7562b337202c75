"""``zenroid xacro FILE [name:=value ...] [-o OUT]``: expand a xacro file to URDF (no ROS needed)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from nodes.tools.cli import UsageError
from nodes.urdf import UrdfError, load_robot_description, parse_xacro_args


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", help=".xacro (or plain URDF) file")
    parser.add_argument("xacro_args", nargs="*", metavar="name:=value", help="xacro arguments")
    parser.add_argument("-o", "--output", help="write the URDF to this file instead of stdout")


def run(args: argparse.Namespace) -> int:
    try:
        urdf = load_robot_description(args.file, xacro_args=parse_xacro_args(args.xacro_args))
    except UrdfError as exc:
        raise UsageError(str(exc)) from None
    if args.output:
        try:
            Path(args.output).write_text(urdf, encoding="utf-8")
        except OSError as exc:
            raise UsageError(f"cannot write '{args.output}': {exc}") from None
    else:
        sys.stdout.write(urdf if urdf.endswith("\n") else urdf + "\n")
    return 0
