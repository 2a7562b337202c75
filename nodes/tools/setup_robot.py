"""``zenroid setup_robot FILE -o DIR [name:=value ...]``: a robot's ros2_control block and controllers file.

What MoveIt Setup Assistant's ros2_control step writes for a ROS user, from the URDF alone
(nodes/urdf/control_setup.py): the URDF with the block (its own when it has one), the block alone and the
controllers configuration. The main job generates the same files for a robot without a block.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from nodes.tools.cli import UsageError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", help="URDF or .xacro file")
    parser.add_argument("xacro_args", nargs="*", metavar="name:=value", help="xacro arguments")
    parser.add_argument("-o", "--output", required=True, help="folder to write the files into")
    parser.add_argument("--per-limb", action="store_true",
                        help="also one trajectory controller per limb (legs, arms, torso: by joint names)")


def run(args: argparse.Namespace) -> int:
    from nodes.sim.robot_files import ConfigError, checked_robot
    from nodes.urdf import UrdfError, load_robot_description, parse_xacro_args
    from nodes.urdf.control_setup import write_setup

    path = Path(args.file)
    try:
        if args.xacro_args:
            xml = load_robot_description(path, xacro_args=parse_xacro_args(args.xacro_args))
            from nodes.urdf import parse_urdf

            model = parse_urdf(xml)
        else:
            model, xml = checked_robot(path)
    except (ConfigError, UrdfError) as exc:
        raise UsageError(f"{args.file}: {exc}") from None
    written = write_setup(model, xml, Path(args.output), per_limb=args.per_limb)
    print(written.describe(model, generated_block=not model.ros2_control))
    return 0
