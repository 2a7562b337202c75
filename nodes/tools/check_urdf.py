"""``zenroid check_urdf FILE [name:=value ...]``: validate a URDF (or xacro) and print its link tree.

Output follows the ROS ``check_urdf`` tool: robot name, root link, then each link's children, indented.
Exit 0 when the model is usable (warnings go to stderr), 2 with a one-line reason when it is not.
"""

from __future__ import annotations

import argparse
import sys

from nodes.tools.cli import UsageError
from nodes.urdf import RobotModel, UrdfError, load_robot_description, parse_urdf, parse_xacro_args, validate


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", help="URDF or .xacro file")
    parser.add_argument("xacro_args", nargs="*", metavar="name:=value", help="xacro arguments")
    parser.add_argument("-q", "--quiet", action="store_true", help="no tree, only problems")


def format_tree(model: RobotModel) -> list[str]:
    lines = [f"robot name is: {model.name}", "---------- Successfully Parsed XML ---------------"]
    root = model.root
    children = model.children_of(root)
    lines.append(f"root Link: {root} has {len(children)} child(ren)")

    def walk(link: str, depth: int) -> None:
        for index, joint in enumerate(model.children_of(link), start=1):
            lines.append(f"{'    ' * depth}child({index}):  {joint.child}")
            walk(joint.child, depth + 1)

    walk(root, 1)
    return lines


def run(args: argparse.Namespace) -> int:
    try:
        xml = load_robot_description(args.file, xacro_args=parse_xacro_args(args.xacro_args))
        model = parse_urdf(xml)
    except UrdfError as exc:
        raise UsageError(f"{args.file}: {exc}") from None
    issues = validate(model)
    errors = [i for i in issues if i.severity == "error"]
    if errors:
        more = f" (and {len(errors) - 1} more)" if len(errors) > 1 else ""
        raise UsageError(f"{args.file}: {errors[0].message}{more}")
    for warning in issues:
        print(f"warning: {warning.message}", file=sys.stderr)
    if not args.quiet:
        print("\n".join(format_tree(model)))
    return 0
